#pragma once
// The SO(3) and matrix helpers every layer uses, written once: Maya's rotate orders and Euler angles among them
// (the learner fits twist shares that read a driver's angles in some order).

#include <numbers>
#include <optional>
#include <string_view>

#include <Eigen/Core>

namespace rig {

// [v]x: skew(v) * w = v x w.
Eigen::Matrix3d skew(const Eigen::Vector3d& v);

// The polar decomposition A = Q S: Q the rotation nearest A (det Q = +1), S symmetric (written to `symmetric`
// when given). A world matrix's 3x3 block may carry scale or shear. A reflection (det A < 0) has the
// orientation of -A, continuous in A: S is then negative definite.
Eigen::Matrix3d polarRotation(const Eigen::Matrix3d& a, Eigen::Matrix3d* symmetric = nullptr);

// polarRotation of an orthonormal block without its SVD: the block, or its negation for a reflection.
Eigen::Matrix3d orthonormalOrientation(const Eigen::Matrix3d& a);

// Whether a 3x3 block is too close to singular to have an orientation or an inverse: its singular values
// (largest first) are not positive, or the smallest is below 1e-9 of the largest.
bool nearlySingular(const Eigen::Vector3d& singularValues);

// Whether a 3x3 block is orthonormal up to rounding (products of rigid operators drift by rounding only): its
// polar decomposition would change it by less than any tolerance, so callers skip that SVD. A reflection passes.
bool nearlyOrthonormal(const Eigen::Matrix3d& a);

// The angle between the orientations of two 3x3 blocks (scale and shear removed), radians in [0, pi].
// Accurate near zero (atan2 of the relative rotation's halves, not acos).
double orientationAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

// `value` moved by whole periods to the one nearest `reference`: an angle unwrapped against its neighbour.
double nearestTurn(double value, double reference, double period = 2.0 * std::numbers::pi);

// Values match Maya's rotateOrder enum indices as stored in scenes.
enum class RotateOrder { xyz = 0, yzx = 1, zxy = 2, xzy = 3, yxz = 4, zyx = 5 };

// Accepts "xyz".."zyx" in any letter case.
std::optional<RotateOrder> rotateOrderFromName(std::string_view name);
// Maya's integer enum index (0..5).
std::optional<RotateOrder> rotateOrderFromIndex(int index);
std::string_view rotateOrderName(RotateOrder order);

// radians = (rx, ry, rz). The first letter of the order is applied first, so
// xyz gives R = Rz * Ry * Rx.
Eigen::Matrix3d eulerToMatrix(const Eigen::Vector3d& radians, RotateOrder order);

// Inverse of eulerToMatrix for a proper rotation. The middle angle lies in
// [-pi/2, pi/2], the others in [-pi, pi]. At gimbal lock the first-applied
// angle is set to zero and the last-applied one carries the rotation.
Eigen::Vector3d matrixToEuler(const Eigen::Matrix3d& rotation, RotateOrder order);

// Among the rotation-equivalent triples of `euler` (2*pi multiples per axis and
// the flipped (a + pi, pi - b, c + pi) solution in application order), the one
// nearest to `reference`; keeps animation curves continuous.
Eigen::Vector3d closestEuler(const Eigen::Vector3d& euler, const Eigen::Vector3d& reference, RotateOrder order);

}  // namespace rig
