#pragma once
// Quaternion helpers shared by the Maya nodes that blend or convert rotations (pairBlend, eulerToQuat,
// quatToEuler, animBlendNodeAdditiveRotation, angleBetween, blendMatrix).

#include <cmath>

#include <Eigen/Geometry>

#include "core/rotation_math.h"

namespace rig {

// The rotation of Euler angles (radians) in `order` as a quaternion composed axis by axis (the first letter
// applied first: xyz gives qz * qy * qx), so its sign is fixed by the angles, as Maya's MEulerRotation gives it.
inline Eigen::Quaterniond eulerQuaternion(const Eigen::Vector3d& radians, RotateOrder order)
{
    static constexpr int axes[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {1, 0, 2}, {2, 1, 0}};
    const auto& a = axes[static_cast<int>(order)];
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    for (int k = 0; k < 3; ++k)
        q = Eigen::Quaterniond(Eigen::AngleAxisd(radians[a[k]], Eigen::Vector3d::Unit(a[k]))) * q;
    return q;
}

// Euler angles of a rotation in `order`, the solution nearest `reference` (so a blend stays continuous and
// returns its input at its ends).
inline Eigen::Vector3d quaternionEuler(const Eigen::Quaterniond& q, RotateOrder order, const Eigen::Vector3d& reference)
{
    return closestEuler(matrixToEuler(q.normalized().toRotationMatrix(), order), reference, order);
}

// q taken `weight` of the way from the identity along the shorter arc (weights outside 0..1 extrapolate).
inline Eigen::Quaterniond scaledRotation(Eigen::Quaterniond q, double weight)
{
    if (q.w() < 0.0) q.coeffs() = -q.coeffs();
    const double angle = 2.0 * std::atan2(q.vec().norm(), q.w());
    if (angle == 0.0) return Eigen::Quaterniond::Identity();
    return Eigen::Quaterniond(Eigen::AngleAxisd(angle * weight, q.vec().normalized()));
}

// Shortest-arc spherical interpolation from a (t = 0) to b (t = 1).
inline Eigen::Quaterniond slerpShortest(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b, double t)
{
    return a * scaledRotation(a.conjugate() * b, t);
}

}  // namespace rig
