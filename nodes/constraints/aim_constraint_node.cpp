// aimConstraint: Maya's aimConstraint, turns an object so that its aim vector points at the weighted
// mean of its targets and its up vector leans toward a world up vector (docs/constraints.md).
#include <algorithm>

#include "nodes/builtin_nodes.h"
#include "nodes/constraints/constraint_attributes.h"
#include "nodes/constraints/constraint_math.h"

namespace rig {
namespace {

enum Attr : AttrId {
    TargetMatrix,
    TargetWeight,
    AimVector,
    UpVector,
    WorldUpType,
    WorldUpVector,
    WorldUpMatrix,
    ConstraintTranslate,
    Offset,
    ConstraintRotateOrder,
    ConstraintJointOrient,
    RestRotate,
    ConstraintParentInverseMatrix,
    ConstraintRotate,
    // Maya's inputs (appended: rig files and the inversion name attributes by the ids above).
    TargetTranslate,
    TargetRotatePivot,
    TargetRotateTranslate,
    TargetParentMatrix,
    ConstraintRotatePivot,
    ConstraintRotateTranslate,
    InverseScale,
    ScaleCompensate,
    EnableRestPosition
};

constexpr constraint::RotateFrame rotateFrame{ConstraintRotateOrder, ConstraintJointOrient};
constexpr constraint::MayaTargetIds mayaTargets{.translate = TargetTranslate,
                                                .rotatePivot = TargetRotatePivot,
                                                .rotateTranslate = TargetRotateTranslate,
                                                .parentMatrix = TargetParentMatrix};
constexpr constraint::ParentScale parentScale{InverseScale, ScaleCompensate};

enum UpType { Scene = 0, Object = 1, ObjectRotation = 2, Vector = 3, None = 4 };

// Relative size below which a vector counts as zero (a target on the object, an up vector parallel
// to the aim).
constexpr double degenerate = 1e-9;

class AimConstraintNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        const auto target =
            constraint::weightedPivot(constraint::gatherFrames(c, TargetMatrix, TargetWeight, mayaTargets));
        const Eigen::Vector3d& aim = c.getVector3(AimVector);
        const Eigen::Matrix4d parent = constraint::parentFrame(c, ConstraintParentInverseMatrix, parentScale);
        // The object's rotate pivot (translate + rotatePivot + rotatePivotTranslate in its parent's space) is
        // the point that aims, as in Maya.
        const Eigen::Vector3d pivot = c.getVector3(ConstraintTranslate) + c.getVector3(ConstraintRotatePivot) +
                                      c.getVector3(ConstraintRotateTranslate);
        const Eigen::Vector3d object =
            (constraint::safeInverse(c.getMatrix(ConstraintParentInverseMatrix)) * pivot.homogeneous()).head<3>();
        if (!target) {
            c.setOutput(ConstraintRotate, c.getBool(EnableRestPosition) ? c.getVector3(RestRotate)
                                                                        : Eigen::Vector3d(Eigen::Vector3d::Zero()));
            return;
        }
        const Eigen::Vector3d toTarget = *target - object;
        if (!(aim.norm() > 0.0) || !(toTarget.norm() > degenerate * std::max({1.0, target->norm(), object.norm()}))) {
            c.setOutput(ConstraintRotate, c.getVector3(RestRotate));
            return;
        }
        const Eigen::Vector3d a = aim.normalized();
        const Eigen::Vector3d A = toTarget.normalized();
        const Eigen::Vector3d& jointOrient = c.getVector3(ConstraintJointOrient);

        Eigen::Vector3d worldUp = Eigen::Vector3d::Zero();
        const Eigen::Matrix4d& upMatrix = c.getMatrix(WorldUpMatrix);
        switch (c.getEnum(WorldUpType)) {
            case Scene:
                worldUp = Eigen::Vector3d::UnitY();
                break;
            case Object:
                worldUp = upMatrix.topRightCorner<3, 1>() - object;
                break;
            case ObjectRotation:
                worldUp = upMatrix.topLeftCorner<3, 3>() * c.getVector3(WorldUpVector);
                break;
            case Vector:
                worldUp = c.getVector3(WorldUpVector);
                break;
            default:
                break;  // none
        }
        const Eigen::Vector3d& up = c.getVector3(UpVector);
        const Eigen::Vector3d u = up - up.dot(a) * a;
        const Eigen::Vector3d U = worldUp - worldUp.dot(A) * A;

        Eigen::Matrix3d aimed;
        if (u.norm() > degenerate * up.norm() && U.norm() > degenerate * worldUp.norm()) {
            // The frame (aim, up, aim x up) taken onto (A, U, A x U).
            Eigen::Matrix3d local, world;
            local << a, u.normalized(), a.cross(u.normalized());
            world << A, U.normalized(), A.cross(U.normalized());
            aimed = world * local.transpose();
        } else {
            // No usable up (worldUpType none, or up parallel to aim, or a zero up): the smallest turn
            // from the object's rest frame (rotate = 0) that points the aim vector at the target.
            const Eigen::Matrix3d rest =
                constraint::rotationOf(parent).toRotationMatrix() * eulerToMatrix(jointOrient, RotateOrder::xyz);
            aimed = rest * Eigen::Quaterniond::FromTwoVectors(a, rest.transpose() * A).toRotationMatrix();
        }
        const Eigen::Matrix3d world = aimed * eulerToMatrix(c.getVector3(Offset), RotateOrder::xyz);
        c.setOutput(ConstraintRotate, constraint::rotateInFrame(c, rotateFrame, parent, world));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeAimConstraintType()
{
    NodeTypeBuilder b("aimConstraint");
    b.description(
        "Turns an object so that its aimVector points at the weighted mean of its targets' positions and its "
        "upVector leans toward a world up direction, as Maya's aimConstraint. The object's world position is "
        "inverse(constraintParentInverseMatrix) * (constraintTranslate + constraintRotatePivot + "
        "constraintRotateTranslate) (constant inputs: reading the object itself would close a cycle); a target's "
        "is the translation of targetMatrix[i] or targetParentMatrix[i] * (targetTranslate[i] + "
        "targetRotatePivot[i] + targetRotateTranslate[i]). With A the unit direction to the target, a the unit "
        "aimVector, u and U the parts of upVector and of the world up orthogonal to a and A: W = [A, U, A x U] * [a, "
        "u, a x u]^T "
        "* R(offset); constraintRotate = Euler angles in constraintRotateOrder of JO^-1 * P^-1 * W, P the rotation "
        "of the parent's frame (inverseScale removed when scaleCompensate is on). "
        "Degenerate cases never give NaN: no usable up (worldUpType none, up parallel to aim, zero up) turns "
        "the object's rest frame by the smallest rotation taking the aim vector onto A; every weight zero, no "
        "target, a target on the object (within 1e-9 relative) or a zero aimVector give restRotate.");
    constraint::addTargets(b, TargetMatrix, TargetWeight,
                           "World matrix of target i (connect from target.worldMatrix); its translation is the "
                           "point aimed at. A target exists where this element exists.");
    b.input(AimVector, "aimVector", ValueType::Vector3)
        .shortName("a")
        .defaultValue(Eigen::Vector3d(1, 0, 0))
        .keyable()
        .doc("The object's local axis that points at the target (any length).");
    b.input(UpVector, "upVector", ValueType::Vector3)
        .shortName("u")
        .defaultValue(Eigen::Vector3d(0, 1, 0))
        .keyable()
        .doc(
            "The object's local axis that leans toward the world up direction (its part orthogonal to "
            "aimVector is used).");
    b.input(WorldUpType, "worldUpType", ValueType::Enum)
        .shortName("wut")
        .enumNames({"scene", "object", "objectRotation", "vector", "none"})
        .defaultValue(static_cast<int>(Vector))
        .doc(
            "Where the world up direction comes from (Maya's set): scene = +Y; object = from the object "
            "toward the translation of worldUpMatrix; objectRotation = worldUpVector in worldUpMatrix's axes "
            "(its 3x3 part times worldUpVector); vector = worldUpVector in world space (the default); none = "
            "no up: the smallest turn from the rest frame.");
    b.input(WorldUpVector, "worldUpVector", ValueType::Vector3)
        .shortName("wu")
        .defaultValue(Eigen::Vector3d(0, 1, 0))
        .keyable()
        .doc(
            "The world up direction for worldUpType vector; for objectRotation, expressed in worldUpMatrix's "
            "axes.");
    b.input(WorldUpMatrix, "worldUpMatrix", ValueType::Matrix4)
        .shortName("wum")
        .doc(
            "World matrix of the up object for worldUpType object and objectRotation (connect from "
            "upObject.worldMatrix).");
    b.input(ConstraintTranslate, "constraintTranslate", ValueType::Vector3)
        .shortName("ct")
        .unit(Unit::Distance)
        .doc(
            "The constrained object's translate, cm: set the same constant, or connect the source that drives "
            "the object's translate (not the object itself: that closes a cycle).");
    constraint::addOffset(b, Offset, Unit::Angle)
        .doc("Rotation (xyz order) applied after aiming, in the object's own axes (Maya's offset).");
    constraint::addRotateFrame(b, rotateFrame);
    constraint::addRestRotate(b, RestRotate)
        .doc(
            "The output when there is nothing to aim at: every weight zero, no target, the target on the "
            "object, or a zero aimVector (Maya's rest position).");
    constraint::addParentInverse(b, ConstraintParentInverseMatrix);
    constraint::addRotateOutput(b, ConstraintRotate);
    constraint::addMayaTargets(b, mayaTargets);
    constraint::addConstraintPivot(b, ConstraintRotatePivot, ConstraintRotateTranslate);
    constraint::addParentScale(b, parentScale);
    constraint::addEnableRestPosition(b, EnableRestPosition);
    b.affectsAll();
    return b.factory<AimConstraintNode>().build();
}

}  // namespace rig
