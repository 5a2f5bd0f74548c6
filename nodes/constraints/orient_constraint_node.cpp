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
    ConstraintRotate
};

constexpr constraint::RotateFrame rotateFrame{ConstraintRotateOrder, ConstraintJointOrient};

class OrientConstraintNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        std::vector<std::pair<Eigen::Quaterniond, double>> rotations;
        for (const constraint::Target& t : constraint::gatherTargets(c, TargetMatrix, TargetWeight))
            rotations.emplace_back(constraint::rotationOf(t.matrix), t.weight);
        const auto average = constraint::averageRotation(rotations);
        if (!average) {
            c.setOutput(ConstraintRotate, c.getVector3(RestRotate));
            return;
        }
        const Eigen::Matrix3d world =
            average->toRotationMatrix() * eulerToMatrix(c.getVector3(Offset), RotateOrder::xyz);
        c.setOutput(ConstraintRotate,
                    constraint::rotateFor(c, rotateFrame, c.getMatrix(ConstraintParentInverseMatrix), world));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeOrientConstraintType()
{
    NodeTypeBuilder b("orientConstraint");
    b.description(
        "Turns an object to the weighted average of its targets' world orientations, as Maya's "
        "orientConstraint with interpType average: q = normalize(sum w_i s_i q_i), q_i the rotation of "
        "targetMatrix[i] (scale removed), s_i = +-1 putting q_i in the hemisphere of the first target of "
        "nonzero weight. World orientation W = R(q) * R(offset); constraintRotate = the Euler angles in "
        "constraintRotateOrder of JO^-1 * P^-1 * W, P the parent's world rotation, JO the joint orient. "
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
    for (AttrId in = TargetMatrix; in < ConstraintRotate; ++in) b.affects(in, {ConstraintRotate});
    return b.factory<OrientConstraintNode>().build();
}

}  // namespace rig
