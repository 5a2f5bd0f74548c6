// reverse: Maya's reverse utility, output = 1 - input per component.

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Input, Output };

class ReverseNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        context.setOutput(Output, Eigen::Vector3d(Eigen::Vector3d::Ones() - context.getVector3(Input)));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeReverseType()
{
    NodeTypeBuilder b("reverse");
    b.description(
        "Outputs 1 - input for each component (Maya's reverse utility node); the usual way to turn "
        "a 0..1 weight w into 1 - w.");
    b.input(Input, "input", ValueType::Vector3)
        .shortName("i")
        .keyable()
        .doc("The value reversed (inputX, inputY, inputZ).");
    b.output(Output, "output", ValueType::Vector3).shortName("o").doc("1 - input (outputX, outputY, outputZ).");
    b.affects(Input, {Output});
    b.factory<ReverseNode>();
    return b.build();
}

}  // namespace rig
