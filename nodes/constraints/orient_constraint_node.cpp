// orientConstraint: Maya's orientConstraint, the quaternion average of target world orientations as
// rotate values of the constrained object (docs/constraints.md).
#include "nodes/builtin_nodes.h"
#include "nodes/constraints/constraint_math.h"
#include "nodes/enum_names.h"

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
        const auto order = rotateOrderFromIndex(c.getEnum(ConstraintRotateOrder)).value_or(RotateOrder::xyz);
        c.setOutput(ConstraintRotate, constraint::rotateFromWorld(c.getMatrix(ConstraintParentInverseMatrix), world,
                                                                  c.getVector3(ConstraintJointOrient), order));
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
    b.input(TargetMatrix, "targetMatrix", ValueType::Matrix4)
        .array()
        .doc(
            "World matrix of target i (connect from target.worldMatrix); its rotation, scale and shear "
            "removed, is the target's orientation. A target exists where this element exists.");
    b.input(TargetWeight, "targetWeight", ValueType::Double)
        .array()
        .defaultValue(1.0)
        .min(0.0)
        .keyable()
        .doc("Weight of target i (1 when the element is absent); weights are normalized by their sum.");
    b.input(Offset, "offset", ValueType::Vector3)
        .unit(Unit::Angle)
        .keyable()
        .doc(
            "Rotation (xyz order) applied after the average, in the constrained object's own axes (Maya's "
            "offset; maintain offset = the averaged orientation's inverse times the object's at bind time).");
    b.input(ConstraintRotateOrder, "constraintRotateOrder", ValueType::Enum)
        .enumNames(rotateOrderEnumNames())
        .doc("The constrained object's rotateOrder (set the same value; connecting it would close a cycle).");
    b.input(ConstraintJointOrient, "constraintJointOrient", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc(
            "The constrained joint's jointOrient (xyz), removed from the result so that it is the joint's "
            "rotate; zero for a transform. Set the same value as the joint's.");
    b.input(RestRotate, "restRotate", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc("The output when every weight is zero or there is no target (Maya's rest position).");
    b.input(ConstraintParentInverseMatrix, "constraintParentInverseMatrix", ValueType::Matrix4)
        .doc(
            "World inverse matrix of the constrained object's parent (connect from parent.worldInverseMatrix; "
            "identity at the root).");
    b.output(ConstraintRotate, "constraintRotate", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc(
            "Rotate for the constrained object in constraintRotateOrder (connect to its rotate); of the "
            "equivalent Euler triples, the one nearest to zero.");
    for (AttrId in = TargetMatrix; in < ConstraintRotate; ++in) b.affects(in, {ConstraintRotate});
    return b.factory<OrientConstraintNode>().build();
}

}  // namespace rig
