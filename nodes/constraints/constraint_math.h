#pragma once
// Math shared by the constraint node types (docs/constraints.md): weighted targets, the quaternion
// average of Maya's interpType "average", and the conversion of a world position or orientation into
// the translate / rotate values of the constrained object.
//
// Conventions: column vectors (world = parentWorld * local), cm, radians.

#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include "graph/node.h"
#include "nodes/transform_math.h"

namespace rig::constraint {

// A total target weight at or below this counts as "all weights zero": the constraint outputs its
// rest value.
inline constexpr double minTotalWeight = 1e-12;

// Maya's per-target inputs, children of its compound multi attribute target (tg) flattened into parallel arrays
// (Maya's ".tg[2].tt" is targetTranslate[2]). A type declares the ones its Maya node has, -1 for the others;
// addMayaTargets declares them in this member order, so a type's enum lists them in the same order.
struct MayaTargetIds {
    AttrId translate = -1;        // targetTranslate (tt) <- target.translate
    AttrId rotate = -1;           // targetRotate (tr) <- target.rotate
    AttrId rotateOrder = -1;      // targetRotateOrder (tro) <- target.rotateOrder
    AttrId rotatePivot = -1;      // targetRotatePivot (trp) <- target.rotatePivot
    AttrId rotateTranslate = -1;  // targetRotateTranslate (trt) <- target.rotatePivotTranslate
    AttrId scale = -1;            // targetScale (ts) <- target.scale
    AttrId parentMatrix = -1;     // targetParentMatrix (tpm) <- target.parentMatrix
    AttrId jointOrient = -1;      // targetJointOrient (tjo) <- joint target.jointOrient
    AttrId scaleCompensate = -1;  // targetScaleCompensate (tsc) <- joint target.segmentScaleCompensate
    AttrId inverseScale = -1;     // targetInverseScale (tis) <- joint target.inverseScale
};
// A target as the types read it: the world matrix that places it and the world position of its rotate pivot.
struct TargetFrame {
    int index = 0;
    double weight = 1.0;
    Eigen::Matrix4d world = Eigen::Matrix4d::Identity();
    Eigen::Vector3d pivot = Eigen::Vector3d::Zero();
    bool fromMatrix = false;  // given by targetMatrix[index] (this project's input), not by Maya's inputs
};

// The targets of a constraint: every index where targetMatrix or one of Maya's per-target arrays in `ids` has an
// element (a targetWeight element alone makes no target), by index. targetMatrix[i], where present, is the target's
// world matrix and its translation the pivot; otherwise world = targetParentMatrix * L, L = T(tt) * IS * T(trt) *
// T(trp) * R(tjo) * R(tr, tro) * S(ts) * T(-trp) (IS = diag(1 / tis) when tsc is on), and pivot = tpm * (tt + trp +
// trt), Maya's world position of the target's rotate pivot.
std::vector<TargetFrame> gatherFrames(const ComputeContext& c, AttrId matrices, AttrId weights,
                                      const MayaTargetIds& ids);

// The weighted mean of the frames' pivots; nullopt when the total weight is <= minTotalWeight.
std::optional<Eigen::Vector3d> weightedPivot(const std::vector<TargetFrame>& frames);

// Maya's interpType enum.
enum InterpType { NoFlip = 0, Average = 1, Shortest = 2, Longest = 3, Cache = 4 };

// Orientations blended as Maya's interpType: average (averageRotation);
// shortest / longest: q = q_first, then for each next target of nonzero weight, q = slerp(q, q_i, w_i / W_i) with
// W_i the weight summed so far including i, the short (long) way round; noFlip and cache read as average.
std::optional<Eigen::Quaterniond> blendRotations(const std::vector<std::pair<Eigen::Quaterniond, double>>& rotations,
                                                 int interpType);

// Element `index` of a matrix array input, or identity when it does not exist.
Eigen::Matrix4d matrixElement(const ComputeContext& c, AttrId matrices, int index);

// The rotation of a matrix with its scale and shear removed (decomposeMatrix's rotation).
Eigen::Quaterniond rotationOf(const Eigen::Matrix4d& matrix);

// Maya's interpType "average": sum of w_i * s_i * q_i with s_i = +-1 so that each q_i lies in the
// hemisphere of the first rotation of nonzero weight, normalized. nullopt when the total weight is
// <= minTotalWeight or the sum (almost) vanishes.
std::optional<Eigen::Quaterniond> averageRotation(const std::vector<std::pair<Eigen::Quaterniond, double>>& rotations);

// The inverse of a matrix; identity when it is singular (|det| <= 1e-300) or the inverse is not finite.
Eigen::Matrix4d safeInverse(const Eigen::Matrix4d& matrix);

// A world point expressed in the constrained object's parent space: parentInverse * point.
Eigen::Vector3d toParentSpace(const Eigen::Matrix4d& parentInverse, const Eigen::Vector3d& worldPoint);

// The rotate values (radians, in `order`) that give the constrained object the world orientation
// `world` under a parent whose world inverse matrix is `parentInverse`, with the joint orient
// (radians, xyz) removed: R = JO^-1 * parentRotation^-1 * world. Exact when the parent's world
// matrix is a rotation times a scale (joints with segment scale compensation, uniform scales). Of the
// equivalent Euler triples, the one nearest to zero (as ikHandle: a knee bent 120 degrees about Y reads
// (0, 120, 0), not (180, 60, 180)).
Eigen::Vector3d rotateFromWorld(const Eigen::Matrix4d& parentInverse, const Eigen::Matrix3d& world,
                                const Eigen::Vector3d& jointOrient, RotateOrder order);

// rotateFromWorld with the parent's world frame itself given (its rotation is used).
Eigen::Vector3d rotateFromFrame(const Eigen::Matrix4d& parentFrame, const Eigen::Matrix3d& world,
                                const Eigen::Vector3d& jointOrient, RotateOrder order);

}  // namespace rig::constraint
