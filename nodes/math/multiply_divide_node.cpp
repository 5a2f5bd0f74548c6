// multiplyDivide: Maya's Multiply Divide utility, component-wise on two vector3 inputs.

#include <cmath>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Operation, Input1, Input2, Output };
enum Op { NoOperation, Multiply, Divide, Power };

double apply(int op, double a, double b)
{
    switch (op) {
        case Multiply:
            return a * b;
        case Divide:
            return a / b;
        case Power:
            return std::pow(a, b);
        default:
            return a;
    }
}

class MultiplyDivideNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const int op = context.getEnum(Operation);
        const Eigen::Vector3d& a = context.getVector3(Input1);
        const Eigen::Vector3d& b = context.getVector3(Input2);
        Eigen::Vector3d out;
        for (int i = 0; i < 3; ++i) {
            const double r = apply(op, a[i], b[i]);
            out[i] = std::isfinite(r) ? r : 0.0;  // x/0, 0/0, (-8)^0.5, overflow: 0, never inf/NaN
        }
        context.setOutput(Output, out);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeMultiplyDivideType()
{
    NodeTypeBuilder b("multiplyDivide");
    b.description(
        "Multiplies, divides or raises to a power two vector3 inputs component by component (Maya's "
        "multiplyDivide utility node). A component whose result is not a finite number (division by zero, "
        "a negative base raised to a fractional power, overflow) outputs 0, where Maya would give inf or NaN.");
    b.input(Operation, "operation", ValueType::Enum)
        .shortName("op")
        .enumNames({"noOperation", "multiply", "divide", "power"})
        .defaultValue(static_cast<int>(Multiply))
        .keyable()
        .doc(
            "noOperation: output = input1; multiply: input1 * input2; divide: input1 / input2; "
            "power: input1 ^ input2 (each component separately).");
    b.input(Input1, "input1", ValueType::Vector3)
        .shortName("i1")
        .keyable()
        .doc("The first operand (input1X, input1Y, input1Z).");
    b.input(Input2, "input2", ValueType::Vector3)
        .shortName("i2")
        .defaultValue(Eigen::Vector3d(1.0, 1.0, 1.0))
        .keyable()
        .doc(
            "The second operand: multiplier, divisor or exponent (input2X, input2Y, input2Z). A zero divisor "
            "gives 0 in that output component.");
    b.output(Output, "output", ValueType::Vector3)
        .shortName("o")
        .doc("The result (outputX, outputY, outputZ); a component that would be inf or NaN is 0.");
    b.affects(Operation, {Output}).affects(Input1, {Output}).affects(Input2, {Output});
    b.factory<MultiplyDivideNode>();
    return b.build();
}

}  // namespace rig
