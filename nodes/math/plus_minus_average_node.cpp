// plusMinusAverage: Maya's Plus Minus Average utility over sparse arrays of doubles and of vector3s.

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Operation, Input1D, Input3D, Output1D, Output3D };
enum Op { NoOperation, Sum, Subtract, Average };

// Folds the existing elements (in logical index order) of one array input; T is double or Vector3d.
template <class T>
T combine(const ComputeContext& context, AttrId attr, int op, T zero)
{
    T result = zero;
    int count = 0;
    context.forEachElement<T>(attr, [&](int, const T& x) {
        if (count == 0) result = x;
        else if (op == Sum || op == Average) result += x;
        else if (op == Subtract) result -= x;
        ++count;
    });
    if (op == Average && count > 0) result /= static_cast<double>(count);
    return result;
}

class PlusMinusAverageNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const int op = context.getEnum(Operation);
        context.setOutput(Output1D, combine<double>(context, Input1D, op, 0.0));
        context.setOutput(Output3D, combine<Eigen::Vector3d>(context, Input3D, op, Eigen::Vector3d::Zero()));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makePlusMinusAverageType()
{
    NodeTypeBuilder b("plusMinusAverage");
    b.description(
        "Sums, subtracts or averages the elements of its input arrays (Maya's plusMinusAverage utility node): "
        "input1D gives output1D, input3D gives output3D. Only existing elements count, taken in logical index "
        "order, so gaps in the indices are skipped (input1D[0] and input1D[5] average over 2). An empty array "
        "gives 0.");
    b.input(Operation, "operation", ValueType::Enum)
        .shortName("op")
        .enumNames({"noOperation", "sum", "subtract", "average"})
        .defaultValue(static_cast<int>(Sum))
        .keyable()
        .doc(
            "noOperation: the first existing element; sum: all elements added; subtract: the first element "
            "minus all the others; average: the sum divided by the number of existing elements.");
    b.input(Input1D, "input1D", ValueType::Double)
        .shortName("i1")
        .array()
        .keyable()
        .doc("The scalar operands, input1D[0], input1D[1], ... (indices may have gaps).");
    b.input(Input3D, "input3D", ValueType::Vector3)
        .shortName("i3")
        .array()
        .children("input3Dx", "input3Dy", "input3Dz")
        .keyable()
        .doc(
            "The vector3 operands, input3D[i] with components input3D[i].input3Dx, .input3Dy, .input3Dz "
            "(indices may have gaps).");
    b.output(Output1D, "output1D", ValueType::Double).shortName("o1").doc("The result over input1D.");
    b.output(Output3D, "output3D", ValueType::Vector3)
        .shortName("o3")
        .children("output3Dx", "output3Dy", "output3Dz")
        .doc("The result over input3D, component by component (output3Dx, output3Dy, output3Dz).");
    b.affects(Operation, {Output1D, Output3D}).affects(Input1D, {Output1D}).affects(Input3D, {Output3D});
    b.factory<PlusMinusAverageNode>();
    return b.build();
}

}  // namespace rig
