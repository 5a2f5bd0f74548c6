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
    ConstraintTranslate,
    // Maya's inputs (appended: rig files and the inversion name attributes by the ids above).
    TargetTranslate,
    TargetRotatePivot,
    TargetRotateTranslate,
    TargetParentMatrix,
    ConstraintRotatePivot,
    ConstraintRotateTranslate,
    EnableRestPosition
};

constexpr constraint::MayaTargetIds mayaTargets{.translate = TargetTranslate,
                                                .rotatePivot = TargetRotatePivot,
                                                .rotateTranslate = TargetRotateTranslate,
                                                .parentMatrix = TargetParentMatrix};

class PointConstraintNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        const auto position =
            constraint::weightedPivot(constraint::gatherFrames(c, TargetMatrix, TargetWeight, mayaTargets));
        if (!position) {
            c.setOutput(ConstraintTranslate, c.getBool(EnableRestPosition) ? c.getVector3(RestTranslate)
                                                                           : Eigen::Vector3d(Eigen::Vector3d::Zero()));
            return;
        }
        // Maya puts the object's rotate pivot (translate + rotatePivotTranslate + rotatePivot in the parent's
        // space) on the point, so the pivot offsets come off the translate.
        const Eigen::Vector3d local = constraint::toParentSpace(c.getMatrix(ConstraintParentInverseMatrix), *position) -
                                      c.getVector3(ConstraintRotatePivot) - c.getVector3(ConstraintRotateTranslate);
        c.setOutput(ConstraintTranslate, Eigen::Vector3d(local + c.getVector3(Offset)));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makePointConstraintType()
{
    NodeTypeBuilder b("pointConstraint");
    b.description(
        "Moves an object to the weighted mean of its targets' world positions, as Maya's pointConstraint: "
        "constraintTranslate = constraintParentInverseMatrix * (sum w_i p_i / sum w_i) - constraintRotatePivot - "
        "constraintRotateTranslate + offset, p_i the translation of targetMatrix[i] or, from Maya's inputs, "
        "targetParentMatrix[i] * (targetTranslate[i] + targetRotatePivot[i] + targetRotateTranslate[i]) (the "
        "target's rotate pivot in world space). With every weight zero (or no target) it outputs restTranslate "
        "(enableRestPosition on). Wire it as docs/constraints.md shows: targets' worldMatrix in (or Maya's "
        "target inputs), the constrained object's parent's worldInverseMatrix in, constraintTranslate to the "
        "object's translate.");
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
    constraint::addMayaTargets(b, mayaTargets);
    constraint::addConstraintPivot(b, ConstraintRotatePivot, ConstraintRotateTranslate);
    constraint::addEnableRestPosition(b, EnableRestPosition);
    b.affectsAll();
    return b.factory<PointConstraintNode>().build();
}

}  // namespace rig
