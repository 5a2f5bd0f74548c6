#pragma once
// The node library's built-in types. registerBuiltinNodes adds them all to a registry; each make*
// function builds one type (one file each under nodes/).

#include <memory>

#include "graph/node_registry.h"

namespace rig {

void registerBuiltinNodes(NodeRegistry& registry);
// A registry holding the built-in types, ready for a Graph.
std::shared_ptr<NodeRegistry> makeBuiltinRegistry();

std::shared_ptr<const NodeType> makeTransformType();
std::shared_ptr<const NodeType> makeJointType();
std::shared_ptr<const NodeType> makeTimeType();
// animCurveTU, animCurveTA, animCurveTL, animCurveTT, animCurveUU, animCurveUA, animCurveUL, animCurveUT.
std::shared_ptr<const NodeType> makeAnimCurveType(const char* typeName);

std::shared_ptr<const NodeType> makeMultiplyDivideType();
std::shared_ptr<const NodeType> makePlusMinusAverageType();
std::shared_ptr<const NodeType> makeBlendTwoAttrType();
std::shared_ptr<const NodeType> makeClampType();
std::shared_ptr<const NodeType> makeReverseType();
std::shared_ptr<const NodeType> makeRemapValueType();
std::shared_ptr<const NodeType> makeConditionType();
// Maya's expression node for rig arithmetic (nodes/math/expression.h).
std::shared_ptr<const NodeType> makeExpressionType();
std::shared_ptr<const NodeType> makeMultMatrixType();
std::shared_ptr<const NodeType> makeComposeMatrixType();
std::shared_ptr<const NodeType> makeDecomposeMatrixType();
std::shared_ptr<const NodeType> makeIkHandleType();  // nodes/ik, nodes/deformers (docs/ik-and-deformers.md)
std::shared_ptr<const NodeType> makeBlendColorsType();
std::shared_ptr<const NodeType> makeTwistDistributeType();
std::shared_ptr<const NodeType> makeSlidingPivotType();
std::shared_ptr<const NodeType> makeSquashStretchType();
std::shared_ptr<const NodeType> makeCoupledBendType();
std::shared_ptr<const NodeType> makeSaturateType();
std::shared_ptr<const NodeType> makeSpringType();
std::shared_ptr<const NodeType> makeBvhClipType();       // nodes/clips/, docs/bvh.md
std::shared_ptr<const NodeType> makeSkeletonClipType();  // nodes/clips/, docs/clips.md
// Constraints (nodes/constraints/, docs/constraints.md).
std::shared_ptr<const NodeType> makePointConstraintType();
std::shared_ptr<const NodeType> makeOrientConstraintType();
std::shared_ptr<const NodeType> makeParentConstraintType();
std::shared_ptr<const NodeType> makeAimConstraintType();
std::shared_ptr<const NodeType> makePoleVectorConstraintType();
// Skeleton-space edits between a clip and a rigInversion node (nodes/edit/, docs/nodes.md).
std::shared_ptr<const NodeType> makeLookAtType();
std::shared_ptr<const NodeType> makeOffsetLayerType();
std::shared_ptr<const NodeType> makeBlendClipsType();

}  // namespace rig
