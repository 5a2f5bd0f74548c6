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
        .doc("Weight of target i (1 when the element is absent); weights are normalized by their sum.");
}

AttributeBuilder addOffset(NodeTypeBuilder& b, AttrId id, Unit unit)
{
    return b.input(id, "offset", ValueType::Vector3).unit(unit).keyable();
}

AttributeBuilder addRestTranslate(NodeTypeBuilder& b, AttrId id)
{
    return b.input(id, "restTranslate", ValueType::Vector3).unit(Unit::Distance);
}

AttributeBuilder addRestRotate(NodeTypeBuilder& b, AttrId id)
{
    return b.input(id, "restRotate", ValueType::Vector3).unit(Unit::Angle);
}

AttributeBuilder addParentInverse(NodeTypeBuilder& b, AttrId id)
{
    return b.input(id, "constraintParentInverseMatrix", ValueType::Matrix4)
        .doc(
            "World inverse matrix of the constrained object's parent (connect from parent.worldInverseMatrix; "
            "identity at the root).");
}

void addRotateFrame(NodeTypeBuilder& b, RotateFrame ids)
{
    b.input(ids.rotateOrder, "constraintRotateOrder", ValueType::Enum)
        .enumNames(rotateOrderEnumNames())
        .doc("The constrained object's rotateOrder (set the same value; connecting it would close a cycle).");
    b.input(ids.jointOrient, "constraintJointOrient", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc(
            "The constrained joint's jointOrient (xyz), removed from the result so that it is the joint's "
            "rotate; zero for a transform. Set the same value as the joint's.");
}

AttributeBuilder addTranslateOutput(NodeTypeBuilder& b, AttrId id)
{
    return b.output(id, "constraintTranslate", ValueType::Vector3)
        .unit(Unit::Distance)
        .doc("Translate for the constrained object, cm (connect to its translate).");
}

void addRotateOutput(NodeTypeBuilder& b, AttrId id)
{
    b.output(id, "constraintRotate", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc(
            "Rotate for the constrained object in constraintRotateOrder (connect to its rotate); of the "
            "equivalent Euler triples, the one nearest to zero.");
}

Eigen::Vector3d rotateFor(const ComputeContext& c, RotateFrame ids, const Eigen::Matrix4d& parentInverse,
                          const Eigen::Matrix3d& world)
{
    const auto order = rotateOrderFromIndex(c.getEnum(ids.rotateOrder)).value_or(RotateOrder::xyz);
    return rotateFromWorld(parentInverse, world, c.getVector3(ids.jointOrient), order);
}

}  // namespace rig::constraint
