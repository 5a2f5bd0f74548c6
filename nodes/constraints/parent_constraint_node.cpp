// parentConstraint: Maya's parentConstraint, the object follows its targets as if it were their child
// (docs/constraints.md).
#include "nodes/builtin_nodes.h"
#include "nodes/constraints/constraint_attributes.h"
#include "nodes/constraints/constraint_math.h"

namespace rig {
namespace {

enum Attr : AttrId {
    TargetMatrix,
    TargetWeight,
    TargetOffset,
    MaintainOffset,
    RestMatrix,
    TargetRestMatrix,
    ConstraintRotateOrder,
    ConstraintJointOrient,
    RestTranslate,
    RestRotate,
    ConstraintParentInverseMatrix,
    ConstraintTranslate,
    ConstraintRotate,
    // Maya's inputs (appended: rig files and the inversion name attributes by the ids above).
    TargetTranslate,
    TargetRotate,
    TargetRotateOrder,
    TargetRotatePivot,
    TargetRotateTranslate,
    TargetScale,
    TargetParentMatrix,
    TargetJointOrient,
    TargetScaleCompensate,
    TargetInverseScale,
    TargetOffsetTranslate,
    TargetOffsetRotate,
    ConstraintRotatePivot,
    ConstraintRotateTranslate,
    InterpType,
    EnableRestPosition
};

constexpr constraint::RotateFrame rotateFrame{ConstraintRotateOrder, ConstraintJointOrient};
constexpr constraint::MayaTargetIds mayaTargets{
    TargetTranslate, TargetRotate,       TargetRotateOrder, TargetRotatePivot,     TargetRotateTranslate,
    TargetScale,     TargetParentMatrix, TargetJointOrient, TargetScaleCompensate, TargetInverseScale};

// Where target i puts the object: its world position and orientation.
struct Placement {
    Eigen::Vector3d position;
    Eigen::Quaterniond rotation;
};

Placement placementOf(const ComputeContext& c, const constraint::TargetFrame& t)
{
    if (c.getBool(MaintainOffset) || t.fromMatrix) {
        const Eigen::Matrix4d offset =
            c.getBool(MaintainOffset)
                ? Eigen::Matrix4d(constraint::safeInverse(constraint::matrixElement(c, TargetRestMatrix, t.index)) *
                                  c.getMatrix(RestMatrix))
                : constraint::matrixElement(c, TargetOffset, t.index);
        const Eigen::Matrix4d placed = t.world * offset;
        return {placed.topRightCorner<3, 1>(), constraint::rotationOf(placed)};
    }
    // Maya's offsets: targetOffsetTranslate from the target's rotate pivot, along the target's axes (its scale
    // included), targetOffsetRotate a rotation after the target's orientation, in the constrained object's rotate
    // order. (A control whose pivot was moved holds its joint where Maya does: the offset is from the pivot.)
    Eigen::Vector3d offsetTranslate = Eigen::Vector3d::Zero();
    Eigen::Vector3d offsetRotate = Eigen::Vector3d::Zero();
    offsetTranslate = c.elements<Eigen::Vector3d>(TargetOffsetTranslate).valueOr(t.index, offsetTranslate);
    offsetRotate = c.elements<Eigen::Vector3d>(TargetOffsetRotate).valueOr(t.index, offsetRotate);
    const auto order = rotateOrderFromIndex(c.getEnum(ConstraintRotateOrder)).value_or(RotateOrder::xyz);
    const Eigen::Quaterniond rotation(constraint::rotationOf(t.world).toRotationMatrix() *
                                      eulerToMatrix(offsetRotate, order));
    return {t.pivot + t.world.topLeftCorner<3, 3>() * offsetTranslate, rotation.normalized()};
}

class ParentConstraintNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        const auto targets = constraint::gatherFrames(c, TargetMatrix, TargetWeight, mayaTargets);
        std::vector<constraint::TargetFrame> placed;  // pivots at the placements, for the weighted mean
        std::vector<std::pair<Eigen::Quaterniond, double>> rotations;
        for (const constraint::TargetFrame& t : targets) {
            const Placement p = placementOf(c, t);
            constraint::TargetFrame at = t;
            at.pivot = p.position;
            placed.push_back(at);
            rotations.emplace_back(p.rotation, t.weight);
        }
        const Eigen::Matrix4d& parentInverse = c.getMatrix(ConstraintParentInverseMatrix);
        const auto position = constraint::weightedPivot(placed);
        const auto average = constraint::blendRotations(rotations, c.getEnum(InterpType));
        const bool rest = c.getBool(EnableRestPosition);
        const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
        // Maya places the object's rotate pivot, so its pivot offsets come off the translate.
        c.setOutput(ConstraintTranslate,
                    position
                        ? Eigen::Vector3d(constraint::toParentSpace(parentInverse, *position) -
                                          c.getVector3(ConstraintRotatePivot) - c.getVector3(ConstraintRotateTranslate))
                        : (rest ? c.getVector3(RestTranslate) : zero));
        if (!average) {
            c.setOutput(ConstraintRotate, rest ? c.getVector3(RestRotate) : zero);
            return;
        }
        c.setOutput(ConstraintRotate,
                    constraint::rotateFor(c, rotateFrame, parentInverse, average->toRotationMatrix()));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeParentConstraintType()
{
    NodeTypeBuilder b("parentConstraint");
    b.description(
        "Makes an object follow its targets as if it were their child, as Maya's parentConstraint: target i "
        "puts the object at M_i = targetMatrix[i] * O_i in world space, O_i = targetOffset[i], or "
        "targetRestMatrix[i]^-1 * restMatrix when maintainOffset is on; from Maya's inputs, at position "
        "W_i * targetOffsetTranslate[i] and orientation R(W_i) * R(targetOffsetRotate[i], constraintRotateOrder), "
        "W_i = targetParentMatrix[i] * the target's local matrix (docs/constraints.md) (stateless: the rest matrices "
        "are constant inputs, nothing is captured). Positions blend linearly and orientations as orientConstraint "
        "(normalized weighted quaternion sum, signs aligned to the first target of nonzero weight; interpType "
        "shortest / longest slerp instead); "
        "constraintTranslate = constraintParentInverseMatrix * position - constraintRotatePivot - "
        "constraintRotateTranslate, constraintRotate = Euler angles in "
        "constraintRotateOrder of JO^-1 * P^-1 * orientation. With every weight zero (or no target) it "
        "outputs restTranslate and restRotate. Wiring: docs/constraints.md.");
    constraint::addTargets(
        b, TargetMatrix, TargetWeight,
        "World matrix of target i (connect from target.worldMatrix). A target exists where this element exists.");
    b.input(TargetOffset, "targetOffset", ValueType::Matrix4)
        .array()
        .doc(
            "The object's matrix relative to target i (Maya's targetOffsetTranslate and targetOffsetRotate as "
            "one matrix): M_i = targetMatrix[i] * targetOffset[i]; identity when absent. Ignored when "
            "maintainOffset is on.");
    b.input(MaintainOffset, "maintainOffset", ValueType::Bool)
        .defaultValue(false)
        .doc(
            "On: each target's offset is targetRestMatrix[i]^-1 * restMatrix, so the object keeps the "
            "relation to each target it had in the rest pose (Maya's -maintainOffset, computed from constant "
            "inputs instead of captured).");
    b.input(RestMatrix, "restMatrix", ValueType::Matrix4)
        .doc("World matrix of the constrained object in the rest pose (a constant), used by maintainOffset.");
    b.input(TargetRestMatrix, "targetRestMatrix", ValueType::Matrix4)
        .array()
        .doc(
            "World matrix of target i in the rest pose (a constant; identity when absent or singular), used "
            "by maintainOffset.");
    constraint::addRotateFrame(b, rotateFrame);
    constraint::addRestTranslate(b, RestTranslate)
        .doc("constraintTranslate when every weight is zero or there is no target (Maya's rest position), cm.");
    constraint::addRestRotate(b, RestRotate)
        .doc("constraintRotate when every weight is zero or there is no target (Maya's rest position).");
    constraint::addParentInverse(b, ConstraintParentInverseMatrix);
    constraint::addTranslateOutput(b, ConstraintTranslate);
    constraint::addRotateOutput(b, ConstraintRotate);
    constraint::addMayaTargets(b, mayaTargets);
    b.input(TargetOffsetTranslate, "targetOffsetTranslate", ValueType::Vector3)
        .array()
        .unit(Unit::Distance)
        .shortName("tot")
        .mayaCompound("target", "tg")
        .doc(
            "Maya's target[i].targetOffsetTranslate: the constrained object's pivot in target i's space (its scale "
            "included), cm; used where targetMatrix[i] is absent and maintainOffset is off.");
    b.input(TargetOffsetRotate, "targetOffsetRotate", ValueType::Vector3)
        .array()
        .unit(Unit::Angle)
        .shortName("tor")
        .mayaCompound("target", "tg")
        .doc(
            "Maya's target[i].targetOffsetRotate: the constrained object's orientation relative to target i's, "
            "Euler angles in constraintRotateOrder; used where targetMatrix[i] is absent and maintainOffset is off.");
    constraint::addConstraintPivot(b, ConstraintRotatePivot, ConstraintRotateTranslate);
    constraint::addInterpType(b, InterpType);
    constraint::addEnableRestPosition(b, EnableRestPosition);
    b.affectsAll();
    return b.factory<ParentConstraintNode>().build();
}

}  // namespace rig
