// pairBlend: Maya's pairBlend, a weighted blend of two translations and two rotations (Maya creates one where a
// constraint and keys drive the same channels).

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"
#include "nodes/enum_names.h"
#include "nodes/math/rotation_blend.h"

namespace rig {
namespace {

enum Attr : AttrId {
    InTranslate1,
    InRotate1,
    InTranslate2,
    InRotate2,
    Weight,
    RotInterpolation,
    RotateOrder_,
    RotateMode,
    TranslateXMode,
    TranslateYMode,
    TranslateZMode,
    CurrentDriver,
    OutTranslate,
    OutRotate
};
enum Mode { BlendInputs, Input1Only, Input2Only };
enum Interpolation { Euler, Quaternion };

double pick(int mode, double a, double b, double w)
{
    if (mode == Input1Only) return a;
    if (mode == Input2Only) return b;
    return a + w * (b - a);
}

Eigen::Vector3d blendRotation(const ComputeContext& context, double w)
{
    const Eigen::Vector3d& r1 = context.getVector3(InRotate1);
    const Eigen::Vector3d& r2 = context.getVector3(InRotate2);
    const int mode = context.getEnum(RotateMode);
    // The ends pass an input through as written (at gimbal lock its Euler triple is not recoverable from the
    // rotation).
    if (mode == Input1Only || (mode == BlendInputs && w == 0.0)) return r1;
    if (mode == Input2Only || (mode == BlendInputs && w == 1.0)) return r2;
    const Eigen::Vector3d euler = r1 + w * (r2 - r1);
    if (context.getEnum(RotInterpolation) != Quaternion) return euler;
    const auto order = rotateOrderFromIndex(context.getEnum(RotateOrder_)).value_or(RotateOrder::xyz);
    const Eigen::Quaterniond q = slerpShortest(eulerQuaternion(r1, order), eulerQuaternion(r2, order), w);
    // Of the Euler triples of the slerped rotation, the one nearest the Euler blend: r1 at w = 0, r2 at w = 1.
    return quaternionEuler(q, order, euler);
}

class PairBlendNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const double w = context.getDouble(Weight);
        const Eigen::Vector3d& t1 = context.getVector3(InTranslate1);
        const Eigen::Vector3d& t2 = context.getVector3(InTranslate2);
        Eigen::Vector3d t;
        for (int i = 0; i < 3; ++i) t[i] = pick(context.getEnum(TranslateXMode + i), t1[i], t2[i], w);
        context.setOutput(OutTranslate, t);
        context.setOutput(OutRotate, blendRotation(context, w));
    }
};

AttributeBuilder vectorInput(NodeTypeBuilder& b, AttrId id, const std::string& stem, const std::string& shortStem,
                             char index, Unit unit)
{
    // Maya names the children with the index last: inTranslateX1 (itx1).
    auto child = [&](const char* axis) { return stem + axis + index; };
    auto shortChild = [&](const char* axis) { return shortStem + axis + index; };
    return b.input(id, stem + index, ValueType::Vector3)
        .shortName(shortStem + index)
        .children(child("X"), child("Y"), child("Z"))
        .childShortNames(shortChild("x"), shortChild("y"), shortChild("z"))
        .unit(unit)
        .keyable();
}

}  // namespace

std::shared_ptr<const NodeType> makePairBlendType()
{
    NodeTypeBuilder b("pairBlend");
    b.description(
        "Blends two translations and two rotations by weight (Maya's pairBlend node): outTranslate = inTranslate1 "
        "+ weight * (inTranslate2 - inTranslate1) per channel unless the channel's mode picks one input; outRotate "
        "the same per Euler angle (rotInterpolation euler), or the shorter-arc slerp of the two rotations in "
        "rotateOrder (quaternion), written as the Euler triple nearest the per-angle blend; weight 0 gives "
        "inRotate1 and weight 1 inRotate2 as written. rotateMode picks the rotation's inputs for all three angles.");
    vectorInput(b, InTranslate1, "inTranslate", "it", '1', Unit::Distance)
        .doc("The first translation (inTranslateX1, inTranslateY1, inTranslateZ1), output at weight 0.");
    vectorInput(b, InRotate1, "inRotate", "ir", '1', Unit::Angle)
        .doc("The first rotation (inRotateX1, inRotateY1, inRotateZ1), in rotateOrder, output at weight 0.");
    vectorInput(b, InTranslate2, "inTranslate", "it", '2', Unit::Distance)
        .doc("The second translation (inTranslateX2, inTranslateY2, inTranslateZ2), output at weight 1.");
    vectorInput(b, InRotate2, "inRotate", "ir", '2', Unit::Angle)
        .doc("The second rotation (inRotateX2, inRotateY2, inRotateZ2), output at weight 1.");
    b.input(Weight, "weight", ValueType::Double)
        .shortName("w")
        .defaultValue(1.0)
        .keyable()
        .doc("0 gives the inputs 1, 1 the inputs 2 (Maya's default); outside 0..1 extrapolates.");
    b.input(RotInterpolation, "rotInterpolation", ValueType::Enum)
        .shortName("ri")
        .enumNames({"euler", "quaternion"})
        .doc("euler blends each angle; quaternion slerps the rotations.");
    b.input(RotateOrder_, "rotateOrder", ValueType::Enum)
        .shortName("ro")
        .enumNames(rotateOrderEnumNames())
        .doc("The rotate order of the inputs and output (connect the driven object's rotateOrder).");
    const std::vector<std::string> modes{"blendInputs", "input1Only", "input2Only"};
    b.input(RotateMode, "rotateMode", ValueType::Enum)
        .shortName("rm")
        .enumNames(modes)
        .doc("blendInputs, input1Only (inRotate1) or input2Only (inRotate2).");
    b.input(TranslateXMode, "translateXMode", ValueType::Enum)
        .shortName("txm")
        .enumNames(modes)
        .doc("outTranslateX from blendInputs, input1Only or input2Only.");
    b.input(TranslateYMode, "translateYMode", ValueType::Enum)
        .shortName("tym")
        .enumNames(modes)
        .doc("outTranslateY from blendInputs, input1Only or input2Only.");
    b.input(TranslateZMode, "translateZMode", ValueType::Enum)
        .shortName("tzm")
        .enumNames(modes)
        .doc("outTranslateZ from blendInputs, input1Only or input2Only.");
    b.input(CurrentDriver, "currentDriver", ValueType::Int)
        .shortName("c")
        .doc("Maya's keying hint (which input a new key goes to), kept for the scene's sake; no effect.");
    b.output(OutTranslate, "outTranslate", ValueType::Vector3)
        .shortName("ot")
        .unit(Unit::Distance)
        .doc("The blended translation (outTranslateX, outTranslateY, outTranslateZ).");
    b.output(OutRotate, "outRotate", ValueType::Vector3)
        .shortName("or")
        .unit(Unit::Angle)
        .doc("The blended rotation in rotateOrder (outRotateX, outRotateY, outRotateZ).");
    b.affects(InTranslate1, {OutTranslate})
        .affects(InTranslate2, {OutTranslate})
        .affects(Weight, {OutTranslate, OutRotate});
    for (AttrId in : {TranslateXMode, TranslateYMode, TranslateZMode}) b.affects(in, {OutTranslate});
    for (AttrId in : {InRotate1, InRotate2, RotInterpolation, RotateOrder_, RotateMode}) b.affects(in, {OutRotate});
    b.factory<PairBlendNode>();
    return b.build();
}

}  // namespace rig
