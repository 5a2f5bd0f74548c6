// multMatrix: Maya's multMatrix, the product of an array of matrices.

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { MatrixIn, MatrixSum };

class MultMatrixNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        // Column vectors: each later matrix multiplies from the left, so matrixIn[0] acts first.
        Eigen::Matrix4d sum = Eigen::Matrix4d::Identity();
        context.forEachElement<Eigen::Matrix4d>(MatrixIn, [&](int, const Eigen::Matrix4d& m) { sum = m * sum; });
        context.setOutput(MatrixSum, sum);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeMultMatrixType()
{
    NodeTypeBuilder b("multMatrix");
    b.description(
        "Multiplies the matrices of matrixIn in logical index order (Maya's multMatrix node). As in Maya, "
        "matrixIn[0] is applied first: Maya's row-vector product matrixIn[0] * matrixIn[1] * ... * matrixIn[n-1] "
        "is, in this engine's column-vector convention, matrixSum = matrixIn[n-1] * ... * matrixIn[1] * "
        "matrixIn[0]. So a local matrix at [0] and its parent's world matrix at [1] give the world matrix. "
        "Gaps in the indices are skipped; no elements give the identity.");
    b.input(MatrixIn, "matrixIn", ValueType::Matrix4)
        .shortName("i")
        .array()
        .doc("The matrices, matrixIn[0] applied first (innermost), then matrixIn[1], and so on.");
    b.output(MatrixSum, "matrixSum", ValueType::Matrix4)
        .shortName("o")
        .doc(
            "matrixIn[n-1] * ... * matrixIn[0] in column-vector form (Maya's row-form "
            "matrixIn[0] * ... * matrixIn[n-1]).");
    b.affects(MatrixIn, {MatrixSum});
    b.factory<MultMatrixNode>();
    return b.build();
}

}  // namespace rig
