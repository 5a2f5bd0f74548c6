// animBlendNodeEnum and animBlendNodeBoolean: Maya's animation-layer blend of a channel that cannot be summed
// (an enum or a switch): the layer overrides what is below it while its weight is above 0.

#include <string>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { InputA, InputB, WeightA, WeightB, Output };

class AnimBlendNodeEnumNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const bool layer = context.getDouble(WeightB) > 0.0;
        const AttrId from = layer ? InputB : InputA;
        if (boolean_) context.setOutput(Output, context.getBool(from));
        else context.setOutput(Output, context.getInt(from));
    }

    explicit AnimBlendNodeEnumNode(bool boolean) : boolean_(boolean) {}

private:
    bool boolean_;
};

}  // namespace

std::shared_ptr<const NodeType> makeAnimBlendNodeEnumType(const char* typeName)
{
    const bool boolean = std::string(typeName) == "animBlendNodeBoolean";
    const ValueType type = boolean ? ValueType::Bool : ValueType::Int;
    NodeTypeBuilder b(typeName);
    b.description(std::string("One ") + (boolean ? "on/off" : "enum") +
                  " channel of Maya's animation layers, as Maya's " + typeName +
                  " takes it: output = inputB while weightB > 0, otherwise inputA (the layer overrides the layers "
                  "below; values of this kind are not summed). weightA has no effect.");
    b.input(InputA, "inputA", type).shortName("ia").keyable().doc("The value from the layers below.");
    b.input(InputB, "inputB", type).shortName("ib").keyable().doc("This layer's value.");
    b.input(WeightA, "weightA", ValueType::Double)
        .shortName("wa")
        .defaultValue(1.0)
        .doc("Maya's weight of inputA, kept for the scene's sake; no effect.");
    b.input(WeightB, "weightB", ValueType::Double)
        .shortName("wb")
        .defaultValue(1.0)
        .keyable()
        .doc("The layer's weight: above 0 the output is inputB.");
    b.output(Output, "output", type).shortName("o").doc("inputB while weightB > 0, otherwise inputA.");
    for (AttrId in : {InputA, InputB, WeightB}) b.affects(in, {Output});
    b.factory([boolean] { return std::unique_ptr<Node>(std::make_unique<AnimBlendNodeEnumNode>(boolean)); });
    return b.build();
}

}  // namespace rig
