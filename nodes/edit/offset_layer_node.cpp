// offsetLayer: an additive rotation and translation on one joint's world matrix, in the joint's axes or
// in world axes, weighted (docs/nodes.md, "Editing a clip's skeleton").
#include "nodes/builtin_nodes.h"
#include "nodes/edit/skeleton_edit_math.h"
#include "nodes/enum_names.h"

namespace rig {
namespace {

enum Attr : AttrId { InMatrix, Rotate, RotateOrderAttr, Translate, Space, Weight, OutMatrix };

class OffsetLayerNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        const RotateOrder order = rotateOrderFromIndex(c.getEnum(RotateOrderAttr)).value_or(RotateOrder::xyz);
        const OffsetSpace space =
            c.getEnum(Space) == static_cast<int>(OffsetSpace::world) ? OffsetSpace::world : OffsetSpace::local;
        c.setOutput(OutMatrix, offsetMatrix(c.getMatrix(InMatrix), c.getVector3(Rotate), order, c.getVector3(Translate),
                                            space, c.getDouble(Weight)));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeOffsetLayerType()
{
    NodeTypeBuilder b("offsetLayer");
    b.description(
        "Adds a rotation and a translation to a joint's world matrix M, weighted: R_w turns by weight times "
        "the angle of R = eulerToMatrix(rotate, rotateOrder) about R's axis, t_w = weight * translate. space "
        "local: outMatrix = M * [R_w t_w; 0 1] (about the joint's origin in its own axes, the translation "
        "along them, the joint's scale included); space world: outMatrix = [R_w * M3 p + t_w; 0 1] (M3, p: "
        "M's 3x3 part and position; about the joint's position in world axes). weight 0 gives M exactly.");
    b.input(InMatrix, "inMatrix", ValueType::Matrix4)
        .doc("The joint's world matrix (connect a clip's worldMatrix[j]).");
    b.input(Rotate, "rotate", ValueType::Vector3)
        .unit(Unit::Angle)
        .keyable()
        .doc("The offset rotation as Euler angles, degrees, in rotateOrder.");
    b.input(RotateOrderAttr, "rotateOrder", ValueType::Enum)
        .enumNames(rotateOrderEnumNames())
        .doc("Order of the rotate angles (xyz: x applied first).");
    b.input(Translate, "translate", ValueType::Vector3)
        .unit(Unit::Distance)
        .keyable()
        .doc("The offset translation, cm.");
    b.input(Space, "space", ValueType::Enum)
        .enumNames({"local", "world"})
        .doc("local: in the joint's own axes; world: in world axes, about the joint's position.");
    b.input(Weight, "weight", ValueType::Double)
        .defaultValue(1.0)
        .range(0.0, 1.0)
        .keyable()
        .doc("0: inMatrix unchanged; 1: the whole offset. A connected value is clamped to 0..1.");
    b.output(OutMatrix, "outMatrix", ValueType::Matrix4).doc("The joint's edited world matrix.");
    for (AttrId in = InMatrix; in <= Weight; ++in) b.affects(in, {OutMatrix});
    return b.factory<OffsetLayerNode>().build();
}

}  // namespace rig
