// addDoubleLinear: Maya's addDoubleLinear, output = input1 + input2.

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Input1, Input2, Output };

class AddDoubleLinearNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        context.setOutput(Output, context.getDouble(Input1) + context.getDouble(Input2));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeAddDoubleLinearType()
{
    NodeTypeBuilder b("addDoubleLinear");
    b.description(
        "Adds two numbers: output = input1 + input2 (Maya's addDoubleLinear node). Unitless: an angle connected "
        "in arrives in degrees.");
    b.input(Input1, "input1", ValueType::Double).shortName("i1").keyable().doc("The first term.");
    b.input(Input2, "input2", ValueType::Double).shortName("i2").keyable().doc("The second term.");
    b.output(Output, "output", ValueType::Double).shortName("o").doc("input1 + input2.");
    b.affects(Input1, {Output}).affects(Input2, {Output});
    b.factory<AddDoubleLinearNode>();
    return b.build();
}

}  // namespace rig
