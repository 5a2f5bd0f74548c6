// scaleConstraint: Maya's scaleConstraint, the weighted geometric mean of the targets' world scales as the
// constrained object's scale (docs/constraints.md).
#include <cmath>

#include "nodes/builtin_nodes.h"
#include "nodes/constraints/constraint_attributes.h"
#include "nodes/constraints/constraint_math.h"

namespace rig {
namespace {

enum Attr : AttrId {
    TargetMatrix,
    TargetWeight,
    TargetScale,
    TargetParentMatrix,
    Offset,
    RestScale,
    EnableRestPosition,
    ConstraintScaleCompensate,
    ConstraintParentInverseMatrix,
    ConstraintScale
};

constexpr constraint::MayaTargetIds mayaTargets{.scale = TargetScale, .parentMatrix = TargetParentMatrix};

// The scale factors of a world matrix (decomposeMatrix's), by absolute value.
Eigen::Vector3d worldScale(const Eigen::Matrix4d& matrix)
{
    return decomposeMatrix(matrix, RotateOrder::xyz).scale.cwiseAbs();
}

class ScaleConstraintNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        // Weighted geometric mean, in logarithms; a zero-weight target takes no part (its log may be -inf).
        double total = 0.0;
        Eigen::Vector3d logSum = Eigen::Vector3d::Zero();
        for (const constraint::TargetFrame& t : constraint::gatherFrames(c, TargetMatrix, TargetWeight, mayaTargets)) {
            if (!(t.weight > 0.0)) continue;
            total += t.weight;
            logSum += t.weight * worldScale(t.world).array().log().matrix();
        }
        if (!(total > constraint::minTotalWeight)) {
            c.setOutput(ConstraintScale, c.getBool(EnableRestPosition) ? c.getVector3(RestScale)
                                                                       : Eigen::Vector3d(Eigen::Vector3d::Ones()));
            return;
        }
        const Eigen::Vector3d target = (logSum / total).array().exp().matrix();
        // The object's world scale is its parent's times its own: divide the parent's out (a zero factor of the
        // parent is left alone, as a joint's inverse scale).
        const Eigen::Vector3d parent = worldScale(constraint::safeInverse(c.getMatrix(ConstraintParentInverseMatrix)));
        Eigen::Vector3d scale = target.cwiseProduct(c.getVector3(Offset));
        for (int k = 0; k < 3; ++k)
            if (parent[k] > 0.0) scale[k] /= parent[k];
        c.setOutput(ConstraintScale, scale);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeScaleConstraintType()
{
    NodeTypeBuilder b("scaleConstraint");
    b.description(
        "Scales an object to the weighted geometric mean of its targets' world scales, as Maya's scaleConstraint: "
        "S = exp(sum w_i log s_i / sum w_i) per axis, s_i the scale factors of targetMatrix[i] or, from Maya's "
        "inputs, of targetParentMatrix[i] * scale(targetScale[i]); constraintScale = S * offset / P per axis, P the "
        "scale factors of inverse(constraintParentInverseMatrix), so that the object's world scale is S * offset. "
        "With every weight zero (or no target) it outputs restScale. Wiring: docs/constraints.md.");
    constraint::addTargets(b, TargetMatrix, TargetWeight,
                           "World matrix of target i (connect from target.worldMatrix); its scale factors "
                           "(decomposeMatrix's) are the target's world scale.");
    constraint::addMayaTargets(b, mayaTargets);
    b.input(Offset, "offset", ValueType::Vector3)
        .shortName("o")
        .defaultValue(Eigen::Vector3d(1, 1, 1))
        .keyable()
        .doc(
            "Factors multiplying the result (Maya's offset; maintain offset = the object's scale over the "
            "constrained result at bind time).");
    b.input(RestScale, "restScale", ValueType::Vector3)
        .childShortNames("rsx", "rsy", "rsz")
        .defaultValue(Eigen::Vector3d(1, 1, 1))
        .doc("The output when every weight is zero or there is no target (Maya's rest position).");
    constraint::addEnableRestPosition(b, EnableRestPosition);
    b.input(ConstraintScaleCompensate, "constraintScaleCompensate", ValueType::Bool)
        .shortName("tsc")
        .defaultValue(false)
        .doc(
            "Maya's constraintScaleCompensate (Maya connects joint.segmentScaleCompensate): read, but the result "
            "does not depend on it here; the parent's full world scale is divided out either way.");
    constraint::addParentInverse(b, ConstraintParentInverseMatrix);
    b.output(ConstraintScale, "constraintScale", ValueType::Vector3)
        .shortName("cs")
        .childShortNames("csx", "csy", "csz")
        .doc("Scale for the constrained object (connect to its scale).");
    b.affectsAll();
    return b.factory<ScaleConstraintNode>().build();
}

}  // namespace rig
