// condition: Maya's condition utility, choosing one of two colours by comparing two terms.

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Operation, FirstTerm, SecondTerm, ColorIfTrue, ColorIfFalse, OutColor };
enum Op { Equal, NotEqual, GreaterThan, GreaterOrEqual, LessThan, LessOrEqual };

bool test(int op, double a, double b)
{
    switch (op) {
        case Equal:
            return a == b;
        case NotEqual:
            return a != b;
        case GreaterThan:
            return a > b;
        case GreaterOrEqual:
            return a >= b;
        case LessThan:
            return a < b;
        default:
            return a <= b;
    }
}

class ConditionNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const bool pass = test(context.getEnum(Operation), context.getDouble(FirstTerm), context.getDouble(SecondTerm));
        context.setOutput(OutColor, context.getVector3(pass ? ColorIfTrue : ColorIfFalse));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeConditionType()
{
    NodeTypeBuilder b("condition");
    b.description(
        "Compares firstTerm with secondTerm and outputs colorIfTrue when the comparison holds, colorIfFalse "
        "otherwise (Maya's condition utility node). Comparisons are exact (no tolerance), as in Maya.");
    b.input(Operation, "operation", ValueType::Enum)
        .shortName("op")
        .enumNames({"equal", "notEqual", "greaterThan", "greaterOrEqual", "lessThan", "lessOrEqual"})
        .keyable()
        .doc(
            "The comparison: firstTerm == (equal), != (notEqual), > (greaterThan), >= (greaterOrEqual), "
            "< (lessThan) or <= (lessOrEqual) secondTerm.");
    b.input(FirstTerm, "firstTerm", ValueType::Double)
        .shortName("ft")
        .keyable()
        .doc("The left side of the comparison.");
    b.input(SecondTerm, "secondTerm", ValueType::Double)
        .shortName("st")
        .keyable()
        .doc("The right side of the comparison.");
    b.input(ColorIfTrue, "colorIfTrue", ValueType::Vector3)
        .shortName("ct")
        .children("colorIfTrueR", "colorIfTrueG", "colorIfTrueB")
        .keyable()
        .doc("The output when the comparison holds (colorIfTrueR, colorIfTrueG, colorIfTrueB).");
    b.input(ColorIfFalse, "colorIfFalse", ValueType::Vector3)
        .shortName("cf")
        .children("colorIfFalseR", "colorIfFalseG", "colorIfFalseB")
        .defaultValue(Eigen::Vector3d(1.0, 1.0, 1.0))
        .keyable()
        .doc("The output when the comparison fails (colorIfFalseR, colorIfFalseG, colorIfFalseB).");
    b.output(OutColor, "outColor", ValueType::Vector3)
        .shortName("oc")
        .children("outColorR", "outColorG", "outColorB")
        .doc("colorIfTrue or colorIfFalse (outColorR, outColorG, outColorB).");
    for (AttrId in : {Operation, FirstTerm, SecondTerm, ColorIfTrue, ColorIfFalse}) b.affects(in, {OutColor});
    b.factory<ConditionNode>();
    return b.build();
}

}  // namespace rig
