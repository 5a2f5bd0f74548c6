// orientConstraint: Maya's orientConstraint, the quaternion average of target world orientations as
// rotate values of the constrained object (docs/constraints.md).
#include "nodes/builtin_nodes.h"
#include "nodes/constraints/constraint_attributes.h"
#include "nodes/constraints/constraint_math.h"

namespace rig {
namespace {

enum Attr : AttrId {
    TargetMatrix,
    TargetWeight,
    Offset,
    ConstraintRotateOrder,
    ConstraintJointOrient,
    RestRotate,
    ConstraintParentInverseMatrix,
    ConstraintRotate,
    // Maya's inputs (appended: rig files and the inversion name attributes by the ids above).
    TargetRotate,
    TargetRotateOrder,
    TargetParentMatrix,
    TargetJointOrient,
    InverseScale,
    ScaleCompensate,
    InterpType,
    EnableRestPosition
};

constexpr constraint::RotateFrame rotateFrame{ConstraintRotateOrder, ConstraintJointOrient};
constexpr constraint::MayaTargetIds mayaTargets{.rotate = TargetRotate,
                                                .rotateOrder = TargetRotateOrder,
                                                .parentMatrix = TargetParentMatrix,
                                                .jointOrient = TargetJointOrient};
constexpr constraint::ParentScale parentScale{InverseScale, ScaleCompensate};

class OrientConstraintNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        std::vector<std::pair<Eigen::Quaterniond, double>> rotations;
        for (const constraint::TargetFrame& t : constraint::gatherFrames(c, TargetMatrix, TargetWeight, mayaTargets))
            rotations.emplace_back(constraint::rotationOf(t.world), t.weight);
        const auto average = constraint::blendRotations(rotations, c.getEnum(InterpType));
        if (!average) {
            c.setOutput(ConstraintRotate, c.getBool(EnableRestPosition) ? c.getVector3(RestRotate)
                                                                        : Eigen::Vector3d(Eigen::Vector3d::Zero()));
            return;
        }
        const Eigen::Matrix3d world =
            average->toRotationMatrix() * eulerToMatrix(c.getVector3(Offset), RotateOrder::xyz);
        const Eigen::Matrix4d parent = constraint::parentFrame(c, ConstraintParentInverseMatrix, parentScale);
        c.setOutput(ConstraintRotate, constraint::rotateInFrame(c, rotateFrame, parent, world));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeOrientConstraintType()
{
    NodeTypeBuilder b("orientConstraint");
    b.description(
        "Turns an object to the weighted average of its targets' world orientations, as Maya's "
        "orientConstraint with interpType average: q = normalize(sum w_i s_i q_i), q_i the rotation of "
        "targetMatrix[i] (scale removed) or, from Maya's inputs, of targetParentMatrix[i] * R(targetJointOrient[i]) "
        "* R(targetRotate[i], targetRotateOrder[i]), s_i = +-1 putting q_i in the hemisphere of the first target of "
        "nonzero weight. World orientation W = R(q) * R(offset); constraintRotate = the Euler angles in "
        "constraintRotateOrder of JO^-1 * P^-1 * W, P the rotation of the parent's world frame (with inverseScale "
        "removed when scaleCompensate is on), JO the joint orient. interpType shortest / longest slerp instead. "
        "With every weight zero (or no target) it outputs restRotate. Wiring: docs/constraints.md.");
    constraint::addTargets(b, TargetMatrix, TargetWeight,
                           "World matrix of target i (connect from target.worldMatrix); its rotation, scale and "
                           "shear removed, is the target's orientation. A target exists where this element exists.");
    constraint::addOffset(b, Offset, Unit::Angle)
        .doc(
            "Rotation (xyz order) applied after the average, in the constrained object's own axes (Maya's "
            "offset; maintain offset = the averaged orientation's inverse times the object's at bind time).");
    constraint::addRotateFrame(b, rotateFrame);
    constraint::addRestRotate(b, RestRotate)
        .doc("The output when every weight is zero or there is no target (Maya's rest position).");
    constraint::addParentInverse(b, ConstraintParentInverseMatrix);
    constraint::addRotateOutput(b, ConstraintRotate);
    constraint::addMayaTargets(b, mayaTargets);
    constraint::addParentScale(b, parentScale);
    constraint::addInterpType(b, InterpType);
    constraint::addEnableRestPosition(b, EnableRestPosition);
    b.affectsAll();
    return b.factory<OrientConstraintNode>().build();
}

}  // namespace rig
