#include "core/rotation_math.h"

#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/SVD>

namespace rig {

Eigen::Matrix3d skew(const Eigen::Vector3d& v)
{
    Eigen::Matrix3d s;
    s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return s;
}

Eigen::Matrix3d polarRotation(const Eigen::Matrix3d& a, Eigen::Matrix3d* symmetric)
{
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(a, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d u = svd.matrixU();
    if ((u * svd.matrixV().transpose()).determinant() < 0) u.col(2) = -u.col(2);
    const Eigen::Matrix3d q = u * svd.matrixV().transpose();
    if (symmetric) *symmetric = q.transpose() * a;
    return q;
}

double orientationAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b)
{
    const Eigen::Quaterniond relative(Eigen::Matrix3d(polarRotation(a).transpose() * polarRotation(b)));
    return 2.0 * std::atan2(relative.vec().norm(), std::abs(relative.w()));
}

double nearestTurn(double value, double reference, double period)
{
    return value + period * std::round((reference - value) / period);
}

}  // namespace rig
