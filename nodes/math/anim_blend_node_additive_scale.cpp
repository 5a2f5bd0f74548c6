// animBlendNodeAdditiveScale: Maya's animation-layer blend of a scale channel, multiplied (Maya's default) or
// added.

#include <cmath>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { InputA, InputB, WeightA, WeightB, AccumulationMode, Output };
enum Mode { Multiply, Additive };

class AnimBlendNodeAdditiveScaleNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const double a = context.getDouble(InputA);
        const double b = context.getDouble(InputB);
        const double wa = context.getDouble(WeightA);
        const double wb = context.getDouble(WeightB);
        const double out =
            context.getEnum(AccumulationMode) == Additive ? a * wa + b * wb : std::pow(a, wa) * std::pow(b, wb);
        // A negative scale raised to a fractional weight (or 0 to a negative one) has no value: 0, never NaN.
        context.setOutput(Output, std::isfinite(out) ? out : 0.0);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeAnimBlendNodeAdditiveScaleType()
{
    NodeTypeBuilder b("animBlendNodeAdditiveScale");
    b.description(
        "One scale channel of Maya's animation layers, as Maya's animBlendNodeAdditiveScale sums it: with "
        "accumulationMode multiply (Maya's default) output = inputA^weightA * inputB^weightB, so a layer's scale "
        "multiplies the layers below and weight 0 makes it 1; with additive output = inputA * weightA + inputB * "
        "weightB. A result that is not a number (a negative scale to a fractional weight) outputs 0.");
    b.input(InputA, "inputA", ValueType::Double).shortName("ia").keyable().doc("The scale from the layers below.");
    b.input(InputB, "inputB", ValueType::Double).shortName("ib").keyable().doc("This layer's scale.");
    b.input(WeightA, "weightA", ValueType::Double).shortName("wa").defaultValue(1.0).keyable().doc("Weight of inputA.");
    b.input(WeightB, "weightB", ValueType::Double)
        .shortName("wb")
        .defaultValue(1.0)
        .keyable()
        .doc("Weight of inputB, the layer's weight.");
    b.input(AccumulationMode, "accumulationMode", ValueType::Enum)
        .shortName("acm")
        .enumNames({"multiply", "additive"})
        .doc(
            "multiply: scales multiply (weights are exponents); additive: weighted sum. Connected from the "
            "layer's scaleAccumulationMode.");
    b.output(Output, "output", ValueType::Double).shortName("o").doc("The accumulated scale.");
    for (AttrId in : {InputA, InputB, WeightA, WeightB, AccumulationMode}) b.affects(in, {Output});
    b.factory<AnimBlendNodeAdditiveScaleNode>();
    return b.build();
}

}  // namespace rig
