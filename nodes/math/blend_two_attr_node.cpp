// blendTwoAttr: Maya's blendTwoAttr, a linear blend of input[0] and input[1].

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { AttributesBlender, Input, Output };

class BlendTwoAttrNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        double in[2] = {0.0, 0.0};
        context.forEachElement<double>(Input, [&](int index, double value) {
            if (index < 2) in[index] = value;
        });
        const double w = context.getDouble(AttributesBlender);
        context.setOutput(Output, in[0] + w * (in[1] - in[0]));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeBlendTwoAttrType()
{
    NodeTypeBuilder b("blendTwoAttr");
    b.description(
        "Blends two values: output = input[0] * (1 - attributesBlender) + input[1] * attributesBlender "
        "(Maya's blendTwoAttr node). A missing input[0] or input[1] counts as 0; elements past index 1 "
        "are ignored. Unlike Maya's generic input, the values are unitless: an angle connected in arrives "
        "in degrees.");
    b.input(AttributesBlender, "attributesBlender", ValueType::Double)
        .shortName("ab")
        .keyable()
        .doc("The blend weight: 0 gives input[0], 1 gives input[1]; values outside 0..1 extrapolate.");
    b.input(Input, "input", ValueType::Double)
        .shortName("i")
        .array()
        .doc("The two values blended, input[0] and input[1].");
    b.output(Output, "output", ValueType::Double).shortName("o").doc("The blended value.");
    b.affects(AttributesBlender, {Output}).affects(Input, {Output});
    b.factory<BlendTwoAttrNode>();
    return b.build();
}

}  // namespace rig
