// blendColors: Maya's blendColors utility, a per-component linear blend of two vector3 values (the
// usual IK/FK switch of joint rotations and translations).

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Color1, Color2, Blender, Output };

class BlendColorsNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const double w = context.getDouble(Blender);
        const Eigen::Vector3d out = context.getVector3(Color1) * w + context.getVector3(Color2) * (1.0 - w);
        context.setOutput(Output, out);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeBlendColorsType()
{
    NodeTypeBuilder b("blendColors");
    b.description(
        "Blends two vector3 values component by component: output = color1 * blender + color2 * (1 - blender) "
        "(Maya's blendColors node). The values are unitless: angles connected in arrive in degrees and leave "
        "as angles again when output drives an angle plug, so an IK/FK switch blends Euler angles linearly "
        "(not a slerp of the rotations).");
    b.input(Color1, "color1", ValueType::Vector3)
        .shortName("c1")
        .children("color1R", "color1G", "color1B")
        .defaultValue(Eigen::Vector3d(1, 0, 0))
        .keyable()
        .doc("The value output at blender = 1 (color1R, color1G, color1B); Maya's default red (1, 0, 0).");
    b.input(Color2, "color2", ValueType::Vector3)
        .shortName("c2")
        .children("color2R", "color2G", "color2B")
        .defaultValue(Eigen::Vector3d(0, 0, 1))
        .keyable()
        .doc("The value output at blender = 0 (color2R, color2G, color2B); Maya's default blue (0, 0, 1).");
    b.input(Blender, "blender", ValueType::Double)
        .shortName("b")
        .defaultValue(0.5)
        .range(0.0, 1.0)
        .keyable()
        .doc("Weight of color1, 0..1 (the IK/FK switch).");
    b.output(Output, "output", ValueType::Vector3)
        .shortName("op")
        .children("outputR", "outputG", "outputB")
        .doc("color1 * blender + color2 * (1 - blender) (outputR, outputG, outputB).");
    b.affects(Color1, {Output}).affects(Color2, {Output}).affects(Blender, {Output});
    b.factory<BlendColorsNode>();
    return b.build();
}

}  // namespace rig
