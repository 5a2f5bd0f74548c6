// blendWeighted: Maya's blendWeighted, the weighted sum of its inputs (the usual node under set-driven keys that
// several drivers share).

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Input, Weight, Current, Output };

class BlendWeightedNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        std::vector<double> weights;
        context.forEachElement<double>(Weight, [&](int i, double w) {
            if (weights.size() <= static_cast<std::size_t>(i)) weights.resize(static_cast<std::size_t>(i) + 1, 1.0);
            weights[static_cast<std::size_t>(i)] = w;
        });
        double sum = 0.0;
        context.forEachElement<double>(Input, [&](int i, double x) {
            const auto k = static_cast<std::size_t>(i);
            sum += x * (k < weights.size() ? weights[k] : 1.0);
        });
        context.setOutput(Output, sum);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeBlendWeightedType()
{
    NodeTypeBuilder b("blendWeighted");
    b.description(
        "Sums its inputs, each times its weight: output = sum over existing input[i] of input[i] * weight[i] "
        "(Maya's blendWeighted node); a missing weight[i] is Maya's default 1, a weight without an input adds "
        "nothing, no inputs give 0. Unitless: an angle connected in arrives in degrees through a YAML rig's "
        "converting connection, in radians through a Maya scene's (which converts with its own unitConversion "
        "nodes).");
    b.input(Input, "input", ValueType::Double).array().shortName("i").keyable().doc("The values summed, input[i].");
    b.input(Weight, "weight", ValueType::Double)
        .array()
        .shortName("w")
        .defaultValue(1.0)
        .keyable()
        .doc("weight[i] multiplies input[i]; 1 when absent.");
    b.input(Current, "current", ValueType::Int)
        .shortName("c")
        .doc("Maya's current driver index, kept for the scene's sake; it does not change the output.");
    b.output(Output, "output", ValueType::Double).shortName("o").doc("The weighted sum.");
    b.affects(Input, {Output}).affects(Weight, {Output});
    b.factory<BlendWeightedNode>();
    return b.build();
}

}  // namespace rig
