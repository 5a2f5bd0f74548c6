// animBlendNodeAdditiveRotation: Maya's animation-layer blend of a rotation, by component (Euler angles summed,
// Maya's default) or by layer (rotations composed).

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"
#include "nodes/enum_names.h"
#include "nodes/math/rotation_blend.h"

namespace rig {
namespace {

enum Attr : AttrId { InputA, InputB, WeightA, WeightB, AccumulationMode, RotateOrder_, Output };
enum Mode { ByComponent, ByLayer };

class AnimBlendNodeAdditiveRotationNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const Eigen::Vector3d& a = context.getVector3(InputA);
        const Eigen::Vector3d& b = context.getVector3(InputB);
        const double wa = context.getDouble(WeightA);
        const double wb = context.getDouble(WeightB);
        const Eigen::Vector3d sum = a * wa + b * wb;
        if (context.getEnum(AccumulationMode) != ByLayer) {
            context.setOutput(Output, sum);
            return;
        }
        // By layer: each layer's whole rotation, scaled by its weight along its shorter arc, applied after the
        // layers below it (as the first-applied axis of an Euler order, the lower layer is the inner rotation).
        const auto order = rotateOrderFromIndex(context.getEnum(RotateOrder_)).value_or(RotateOrder::xyz);
        const Eigen::Quaterniond q =
            scaledRotation(eulerQuaternion(b, order), wb) * scaledRotation(eulerQuaternion(a, order), wa);
        context.setOutput(Output, quaternionEuler(q, order, sum));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeAnimBlendNodeAdditiveRotationType()
{
    NodeTypeBuilder b("animBlendNodeAdditiveRotation");
    b.description(
        "A rotation of Maya's animation layers, as Maya's animBlendNodeAdditiveRotation sums it. accumulationMode "
        "byComponent (Maya's default): output = inputA * weightA + inputB * weightB per Euler angle. byLayer: the "
        "rotations compose, R = R(inputB)^weightB * R(inputA)^weightA in rotateOrder (each weighted along its "
        "shorter arc, this layer applied after the layers below), written as the Euler triple nearest the "
        "by-component sum.");
    b.input(InputA, "inputA", ValueType::Vector3)
        .shortName("ia")
        .unit(Unit::Angle)
        .keyable()
        .doc("The rotation from the layers below (inputAX, inputAY, inputAZ).");
    b.input(InputB, "inputB", ValueType::Vector3)
        .shortName("ib")
        .unit(Unit::Angle)
        .keyable()
        .doc("This layer's rotation (inputBX, inputBY, inputBZ).");
    b.input(WeightA, "weightA", ValueType::Double).shortName("wa").defaultValue(1.0).keyable().doc("Weight of inputA.");
    b.input(WeightB, "weightB", ValueType::Double)
        .shortName("wb")
        .defaultValue(1.0)
        .keyable()
        .doc("Weight of inputB, the layer's weight.");
    b.input(AccumulationMode, "accumulationMode", ValueType::Enum)
        .shortName("acm")
        .enumNames({"byComponent", "byLayer"})
        .doc(
            "byComponent sums Euler angles; byLayer composes rotations. Connected from the layer's "
            "outRotationAccumulationMode.");
    b.input(RotateOrder_, "rotateOrder", ValueType::Enum)
        .shortName("ro")
        .enumNames(rotateOrderEnumNames())
        .doc("The rotate order of inputs and output (connected from the driven object's rotateOrder); byLayer only.");
    b.output(Output, "output", ValueType::Vector3)
        .shortName("o")
        .unit(Unit::Angle)
        .doc("The accumulated rotation (outputX, outputY, outputZ).");
    for (AttrId in : {InputA, InputB, WeightA, WeightB, AccumulationMode, RotateOrder_}) b.affects(in, {Output});
    b.factory<AnimBlendNodeAdditiveRotationNode>();
    return b.build();
}

}  // namespace rig
