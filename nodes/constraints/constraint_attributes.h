#pragma once
// The attributes the constraint node types share (docs/constraints.md), declared once: name, type, unit, flags
// and, where every type means the same by it, the description. A type passes its own enum's ids (NodeTypeBuilder
// checks that they follow the declaration order) and gives a description where it reads the attribute its own
// way; the readers below turn the shared inputs into values.

#include <string>

#include <Eigen/Core>

#include "graph/node.h"
#include "graph/node_type.h"

namespace rig::constraint {

// targetMatrix[] and targetWeight[] (read by gatherTargets); `matrixDoc` says what the type takes from a target's
// world matrix.
void addTargets(NodeTypeBuilder& b, AttrId matrices, AttrId weights, std::string matrixDoc);

// offset: a keyable vector3 in `unit` (a translation's cm or a rotation's angles), added to the result.
AttributeBuilder addOffset(NodeTypeBuilder& b, AttrId id, Unit unit);

// restTranslate and restRotate: what the type outputs with nothing to follow.
AttributeBuilder addRestTranslate(NodeTypeBuilder& b, AttrId id);
AttributeBuilder addRestRotate(NodeTypeBuilder& b, AttrId id);

// constraintParentInverseMatrix, described as the constrained object's parent's world inverse matrix.
AttributeBuilder addParentInverse(NodeTypeBuilder& b, AttrId id);

// The constrained object's constraintRotateOrder and constraintJointOrient, which turn a world orientation into
// its rotate values.
struct RotateFrame {
    AttrId rotateOrder;
    AttrId jointOrient;
};
void addRotateFrame(NodeTypeBuilder& b, RotateFrame ids);

// The outputs: constraintTranslate (cm, for the object's translate) and constraintRotate (for its rotate).
AttributeBuilder addTranslateOutput(NodeTypeBuilder& b, AttrId id);
void addRotateOutput(NodeTypeBuilder& b, AttrId id);

// The rotate values in the type's constraintRotateOrder that give the constrained object the world orientation
// `world`, its constraintJointOrient removed (rotateFromWorld).
Eigen::Vector3d rotateFor(const ComputeContext& c, RotateFrame ids, const Eigen::Matrix4d& parentInverse,
                          const Eigen::Matrix3d& world);

}  // namespace rig::constraint
