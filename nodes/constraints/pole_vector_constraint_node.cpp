// poleVectorConstraint: Maya's poleVectorConstraint, the pole vector of a rotate-plane ikHandle from
// the start joint toward the weighted mean of its targets (docs/constraints.md).
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
    PivotSpace,
    ConstraintRotatePivot,
    ConstraintParentInverseMatrix,
    ConstraintTranslate,
    // Maya's inputs (appended: rig files and the inversion name attributes by the ids above).
    TargetTranslate,
    TargetRotatePivot,
    TargetRotateTranslate,
    TargetParentMatrix,
    ConstraintRotateTranslate,
    EnableRestPosition
};

constexpr constraint::MayaTargetIds mayaTargets{.translate = TargetTranslate,
                                                .rotatePivot = TargetRotatePivot,
                                                .rotateTranslate = TargetRotateTranslate,
                                                .parentMatrix = TargetParentMatrix};

class PoleVectorConstraintNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        const auto target =
            constraint::weightedPivot(constraint::gatherFrames(c, TargetMatrix, TargetWeight, mayaTargets));
        if (!target) {
            c.setOutput(ConstraintTranslate, c.getBool(EnableRestPosition) ? c.getVector3(RestTranslate)
                                                                           : Eigen::Vector3d(Eigen::Vector3d::Zero()));
            return;
        }
        const Eigen::Vector3d startLocal =
            c.getVector3(ConstraintRotatePivot) + c.getVector3(ConstraintRotateTranslate);
        const Eigen::Vector3d start = (c.getMatrix(PivotSpace) * startLocal.homogeneous()).head<3>();
        const Eigen::Vector3d pole =
            c.getMatrix(ConstraintParentInverseMatrix).topLeftCorner<3, 3>() * (*target - start) + c.getVector3(Offset);
        c.setOutput(ConstraintTranslate, pole);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makePoleVectorConstraintType()
{
    NodeTypeBuilder b("poleVectorConstraint");
    b.description(
        "The pole vector of a rotate-plane ikHandle toward the weighted mean of its targets, as Maya's "
        "poleVectorConstraint: constraintTranslate = L * (p - s) + offset, p = sum w_i p_i / sum w_i (p_i the "
        "translation of targetMatrix[i] or targetParentMatrix[i] * (targetTranslate[i] + targetRotatePivot[i] + "
        "targetRotateTranslate[i])), s = pivotSpace * (constraintRotatePivot + constraintRotateTranslate) the start "
        "joint's world position, L the 3x3 part of constraintParentInverseMatrix (identity by default: a world-space "
        "direction from the start joint, the pole vector the ikHandle takes). With every weight zero (or no "
        "target) it outputs restTranslate. Wiring: docs/constraints.md.");
    constraint::addTargets(b, TargetMatrix, TargetWeight,
                           "World matrix of target i, the pole control (connect from target.worldMatrix); its "
                           "translation is the target's position. A target exists where this element exists.");
    constraint::addOffset(b, Offset, Unit::Distance)
        .doc("Added to the pole vector, cm (Maya's offset, inherited from pointConstraint).");
    constraint::addRestTranslate(b, RestTranslate)
        .doc("The output when every weight is zero or there is no target: set the handle's rest pole vector.");
    b.input(PivotSpace, "pivotSpace", ValueType::Matrix4)
        .shortName("ps")
        .doc(
            "World matrix of the ik chain's start joint's PARENT (connect from parent.worldMatrix; Maya "
            "connects startJoint.parentMatrix).");
    b.input(ConstraintRotatePivot, "constraintRotatePivot", ValueType::Vector3)
        .shortName("crp")
        .unit(Unit::Distance)
        .doc(
            "The start joint's translate, cm (set the same constant; connecting the start joint itself would "
            "close a cycle through the ikHandle). Start joint world position = pivotSpace * this.");
    constraint::addParentInverse(b, ConstraintParentInverseMatrix)
        .doc(
            "Frame the pole vector is expressed in (only its 3x3 part is used): leave identity for a world-space "
            "pole vector; connect the ikHandle's parent's worldInverseMatrix for a handle that takes it in its "
            "parent's space (Maya connects handle.parentInverseMatrix).");
    constraint::addTranslateOutput(b, ConstraintTranslate)
        .doc("The pole vector, cm: from the start joint toward the target (connect to ikHandle.poleVector).");
    constraint::addMayaTargets(b, mayaTargets);
    b.input(ConstraintRotateTranslate, "constraintRotateTranslate", ValueType::Vector3)
        .shortName("crt")
        .unit(Unit::Distance)
        .doc(
            "Added to constraintRotatePivot before pivotSpace (Maya's, inherited from pointConstraint; zero as Maya "
            "wires a pole vector).");
    constraint::addEnableRestPosition(b, EnableRestPosition);
    b.affectsAll();
    return b.factory<PoleVectorConstraintNode>().build();
}

}  // namespace rig
