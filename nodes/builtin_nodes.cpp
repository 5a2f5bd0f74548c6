#include "nodes/builtin_nodes.h"

namespace rig {

void registerBuiltinNodes(NodeRegistry& registry)
{
    registry.add(makeTransformType());
    registry.add(makeJointType());
    registry.add(makeTimeType());
    for (const char* name : {"animCurveTU", "animCurveTA", "animCurveTL", "animCurveTT", "animCurveUU", "animCurveUA",
                             "animCurveUL", "animCurveUT"})
        registry.add(makeAnimCurveType(name));
    registry.add(makeMultiplyDivideType());
    registry.add(makePlusMinusAverageType());
    registry.add(makeBlendTwoAttrType());
    registry.add(makeClampType());
    registry.add(makeReverseType());
    registry.add(makeRemapValueType());
    registry.add(makeConditionType());
    registry.add(makeExpressionType());
    registry.add(makeMultMatrixType());
    registry.add(makeComposeMatrixType());
    registry.add(makeDecomposeMatrixType());
    registry.add(makeBvhClipType());
    registry.add(makeSkeletonClipType());
    registry.add(makeIkHandleType());
    registry.add(makeBlendColorsType());
    registry.add(makeTwistDistributeType());
    registry.add(makeSlidingPivotType());
    registry.add(makeSquashStretchType());
    registry.add(makeCoupledBendType());
    registry.add(makeSaturateType());
    registry.add(makeSpringType());
    registry.add(makePointConstraintType());
    registry.add(makeOrientConstraintType());
    registry.add(makeParentConstraintType());
    registry.add(makeAimConstraintType());
    registry.add(makePoleVectorConstraintType());
    registry.add(makeLookAtType());
    registry.add(makeOffsetLayerType());
    registry.add(makeBlendClipsType());
}

std::shared_ptr<NodeRegistry> makeBuiltinRegistry()
{
    auto registry = std::make_shared<NodeRegistry>();
    registerBuiltinNodes(*registry);
    return registry;
}

}  // namespace rig
