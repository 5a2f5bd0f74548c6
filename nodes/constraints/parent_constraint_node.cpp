// parentConstraint: Maya's parentConstraint, the object follows its targets as if it were their child
// (docs/constraints.md).
#include "nodes/builtin_nodes.h"
#include "nodes/constraints/constraint_math.h"
#include "nodes/enum_names.h"

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
    ConstraintRotate
};

class ParentConstraintNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        std::vector<constraint::Target> targets = constraint::gatherTargets(c, TargetMatrix, TargetWeight);
        const bool maintain = c.getBool(MaintainOffset);
        const Eigen::Matrix4d& rest = c.getMatrix(RestMatrix);
        std::vector<std::pair<Eigen::Quaterniond, double>> rotations;
        for (constraint::Target& t : targets) {
            const Eigen::Matrix4d offset =
                maintain ? Eigen::Matrix4d(
                               constraint::safeInverse(constraint::matrixElement(c, TargetRestMatrix, t.index)) * rest)
                         : constraint::matrixElement(c, TargetOffset, t.index);
            t.matrix = t.matrix * offset;  // where target i puts the object, in world space
            rotations.emplace_back(constraint::rotationOf(t.matrix), t.weight);
        }
        const Eigen::Matrix4d& parentInverse = c.getMatrix(ConstraintParentInverseMatrix);
        const auto position = constraint::weightedPosition(targets);
        const auto average = constraint::averageRotation(rotations);
        c.setOutput(ConstraintTranslate,
                    position ? constraint::toParentSpace(parentInverse, *position) : c.getVector3(RestTranslate));
        if (!average) {
            c.setOutput(ConstraintRotate, c.getVector3(RestRotate));
            return;
        }
        const auto order = rotateOrderFromIndex(c.getEnum(ConstraintRotateOrder)).value_or(RotateOrder::xyz);
        c.setOutput(ConstraintRotate, constraint::rotateFromWorld(parentInverse, average->toRotationMatrix(),
                                                                  c.getVector3(ConstraintJointOrient), order));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeParentConstraintType()
{
    NodeTypeBuilder b("parentConstraint");
    b.description(
        "Makes an object follow its targets as if it were their child, as Maya's parentConstraint: target i "
        "puts the object at M_i = targetMatrix[i] * O_i in world space, O_i = targetOffset[i], or "
        "targetRestMatrix[i]^-1 * restMatrix when maintainOffset is on (stateless: the rest matrices are "
        "constant inputs, nothing is captured). Positions blend linearly and orientations as orientConstraint "
        "(normalized weighted quaternion sum, signs aligned to the first target of nonzero weight); "
        "constraintTranslate = constraintParentInverseMatrix * position, constraintRotate = Euler angles in "
        "constraintRotateOrder of JO^-1 * P^-1 * orientation. With every weight zero (or no target) it "
        "outputs restTranslate and restRotate. Wiring: docs/constraints.md.");
    b.input(TargetMatrix, "targetMatrix", ValueType::Matrix4)
        .array()
        .doc(
            "World matrix of target i (connect from target.worldMatrix). A target exists where this element "
            "exists.");
    b.input(TargetWeight, "targetWeight", ValueType::Double)
        .array()
        .defaultValue(1.0)
        .min(0.0)
        .keyable()
        .doc("Weight of target i (1 when the element is absent); weights are normalized by their sum.");
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
    b.input(ConstraintRotateOrder, "constraintRotateOrder", ValueType::Enum)
        .enumNames(rotateOrderEnumNames())
        .doc("The constrained object's rotateOrder (set the same value; connecting it would close a cycle).");
    b.input(ConstraintJointOrient, "constraintJointOrient", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc(
            "The constrained joint's jointOrient (xyz), removed from the result so that it is the joint's "
            "rotate; zero for a transform. Set the same value as the joint's.");
    b.input(RestTranslate, "restTranslate", ValueType::Vector3)
        .unit(Unit::Distance)
        .doc("constraintTranslate when every weight is zero or there is no target (Maya's rest position), cm.");
    b.input(RestRotate, "restRotate", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc("constraintRotate when every weight is zero or there is no target (Maya's rest position).");
    b.input(ConstraintParentInverseMatrix, "constraintParentInverseMatrix", ValueType::Matrix4)
        .doc(
            "World inverse matrix of the constrained object's parent (connect from parent.worldInverseMatrix; "
            "identity at the root).");
    b.output(ConstraintTranslate, "constraintTranslate", ValueType::Vector3)
        .unit(Unit::Distance)
        .doc("Translate for the constrained object, cm (connect to its translate).");
    b.output(ConstraintRotate, "constraintRotate", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc(
            "Rotate for the constrained object in constraintRotateOrder (connect to its rotate); of the "
            "equivalent Euler triples, the one nearest to zero.");
    for (AttrId in : {TargetMatrix, TargetWeight, TargetOffset, MaintainOffset, RestMatrix, TargetRestMatrix,
                      ConstraintParentInverseMatrix})
        b.affects(in, {ConstraintTranslate, ConstraintRotate});
    b.affects(RestTranslate, {ConstraintTranslate});
    for (AttrId in : {ConstraintRotateOrder, ConstraintJointOrient, RestRotate}) b.affects(in, {ConstraintRotate});
    return b.factory<ParentConstraintNode>().build();
}

}  // namespace rig
