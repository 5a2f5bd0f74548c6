#pragma once
// The SO(3) and matrix helpers every layer uses, written once.

#include <numbers>

#include <Eigen/Core>

namespace rig {

// [v]x: skew(v) * w = v x w.
Eigen::Matrix3d skew(const Eigen::Vector3d& v);

// The polar decomposition A = Q S: Q the rotation nearest A (a reflection removed, det Q = +1), S
// symmetric (written to `symmetric` when given). A world matrix's 3x3 block may carry scale or shear.
Eigen::Matrix3d polarRotation(const Eigen::Matrix3d& a, Eigen::Matrix3d* symmetric = nullptr);

// The angle between the orientations of two 3x3 blocks (scale and shear removed), radians in [0, pi].
// Accurate near zero (atan2 of the relative rotation's halves, not acos).
double orientationAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

// `value` moved by whole periods to the one nearest `reference`: an angle unwrapped against its neighbour.
double nearestTurn(double value, double reference, double period = 2.0 * std::numbers::pi);

}  // namespace rig
