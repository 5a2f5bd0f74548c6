// pointConstraint: Maya's pointConstraint, the weighted mean of target positions in the constrained
// object's parent space (docs/constraints.md).
#include "nodes/builtin_nodes.h"
#include "nodes/constraints/constraint_attributes.h"
#include "nodes/constraints/constraint_math.h"

namespace rig {
namespace {

enum Attr : AttrId {
    TargetMatrix,
    TargetWeight,
    Offset,
    RestTranslate,
    ConstraintParentInverseMatrix,
    ConstraintTranslate
};

class PointConstraintNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        const auto position = constraint::weightedPosition(constraint::gatherTargets(c, TargetMatrix, TargetWeight));
        if (!position) {
            c.setOutput(ConstraintTranslate, c.getVector3(RestTranslate));
            return;
        }
        const Eigen::Vector3d local = constraint::toParentSpace(c.getMatrix(ConstraintParentInverseMatrix), *position);
        c.setOutput(ConstraintTranslate, Eigen::Vector3d(local + c.getVector3(Offset)));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makePointConstraintType()
{
    NodeTypeBuilder b("pointConstraint");
    b.description(
        "Moves an object to the weighted mean of its targets' world positions, as Maya's pointConstraint: "
        "constraintTranslate = constraintParentInverseMatrix * (sum w_i p_i / sum w_i) + offset, p_i the "
        "translation of targetMatrix[i]. With every weight zero (or no target) it outputs restTranslate. "
        "Wire it as docs/constraints.md shows: targets' worldMatrix in, the constrained object's parent's "
        "worldInverseMatrix in, constraintTranslate to the object's translate.");
    constraint::addTargets(
        b, TargetMatrix, TargetWeight,
        "World matrix of target i (connect from target.worldMatrix); its translation is the target's position "
        "(Maya uses the target's rotate pivot, the same point when its pivots are zero). A target exists where "
        "this element exists.");
    constraint::addOffset(b, Offset, Unit::Distance)
        .doc(
            "Added to the result in the parent's space, cm (Maya's offset; maintain offset = the object's "
            "translate minus the constrained result at bind time).");
    constraint::addRestTranslate(b, RestTranslate)
        .doc("The output when every weight is zero or there is no target (Maya's rest position), cm.");
    constraint::addParentInverse(b, ConstraintParentInverseMatrix);
    constraint::addTranslateOutput(b, ConstraintTranslate);
    for (AttrId in = TargetMatrix; in < ConstraintTranslate; ++in) b.affects(in, {ConstraintTranslate});
    return b.factory<PointConstraintNode>().build();
}

}  // namespace rig
