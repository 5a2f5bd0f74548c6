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
    ConstraintRotate
};

constexpr constraint::RotateFrame rotateFrame{ConstraintRotateOrder, ConstraintJointOrient};

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
        "targetRestMatrix[i]^-1 * restMatrix when maintainOffset is on (stateless: the rest matrices are "
        "constant inputs, nothing is captured). Positions blend linearly and orientations as orientConstraint "
        "(normalized weighted quaternion sum, signs aligned to the first target of nonzero weight); "
        "constraintTranslate = constraintParentInverseMatrix * position, constraintRotate = Euler angles in "
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
    for (AttrId in : {TargetMatrix, TargetWeight, TargetOffset, MaintainOffset, RestMatrix, TargetRestMatrix,
                      ConstraintParentInverseMatrix})
        b.affects(in, {ConstraintTranslate, ConstraintRotate});
    b.affects(RestTranslate, {ConstraintTranslate});
    for (AttrId in : {ConstraintRotateOrder, ConstraintJointOrient, RestRotate}) b.affects(in, {ConstraintRotate});
    return b.factory<ParentConstraintNode>().build();
}

}  // namespace rig
