#pragma once
// The node library's built-in types. registerBuiltinNodes adds them all to a registry; each make*
// function builds one type (one file each under nodes/).

#include <memory>
#include <string>
#include <vector>

#include "graph/node_registry.h"
#include "graph/value.h"
#include "nodes/anim_curve_math.h"

namespace rig {

void registerBuiltinNodes(NodeRegistry& registry);
// A registry holding the built-in types, ready for a Graph.
std::shared_ptr<NodeRegistry> makeBuiltinRegistry();

std::shared_ptr<const NodeType> makeTransformType();
std::shared_ptr<const NodeType> makeJointType();
std::shared_ptr<const NodeType> makeTimeType();
std::shared_ptr<const NodeType> makeCharacterType();  // nodes/curves: Maya's character set (docs/maya.md)
// animCurveTU, animCurveTA, animCurveTL, animCurveTT, animCurveUU, animCurveUA, animCurveUL, animCurveUT.
std::shared_ptr<const NodeType> makeAnimCurveType(const char* typeName);
// Maya's code of a tangent type in a scene's animCurve (.kit, .kot: 18 for auto, 9 for spline, ...).
int mayaTangentCode(TangentType type);

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
// Maya's utility and animation-layer types (nodes/math/, docs/nodes.md).
std::shared_ptr<const NodeType> makeUnitConversionType();
// The conversionFactor a unitConversion node takes, between a `source` plug and a `destination` plug joined by
// converting connections (a YAML rig's), for Maya's factor `mayaFactor`: Maya multiplies internal units (radians),
// while such a connection between an angle plug and a unitless one already converts radians and degrees, so that
// part is divided out (57.2958 from rotateX into an animCurveUA's input becomes 1). A Maya scene's connections
// convert nothing: its factors are used as they are (docs/maya.md).
double unitConversionFactor(double mayaFactor, Unit source, Unit destination);
std::shared_ptr<const NodeType> makeMultDoubleLinearType();
std::shared_ptr<const NodeType> makeAddDoubleLinearType();
std::shared_ptr<const NodeType> makeBlendWeightedType();
std::shared_ptr<const NodeType> makePairBlendType();
std::shared_ptr<const NodeType> makeDistanceBetweenType();
std::shared_ptr<const NodeType> makeSetRangeType();
std::shared_ptr<const NodeType> makeInverseMatrixType();
std::shared_ptr<const NodeType> makeFloatConstantType();
std::shared_ptr<const NodeType> makeAngleBetweenType();
std::shared_ptr<const NodeType> makeQuatToEulerType();
std::shared_ptr<const NodeType> makeEulerToQuatType();
std::shared_ptr<const NodeType> makeBlendMatrixType();
// animBlendNodeAdditive, animBlendNodeAdditiveDL/DA/F/FA/I16/I32.
std::shared_ptr<const NodeType> makeAnimBlendNodeAdditiveType(const char* typeName);
std::shared_ptr<const NodeType> makeAnimBlendNodeAdditiveRotationType();
std::shared_ptr<const NodeType> makeAnimBlendNodeAdditiveScaleType();
// animBlendNodeEnum, animBlendNodeBoolean.
std::shared_ptr<const NodeType> makeAnimBlendNodeEnumType(const char* typeName);
// Every Maya utility and animation-layer type name registered by the functions above.
const std::vector<std::string>& mayaUtilityTypeNames();
std::shared_ptr<const NodeType> makeIkHandleType();  // nodes/ik, nodes/deformers (docs/ik-and-deformers.md)
std::shared_ptr<const NodeType>
makeMayaIkHandleType();  // nodes/ik: Maya's ikHandle (RP and SC solvers), for .ma scenes
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
std::shared_ptr<const NodeType> makeScaleConstraintType();
// Skeleton-space edits between a clip and a rigInversion node (nodes/edit/, docs/nodes.md).
std::shared_ptr<const NodeType> makeLookAtType();
std::shared_ptr<const NodeType> makeOffsetLayerType();
std::shared_ptr<const NodeType> makeBlendClipsType();

}  // namespace rig
