#pragma once
// What the residual workspace's files share (jacobian.cpp: targets, evaluation and the operators' Jacobian;
// base_velocity.cpp: the constraints' and blends' bases; twist_fold.cpp: the twist-form normal equations): the
// joint target's residual rows and products of affine matrices kept as their top rows. Internal to the solve.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/rotation_math.h"
#include "inversion/solve/jacobian.h"

namespace rig::jacobian_math {

using Vector6d = Eigen::Matrix<double, 6, 1>;

// The rotation residual: 2 vec(q) for the unit quaternion q = (w, v) of Q_target^T Q, taken with w >= 0,
// so |r| = 2 sin(theta / 2). Its cost 2 sin^2(theta / 2) = 1 - cos(theta) is smooth everywhere and stationary
// only at theta = 0 (the minimum) and at half a turn (its maximum). The logarithm's cost theta^2 / 2 has
// the same minimum, but its derivative blows up at half a turn, where Gauss-Newton's steps shrink to
// nothing and a solve "converges" 180 degrees away.
struct HalfAngle {
    Eigen::Vector3d residual;  // 2 v
    Eigen::Matrix3d rows;      // d(2 v) / d omega for Q -> Q exp([omega]x): w I + [v]x
};

inline HalfAngle halfAngle(const Eigen::Matrix3d& q, const PreparedTarget& t)
{
    Eigen::Quaterniond e(t.rotation.transpose() * q);
    if (e.w() < 0) e.coeffs() = -e.coeffs();
    HalfAngle h;
    h.residual = 2.0 * e.vec();
    h.rows = e.w() * Eigen::Matrix3d::Identity() + skew(e.vec());
    return h;
}

inline Eigen::Vector3d rotationResidual(const Eigen::Matrix3d& q, const PreparedTarget& t)
{
    Eigen::Quaterniond e(t.rotation.transpose() * q);
    return 2.0 * (e.w() < 0 ? -e.vec() : Eigen::Vector3d(e.vec()));
}

// `rigid`: the world is known to be a rotation and a translation (no check, no polar decomposition).
inline Vector6d residual6(const Eigen::Matrix4d& world, const PreparedTarget& t, bool rigid = false)
{
    Vector6d r;
    r.head<3>() = t.positionWeight * (world.block<3, 1>(0, 3) - t.position);
    const Eigen::Matrix3d a = world.block<3, 3>(0, 0);
    r.tail<3>() = t.rotationWeight *
                  rotationResidual(rigid || nearlyOrthonormal(a) ? orthonormalOrientation(a) : polarRotation(a), t);
    return r;
}

using Affine = Eigen::Matrix<double, 3, 4>;

// a * b for 4x4 matrices whose last rows are 0 0 0 1, kept as their top three rows (b: any 3x4, such as a
// 4x4's top rows, read in place).
template <class B>
[[gnu::always_inline]] inline Affine compose(const Affine& a, const Eigen::MatrixBase<B>& b)
{
    Affine r;
    r.leftCols<3>().noalias() = a.leftCols<3>() * b.template leftCols<3>();
    r.col(3).noalias() = a.leftCols<3>() * b.col(3);
    r.col(3) += a.col(3);
    return r;
}

}  // namespace rig::jacobian_math
