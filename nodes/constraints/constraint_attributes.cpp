#include "nodes/constraints/constraint_attributes.h"

#include <utility>

#include "nodes/constraints/constraint_math.h"
#include "nodes/enum_names.h"

namespace rig::constraint {

void addTargets(NodeTypeBuilder& b, AttrId matrices, AttrId weights, std::string matrixDoc)
{
    b.input(matrices, "targetMatrix", ValueType::Matrix4).array().doc(std::move(matrixDoc));
    b.input(weights, "targetWeight", ValueType::Double)
        .array()
        .defaultValue(1.0)
        .min(0.0)
        .keyable()
        .shortName("tw")
        .mayaCompound("target", "tg")
        .doc("Weight of target i (1 when the element is absent); weights are normalized by their sum.");
}

void addMayaTargets(NodeTypeBuilder& b, const MayaTargetIds& ids)
{
    const auto child = [&](AttrId id, const char* name, const char* shortName, ValueType type) {
        return b.input(id, name, type).array().shortName(shortName).mayaCompound("target", "tg");
    };
    if (ids.translate >= 0)
        child(ids.translate, "targetTranslate", "tt", ValueType::Vector3)
            .unit(Unit::Distance)
            .doc("Maya's target[i].targetTranslate: target i's translate, cm (connect target.translate).");
    if (ids.rotate >= 0)
        child(ids.rotate, "targetRotate", "tr", ValueType::Vector3)
            .unit(Unit::Angle)
            .doc("Maya's target[i].targetRotate: target i's rotate, in targetRotateOrder (connect target.rotate).");
    if (ids.rotateOrder >= 0)
        child(ids.rotateOrder, "targetRotateOrder", "tro", ValueType::Enum)
            .enumNames(rotateOrderEnumNames())
            .doc("Maya's target[i].targetRotateOrder: target i's rotateOrder (connect target.rotateOrder).");
    if (ids.rotatePivot >= 0)
        child(ids.rotatePivot, "targetRotatePivot", "trp", ValueType::Vector3)
            .unit(Unit::Distance)
            .doc("Maya's target[i].targetRotatePivot: target i's rotatePivot, cm (connect target.rotatePivot).");
    if (ids.rotateTranslate >= 0)
        child(ids.rotateTranslate, "targetRotateTranslate", "trt", ValueType::Vector3)
            .unit(Unit::Distance)
            .doc(
                "Maya's target[i].targetRotateTranslate: target i's rotatePivotTranslate, cm (connect "
                "target.rotatePivotTranslate).");
    if (ids.scale >= 0)
        child(ids.scale, "targetScale", "ts", ValueType::Vector3)
            .defaultValue(Eigen::Vector3d(1, 1, 1))
            .doc("Maya's target[i].targetScale: target i's scale (connect target.scale).");
    if (ids.parentMatrix >= 0)
        child(ids.parentMatrix, "targetParentMatrix", "tpm", ValueType::Matrix4)
            .doc(
                "Maya's target[i].targetParentMatrix: target i's parentMatrix, its parent's world matrix (connect "
                "target.parentMatrix); identity at the root.");
    if (ids.jointOrient >= 0)
        child(ids.jointOrient, "targetJointOrient", "tjo", ValueType::Vector3)
            .unit(Unit::Angle)
            .doc("Maya's target[i].targetJointOrient: a joint target's jointOrient, xyz (connect target.jointOrient).");
    if (ids.scaleCompensate >= 0)
        child(ids.scaleCompensate, "targetScaleCompensate", "tsc", ValueType::Bool)
            .defaultValue(false)
            .doc(
                "Maya's target[i].targetScaleCompensate: a joint target's segmentScaleCompensate; on, "
                "targetInverseScale is removed after its translate (connect target.segmentScaleCompensate).");
    if (ids.inverseScale >= 0)
        child(ids.inverseScale, "targetInverseScale", "tis", ValueType::Vector3)
            .defaultValue(Eigen::Vector3d(1, 1, 1))
            .doc("Maya's target[i].targetInverseScale: a joint target's inverseScale (connect target.inverseScale).");
}

void addConstraintPivot(NodeTypeBuilder& b, AttrId rotatePivot, AttrId rotateTranslate)
{
    b.input(rotatePivot, "constraintRotatePivot", ValueType::Vector3)
        .shortName("crp")
        .unit(Unit::Distance)
        .doc(
            "The constrained object's rotatePivot, cm (Maya connects object.rotatePivot; set the same constant): "
            "the object's pivot, not its origin, is put on the result.");
    b.input(rotateTranslate, "constraintRotateTranslate", ValueType::Vector3)
        .shortName("crt")
        .unit(Unit::Distance)
        .doc("The constrained object's rotatePivotTranslate, cm (Maya connects object.rotatePivotTranslate).");
}

void addEnableRestPosition(NodeTypeBuilder& b, AttrId id)
{
    b.input(id, "enableRestPosition", ValueType::Bool)
        .shortName("erp")
        .defaultValue(true)
        .doc(
            "On (the default here and what Maya's constraint commands set): every weight zero gives the rest "
            "value. Off: Maya leaves the output uncomputed; this node gives the output's default (zero, or one "
            "for a scale), what Maya shows on opening such a scene.");
}

void addInterpType(NodeTypeBuilder& b, AttrId id)
{
    b.input(id, "interpType", ValueType::Enum)
        .shortName("int")
        .enumNames({"noFlip", "average", "shortest", "longest", "cache"})
        .defaultValue(static_cast<int>(Average))
        .doc(
            "How target orientations blend (Maya's interpType): average = normalized weighted quaternion sum, signs "
            "aligned (the default); shortest / longest = weighted slerps in index order the short / long way "
            "round; noFlip and cache are history-dependent in Maya and read as average.");
}

void addParentScale(NodeTypeBuilder& b, ParentScale ids)
{
    b.input(ids.inverseScale, "inverseScale", ValueType::Vector3)
        .shortName("is")
        .defaultValue(Eigen::Vector3d(1, 1, 1))
        .doc(
            "The constrained joint's inverseScale (Maya connects joint.inverseScale; the parent's scale): with "
            "scaleCompensate on, the joint's parent frame is inverse(constraintParentInverseMatrix) * "
            "diag(1 / inverseScale), as segment scale compensation makes it.");
    b.input(ids.scaleCompensate, "scaleCompensate", ValueType::Bool)
        .shortName("sc")
        .defaultValue(true)
        .doc("On: inverseScale is removed from the parent frame (see inverseScale).");
}

Eigen::Matrix4d parentFrame(const ComputeContext& c, AttrId parentInverse, ParentScale ids)
{
    Eigen::Matrix4d frame = safeInverse(c.getMatrix(parentInverse));
    if (!c.getBool(ids.scaleCompensate)) return frame;
    const Eigen::Vector3d& inverseScale = c.getVector3(ids.inverseScale);
    for (int k = 0; k < 3; ++k)
        if (inverseScale[k] != 0.0) frame.col(k) /= inverseScale[k];  // a zero is left uncompensated (as joints)
    return frame;
}

AttributeBuilder addOffset(NodeTypeBuilder& b, AttrId id, Unit unit)
{
    return b.input(id, "offset", ValueType::Vector3).shortName("o").unit(unit).keyable();
}

AttributeBuilder addRestTranslate(NodeTypeBuilder& b, AttrId id)
{
    return b.input(id, "restTranslate", ValueType::Vector3)
        .shortName("rst")
        .childShortNames("rtx", "rty", "rtz")
        .unit(Unit::Distance);
}

AttributeBuilder addRestRotate(NodeTypeBuilder& b, AttrId id)
{
    return b.input(id, "restRotate", ValueType::Vector3)
        .shortName("rsrr")
        .childShortNames("rrx", "rry", "rrz")
        .unit(Unit::Angle);
}

AttributeBuilder addParentInverse(NodeTypeBuilder& b, AttrId id)
{
    return b.input(id, "constraintParentInverseMatrix", ValueType::Matrix4)
        .shortName("cpim")
        .doc(
            "World inverse matrix of the constrained object's parent (connect from parent.worldInverseMatrix; "
            "identity at the root).");
}

void addRotateFrame(NodeTypeBuilder& b, RotateFrame ids)
{
    b.input(ids.rotateOrder, "constraintRotateOrder", ValueType::Enum)
        .shortName("cro")
        .enumNames(rotateOrderEnumNames())
        .doc("The constrained object's rotateOrder (set the same value; connecting it would close a cycle).");
    b.input(ids.jointOrient, "constraintJointOrient", ValueType::Vector3)
        .shortName("cjo")
        .unit(Unit::Angle)
        .doc(
            "The constrained joint's jointOrient (xyz), removed from the result so that it is the joint's "
            "rotate; zero for a transform. Set the same value as the joint's.");
}

AttributeBuilder addTranslateOutput(NodeTypeBuilder& b, AttrId id)
{
    return b.output(id, "constraintTranslate", ValueType::Vector3)
        .shortName("ct")
        .unit(Unit::Distance)
        .doc("Translate for the constrained object, cm (connect to its translate).");
}

void addRotateOutput(NodeTypeBuilder& b, AttrId id)
{
    b.output(id, "constraintRotate", ValueType::Vector3)
        .shortName("cr")
        .unit(Unit::Angle)
        .doc(
            "Rotate for the constrained object in constraintRotateOrder (connect to its rotate); of the "
            "equivalent Euler triples, the one nearest to zero.");
}

Eigen::Vector3d rotateFor(const ComputeContext& c, RotateFrame ids, const Eigen::Matrix4d& parentInverse,
                          const Eigen::Matrix3d& world)
{
    return rotateInFrame(c, ids, safeInverse(parentInverse), world);
}

Eigen::Vector3d rotateInFrame(const ComputeContext& c, RotateFrame ids, const Eigen::Matrix4d& parentFrame,
                              const Eigen::Matrix3d& world)
{
    const auto order = rotateOrderFromIndex(c.getEnum(ids.rotateOrder)).value_or(RotateOrder::xyz);
    return rotateFromFrame(parentFrame, world, c.getVector3(ids.jointOrient), order);
}

}  // namespace rig::constraint
