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

struct Target {
    int index = 0;                                         // logical index in targetMatrix
    Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();  // world matrix of the target
    double weight = 1.0;
};

// The targets of a constraint: every existing element of the array `matrices`, with the element of
// the same index of `weights` (1, Maya's default, when that element does not exist), by index.
std::vector<Target> gatherTargets(const ComputeContext& c, AttrId matrices, AttrId weights);

// Element `index` of a matrix array input, or identity when it does not exist.
Eigen::Matrix4d matrixElement(const ComputeContext& c, AttrId matrices, int index);

double totalWeight(const std::vector<Target>& targets);

// The weighted mean of the targets' positions (translation columns), weights normalized; nullopt when
// the total weight is <= minTotalWeight.
std::optional<Eigen::Vector3d> weightedPosition(const std::vector<Target>& targets);

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

// The parent's world rotation: the rotation of inverse(parentInverse).
Eigen::Matrix3d parentRotation(const Eigen::Matrix4d& parentInverse);

// The rotate values (radians, in `order`) that give the constrained object the world orientation
// `world` under a parent whose world inverse matrix is `parentInverse`, with the joint orient
// (radians, xyz) removed: R = JO^-1 * parentRotation^-1 * world. Exact when the parent's world
// matrix is a rotation times a scale (joints with segment scale compensation, uniform scales). Of the
// equivalent Euler triples, the one nearest to zero (as ikHandle: a knee bent 120 degrees about Y reads
// (0, 120, 0), not (180, 60, 180)).
Eigen::Vector3d rotateFromWorld(const Eigen::Matrix4d& parentInverse, const Eigen::Matrix3d& world,
                                const Eigen::Vector3d& jointOrient, RotateOrder order);

// The world orientation the constrained object has with rotate = 0: parentRotation * JO.
Eigen::Matrix3d restFrame(const Eigen::Matrix4d& parentInverse, const Eigen::Vector3d& jointOrient);

}  // namespace rig::constraint
