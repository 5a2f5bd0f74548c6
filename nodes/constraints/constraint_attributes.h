#pragma once
// The attributes the constraint node types share (docs/constraints.md), declared once: name, type, unit, flags
// and, where every type means the same by it, the description. A type passes its own enum's ids (NodeTypeBuilder
// checks that they follow the declaration order) and gives a description where it reads the attribute its own
// way; the readers below turn the shared inputs into values.

#include <string>

#include <Eigen/Core>

#include "graph/node.h"
#include "graph/node_type.h"
#include "nodes/constraints/constraint_math.h"

namespace rig::constraint {

// targetMatrix[] and targetWeight[] (Maya's target[i].targetWeight, tw; read by gatherFrames); `matrixDoc` says
// what the type takes from a target's world matrix.
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

// --- Maya's inputs (docs/constraints.md, "Maya's inputs") ---

// Maya's per-target inputs (MayaTargetIds, constraint_math.h), children of its compound multi attribute target (tg)
// flattened into parallel arrays (Maya's ".tg[2].tt" is targetTranslate[2]), declared in MayaTargetIds' member order.
void addMayaTargets(NodeTypeBuilder& b, const MayaTargetIds& ids);

// constraintRotatePivot (crp) and constraintRotateTranslate (crt): the constrained object's rotatePivot and
// rotatePivotTranslate, whose sum Maya removes so that the object's pivot (not its origin) lands on the result.
void addConstraintPivot(NodeTypeBuilder& b, AttrId rotatePivot, AttrId rotateTranslate);

// enableRestPosition (erp): on, the rest value is the output when every weight is zero.
void addEnableRestPosition(NodeTypeBuilder& b, AttrId id);

// interpType (int): how orientations blend (Maya's enum noFlip, average, shortest, longest, cache).
void addInterpType(NodeTypeBuilder& b, AttrId id);

// inverseScale (is) and scaleCompensate (sc): a constrained joint's inverseScale, removed from its parent's frame
// when scaleCompensate is on (segment scale compensation).
struct ParentScale {
    AttrId inverseScale;
    AttrId scaleCompensate;
};
void addParentScale(NodeTypeBuilder& b, ParentScale ids);

// The constrained object's parent frame (inverse(constraintParentInverseMatrix)), its inverse scale removed.
Eigen::Matrix4d parentFrame(const ComputeContext& c, AttrId parentInverse, ParentScale ids);

// The rotate values in the type's constraintRotateOrder that give the constrained object the world orientation
// `world`, its constraintJointOrient removed (rotateFromWorld).
Eigen::Vector3d rotateFor(const ComputeContext& c, RotateFrame ids, const Eigen::Matrix4d& parentInverse,
                          const Eigen::Matrix3d& world);

}  // namespace rig::constraint

namespace rig::constraint {

// rotateFor with the parent's world frame given (parentFrame, e.g. with a joint's inverse scale removed).
Eigen::Vector3d rotateInFrame(const ComputeContext& c, RotateFrame ids, const Eigen::Matrix4d& parentFrame,
                              const Eigen::Matrix3d& world);

}  // namespace rig::constraint
