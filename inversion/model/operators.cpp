#include "inversion/model/operators.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Geometry>

#include "core/rotation_math.h"

namespace rig {
namespace {

// The derivative of [L, p - L p] (a linear map L about the pivot p) for a derivative dL of the linear map.
Eigen::Matrix4d aboutPivotDerivative(const Eigen::Matrix3d& dLinear, const Eigen::Vector3d& pivot)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
    m.block<3, 3>(0, 0) = dLinear;
    m.block<3, 1>(0, 3) = -dLinear * pivot;
    return m;
}

}  // namespace

std::string_view operatorKindName(OperatorKind kind)
{
    const auto k = static_cast<std::size_t>(kind);
    return k < operatorKindTraits.size() ? operatorKindTraits[k].name : "?";
}

std::optional<OperatorKind> operatorKindFromName(std::string_view name)
{
    for (const OperatorKindTraits& t : operatorKindTraits)
        if (t.name == name) return t.kind;
    return std::nullopt;
}

Eigen::Matrix3d rotationFromVector(const Eigen::Vector3d& r)
{
    const double angle = r.norm();
    if (angle < 1e-300) return Eigen::Matrix3d::Identity();
    return Eigen::AngleAxisd(angle, r / angle).toRotationMatrix();
}

Eigen::Vector3d rotationVector(const Eigen::Matrix3d& rotation)
{
    const Eigen::AngleAxisd aa(rotation);
    return aa.angle() * aa.axis();
}

Eigen::Matrix3d leftJacobian(const Eigen::Vector3d& r)
{
    const double t = r.norm();
    const Eigen::Matrix3d k = skew(r);
    // Series near zero: J = I + K/2 + K^2/6.
    if (t < 1e-5) return Eigen::Matrix3d::Identity() + 0.5 * k + k * k / 6.0;
    return Eigen::Matrix3d::Identity() + (1.0 - std::cos(t)) / (t * t) * k + (t - std::sin(t)) / (t * t * t) * k * k;
}

double Operator::magnitude(double a) const
{
    a = std::clamp(a, low, high);
    return linear() ? slope * a : curve.value(a)[0];
}

double Operator::magnitudeDerivative(double a) const
{
    if (!acts(a)) return 0.0;
    return linear() ? slope : curve.derivative(a)[0];
}

Eigen::Matrix4d Operator::matrix(double a) const
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topRows<3>() = affineRows(a);
    return m;
}

Eigen::Matrix<double, 3, 4> Operator::affineRows(double a) const
{
    a = std::clamp(a, low, high);
    Eigen::Matrix<double, 3, 4> m;  // one named result, built in place
    // [L, p - L p]: a linear map L about the pivot p.
    const auto aboutPivot = [&](const Eigen::Matrix3d& linear) {
        m.leftCols<3>() = linear;
        m.col(3) = pivot - linear * pivot;
    };
    switch (kind) {
        case OperatorKind::translation:
            m.leftCols<3>().setIdentity();
            m.col(3) = magnitude(a) * axis;
            return m;
        case OperatorKind::rotation:
            aboutPivot(Eigen::AngleAxisd(magnitude(a), axis).toRotationMatrix());
            return m;
        case OperatorKind::axisScale:
            aboutPivot(Eigen::Matrix3d::Identity() + magnitude(a) * axis * axis.transpose());
            return m;
        case OperatorKind::uniformScale:
            aboutPivot((1.0 + magnitude(a)) * Eigen::Matrix3d::Identity());
            return m;
        case OperatorKind::sampledRigid: {
            const auto v = rigid.value(a);
            m.leftCols<3>() = rotationFromVector(v.head<3>());
            m.col(3) = v.tail<3>();
            return m;
        }
        case OperatorKind::sampledAffine: {
            const auto v = affine.value(a);
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 4; ++c) m(r, c) = (r == c ? 1.0 : 0.0) + v[4 * r + c];
            return m;
        }
    }
    m.setIdentity();
    return m;
}

Eigen::Matrix4d Operator::derivative(double a) const
{
    if (!acts(a)) return Eigen::Matrix4d::Zero();
    switch (kind) {
        case OperatorKind::translation: {
            Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
            m.block<3, 1>(0, 3) = magnitudeDerivative(a) * axis;
            return m;
        }
        case OperatorKind::rotation: {
            const Eigen::Matrix3d r = Eigen::AngleAxisd(magnitude(a), axis).toRotationMatrix();
            return aboutPivotDerivative(magnitudeDerivative(a) * skew(axis) * r, pivot);
        }
        case OperatorKind::axisScale:
            return aboutPivotDerivative(magnitudeDerivative(a) * axis * axis.transpose(), pivot);
        case OperatorKind::uniformScale:
            return aboutPivotDerivative(magnitudeDerivative(a) * Eigen::Matrix3d::Identity(), pivot);
        case OperatorKind::sampledRigid: {
            const auto v = rigid.value(a);
            const auto dv = rigid.derivative(a);
            const Eigen::Vector3d omega = leftJacobian(v.head<3>()) * dv.head<3>();
            Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
            m.block<3, 3>(0, 0) = skew(omega) * rotationFromVector(v.head<3>());
            m.block<3, 1>(0, 3) = dv.tail<3>();
            return m;
        }
        case OperatorKind::sampledAffine: {
            const auto dv = affine.derivative(a);
            Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 4; ++c) m(r, c) = dv[4 * r + c];
            return m;
        }
    }
    return Eigen::Matrix4d::Zero();
}

}  // namespace rig
