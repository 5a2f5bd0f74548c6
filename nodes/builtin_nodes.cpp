#include "nodes/builtin_nodes.h"

#include <iterator>

namespace rig {
namespace {

constexpr const char* additiveLayerTypes[] = {
    "animBlendNodeAdditive",   "animBlendNodeAdditiveDL",  "animBlendNodeAdditiveDA", "animBlendNodeAdditiveF",
    "animBlendNodeAdditiveFA", "animBlendNodeAdditiveI16", "animBlendNodeAdditiveI32"};

}  // namespace

const std::vector<std::string>& mayaUtilityTypeNames()
{
    static const std::vector<std::string> names = [] {
        std::vector<std::string> n{"multiplyDivide",
                                   "plusMinusAverage",
                                   "condition",
                                   "clamp",
                                   "reverse",
                                   "remapValue",
                                   "blendTwoAttr",
                                   "blendColors",
                                   "composeMatrix",
                                   "decomposeMatrix",
                                   "multMatrix",
                                   "unitConversion",
                                   "multDoubleLinear",
                                   "addDoubleLinear",
                                   "blendWeighted",
                                   "pairBlend",
                                   "distanceBetween",
                                   "setRange",
                                   "inverseMatrix",
                                   "floatConstant",
                                   "angleBetween",
                                   "quatToEuler",
                                   "eulerToQuat",
                                   "blendMatrix",
                                   "animBlendNodeAdditiveRotation",
                                   "animBlendNodeAdditiveScale",
                                   "animBlendNodeEnum",
                                   "animBlendNodeBoolean"};
        n.insert(n.end(), std::begin(additiveLayerTypes), std::end(additiveLayerTypes));
        return n;
    }();
    return names;
}

void registerBuiltinNodes(NodeRegistry& registry)
{
    registry.add(makeTransformType());
    registry.add(makeJointType());
    registry.add(makeTimeType());
    registry.add(makeCharacterType());
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
    registry.add(makeUnitConversionType());
    registry.add(makeMultDoubleLinearType());
    registry.add(makeAddDoubleLinearType());
    registry.add(makeBlendWeightedType());
    registry.add(makePairBlendType());
    registry.add(makeDistanceBetweenType());
    registry.add(makeSetRangeType());
    registry.add(makeInverseMatrixType());
    registry.add(makeFloatConstantType());
    registry.add(makeAngleBetweenType());
    registry.add(makeQuatToEulerType());
    registry.add(makeEulerToQuatType());
    registry.add(makeBlendMatrixType());
    for (const char* name : additiveLayerTypes) registry.add(makeAnimBlendNodeAdditiveType(name));
    registry.add(makeAnimBlendNodeAdditiveRotationType());
    registry.add(makeAnimBlendNodeAdditiveScaleType());
    for (const char* name : {"animBlendNodeEnum", "animBlendNodeBoolean"})
        registry.add(makeAnimBlendNodeEnumType(name));
    registry.add(makeBvhClipType());
    registry.add(makeSkeletonClipType());
    registry.add(makeIkHandleType());
    registry.add(makeMayaIkHandleType());
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
    registry.add(makeScaleConstraintType());
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
