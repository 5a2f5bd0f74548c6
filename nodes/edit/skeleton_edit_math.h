#pragma once
// The math of the skeleton-space edit nodes (nodes/edit/, docs/nodes.md "Editing a clip's skeleton"):
// a look-at over a chain of joints, an additive offset on one joint, and a blend of two poses. Plain
// functions on world matrices, separate from the nodes so that tests check them against closed forms.
//
// Conventions: column vectors (world = parentWorld * local), cm, radians.

#include <optional>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include "nodes/transform_math.h"

namespace rig {

struct LookAtSettings {
    std::vector<Eigen::Matrix4d> chain;  // world matrices of the chain's joints, root first
    Eigen::Vector3d target = Eigen::Vector3d::Zero();
    // Per joint, the fraction of the remaining turn it takes, in [0, 1]; empty: 1 / (joints left), so
    // that joints sharing a pivot split the turn in equal parts.
    std::vector<double> share;
    std::vector<double> limit;                           // per joint, the largest swing in radians (>= 0); empty: none
    double weight = 1.0;                                 // clamped to [0, 1]; NaN counts as 0
    Eigen::Vector3d aimAxis = Eigen::Vector3d::UnitZ();  // in the last joint's axes
    Eigen::Vector3d upAxis = Eigen::Vector3d::UnitY();   // in the last joint's axes
    std::optional<Eigen::Vector3d> worldUp;              // nullopt: no up (upMode none)
};

struct LookAtResult {
    std::vector<Eigen::Matrix4d> world;  // the edited world matrices
    // delta[k] * chain[k] = world[k]: the rigid motion of joint k's frame, which also carries anything
    // parented under joint k.
    std::vector<Eigen::Matrix4d> delta;
    std::vector<double> turn;                 // each joint's own turn, radians (weight included)
    std::vector<Eigen::AngleAxisd> fullTurn;  // each joint's own turn at weight 1
};

// Sizes of share and limit must be 0 or chain.size(), and their values in range (the node checks them). The
// result's lists are resized in place: a node that looks every frame keeps one result and allocates nothing.
void lookAtChain(const LookAtSettings& settings, LookAtResult& result);

enum class OffsetSpace { local = 0, world = 1 };

// The rotation `rotateRadians` (in `order`) and `translate`, both scaled by `weight` (angle about the
// same axis, translation linearly), applied to `matrix`: local = M * [R_w t_w; 0 1], world = the rotation
// about M's position in world axes, then the translation in world axes.
Eigen::Matrix4d offsetMatrix(const Eigen::Matrix4d& matrix, const Eigen::Vector3d& rotateRadians, RotateOrder order,
                             const Eigen::Vector3d& translate, OffsetSpace space, double weight);

// Per joint blend of two world matrices: rotations by quaternion slerp (the shorter way), the stretch
// left by the polar decomposition and the translation linearly. weight 0 gives a, 1 gives b, exactly.
Eigen::Matrix4d blendMatrix(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b, double weight);

// The rotation of `rotation`'s angle times `fraction` about the same axis (a slerp from the identity).
Eigen::Matrix3d scaledRotation(const Eigen::Matrix3d& rotation, double fraction);

}  // namespace rig
