// inverseMatrix: Maya's inverseMatrix, the inverse of a matrix.

#include <Eigen/LU>

#include "graph/node_type.h"
#include "graph/value.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { InputMatrix, OutputMatrix };

class InverseMatrixNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        Eigen::Matrix4d inverse;
        bool invertible = false;
        context.getMatrix(InputMatrix).computeInverseWithCheck(inverse, invertible, 0.0);
        // A singular matrix has no inverse; the identity keeps NaN out of the graph.
        if (!invertible || !inverse.allFinite()) inverse.setIdentity();
        context.setOutput(OutputMatrix, inverse);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeInverseMatrixType()
{
    NodeTypeBuilder b("inverseMatrix");
    b.description(
        "Inverts a matrix (Maya's inverseMatrix node): outputMatrix = inputMatrix^-1. A singular matrix (a zero "
        "scale) outputs the identity.");
    b.input(InputMatrix, "inputMatrix", ValueType::Matrix4).shortName("imat").doc("The matrix inverted.");
    b.output(OutputMatrix, "outputMatrix", ValueType::Matrix4)
        .shortName("omat")
        .doc("The inverse, or the identity when inputMatrix is singular.");
    b.affects(InputMatrix, {OutputMatrix});
    b.factory<InverseMatrixNode>();
    return b.build();
}

}  // namespace rig
