// floatConstant: Maya's floatConstant, outFloat = inFloat.

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { InFloat, OutFloat };

class FloatConstantNode final : public Node {
public:
    void compute(ComputeContext& context) override { context.setOutput(OutFloat, context.getDouble(InFloat)); }
};

}  // namespace

std::shared_ptr<const NodeType> makeFloatConstantType()
{
    NodeTypeBuilder b("floatConstant");
    b.description("Passes a number through: outFloat = inFloat (Maya's floatConstant node), one value fanned out.");
    b.input(InFloat, "inFloat", ValueType::Double).shortName("if").keyable().doc("The constant.");
    b.output(OutFloat, "outFloat", ValueType::Double).shortName("of").doc("inFloat.");
    b.affects(InFloat, {OutFloat});
    b.factory<FloatConstantNode>();
    return b.build();
}

}  // namespace rig
