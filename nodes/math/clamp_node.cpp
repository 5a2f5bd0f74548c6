// clamp: Maya's clamp utility, keeping each component of a vector3 between min and max.

#include <algorithm>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Min, Max, Input, Output };

class ClampNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const Eigen::Vector3d& lo = context.getVector3(Min);
        const Eigen::Vector3d& hi = context.getVector3(Max);
        const Eigen::Vector3d& x = context.getVector3(Input);
        Eigen::Vector3d out;
        for (int i = 0; i < 3; ++i) out[i] = std::min(std::max(x[i], lo[i]), hi[i]);
        context.setOutput(Output, out);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeClampType()
{
    NodeTypeBuilder b("clamp");
    b.description(
        "Clamps each component of input into [min, max]: output = min(max(input, min), max) (Maya's clamp "
        "utility node). Where min > max the output is max. With the defaults (min = max = 0) the output is 0.");
    b.input(Min, "min", ValueType::Vector3)
        .shortName("mn")
        .children("minR", "minG", "minB")
        .keyable()
        .doc("Lower bound of each component (minR, minG, minB).");
    b.input(Max, "max", ValueType::Vector3)
        .shortName("mx")
        .children("maxR", "maxG", "maxB")
        .keyable()
        .doc("Upper bound of each component (maxR, maxG, maxB); wins over min where they cross.");
    b.input(Input, "input", ValueType::Vector3)
        .shortName("ip")
        .children("inputR", "inputG", "inputB")
        .keyable()
        .doc("The value clamped (inputR, inputG, inputB).");
    b.output(Output, "output", ValueType::Vector3)
        .shortName("op")
        .children("outputR", "outputG", "outputB")
        .doc("The clamped value (outputR, outputG, outputB).");
    b.affects(Min, {Output}).affects(Max, {Output}).affects(Input, {Output});
    b.factory<ClampNode>();
    return b.build();
}

}  // namespace rig
