// animBlendNodeAdditive and its typed variants (DL, DA, F, FA, I16, I32): Maya's animation-layer blend of one
// channel, output = inputA * weightA + inputB * weightB. One file: the variants differ only in value type and unit.

#include <cmath>
#include <string>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { InputA, InputB, WeightA, WeightB, Output };

class AnimBlendNodeAdditiveNode final : public Node {
public:
    explicit AnimBlendNodeAdditiveNode(bool integer) : integer_(integer) {}

    void compute(ComputeContext& context) override
    {
        const double wa = context.getDouble(WeightA);
        const double wb = context.getDouble(WeightB);
        if (!integer_) {
            context.setOutput(Output, context.getDouble(InputA) * wa + context.getDouble(InputB) * wb);
            return;
        }
        const double sum = context.getInt(InputA) * wa + context.getInt(InputB) * wb;
        // An integer channel takes the nearest integer; beyond int's range (or NaN) it holds 0.
        const bool fits = std::isfinite(sum) && std::abs(sum) < 2.0e9;
        context.setOutput(Output, fits ? static_cast<int>(std::lround(sum)) : 0);
    }

private:
    bool integer_;
};

struct Variant {
    ValueType type;
    Unit unit;
    const char* what;
};

Variant variantOf(const std::string& typeName)
{
    if (typeName.ends_with("DL")) return {ValueType::Double, Unit::Distance, "a distance (cm)"};
    if (typeName.ends_with("DA") || typeName.ends_with("FA")) return {ValueType::Double, Unit::Angle, "an angle"};
    if (typeName.ends_with("I16") || typeName.ends_with("I32"))
        return {ValueType::Int, Unit::None, "an integer (rounded to the nearest)"};
    return {ValueType::Double, Unit::None, "a number"};
}

}  // namespace

std::shared_ptr<const NodeType> makeAnimBlendNodeAdditiveType(const char* typeName)
{
    const Variant v = variantOf(typeName);
    NodeTypeBuilder b(typeName);
    b.description("One channel of Maya's animation layers, as Maya's " + std::string(typeName) +
                  " sums them: output = inputA * weightA + inputB * weightB, " + v.what +
                  ". inputA is the layers below (or the base animation), inputB this layer's curve, weightB this "
                  "layer's weight.");
    b.input(InputA, "inputA", v.type).shortName("ia").unit(v.unit).keyable().doc("The value from the layers below.");
    b.input(InputB, "inputB", v.type).shortName("ib").unit(v.unit).keyable().doc("This layer's value.");
    b.input(WeightA, "weightA", ValueType::Double)
        .shortName("wa")
        .defaultValue(1.0)
        .keyable()
        .doc("Weight of inputA (Maya's default 1).");
    b.input(WeightB, "weightB", ValueType::Double)
        .shortName("wb")
        .defaultValue(1.0)
        .keyable()
        .doc("Weight of inputB, the layer's weight (Maya's default 1).");
    b.output(Output, "output", v.type).shortName("o").unit(v.unit).doc("inputA * weightA + inputB * weightB.");
    for (AttrId in : {InputA, InputB, WeightA, WeightB}) b.affects(in, {Output});
    const bool integer = v.type == ValueType::Int;
    b.factory([integer] { return std::unique_ptr<Node>(std::make_unique<AnimBlendNodeAdditiveNode>(integer)); });
    return b.build();
}

}  // namespace rig
