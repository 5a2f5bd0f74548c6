// saturate: a symmetric clamp; past the threshold the parameter has no effect (a control whose range
// is limited by the rig rather than by the animator's attribute limits).

#include <algorithm>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Input, Threshold, Output };

class SaturateNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const double x = context.getDouble(Input);
        const double t = std::max(context.getDouble(Threshold), 0.0);  // connections bypass the minimum
        context.setOutput(Output, x >= 0.0 ? std::min(x, t) : std::max(x, -t));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeSaturateType()
{
    NodeTypeBuilder b("saturate");
    b.description(
        "Saturates a value symmetrically: output = min(input, threshold) for input >= 0, max(input, "
        "-threshold) below (a negative threshold acts as 0). Past the threshold the input has no effect, so "
        "an inversion cannot recover it there. Unitless: an angle connected in arrives in degrees, so the "
        "threshold is then in degrees. Maya's clamp node with min = -threshold, max = threshold does the same.");
    b.input(Input, "input", ValueType::Double).keyable().doc("The value saturated.");
    b.input(Threshold, "threshold", ValueType::Double)
        .defaultValue(1.0)
        .min(0.0)
        .keyable()
        .doc("The largest magnitude passed through.");
    b.output(Output, "output", ValueType::Double).doc("input limited to [-threshold, threshold].");
    b.affects(Input, {Output}).affects(Threshold, {Output});
    b.factory<SaturateNode>();
    return b.build();
}

}  // namespace rig
