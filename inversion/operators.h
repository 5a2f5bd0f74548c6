#pragma once
// The operators P(a) of the talk: world-space transforms with P(0) = I that a parameter's value `a`
// (its offset from the rest value) applies on the left of an output's rest world matrix.
//
//   translation     P = [I, m(a) n]                        along the unit axis n
//   rotation        P = [R, p - R p], R = rotation by m(a) about n through the pivot p
//   axisScale       P = [S, p - S p], S = I + m(a) n n^T   (scale 1 + m along n about p)
//   uniformScale    P = [S, p - S p], S = (1 + m(a)) I
//   sampledRigid    P = [exp(r(a)), t(a)]                  r (a rotation vector) and t are splines
//   sampledAffine   P = I + [A(a), t(a)]                   the twelve entries are splines
//
// The magnitude m(a) is linear (m = slope * a) or a natural cubic spline through fitted samples
// (driven keys, aim constraints). A saturated control (a clamp) holds its operator beyond `low` and
// `high`: P(a) = P(clamp(a, low, high)), with dP/da = 0 outside, so the fit covers only the range where
// the control acts and no spline has to bend round a kink. Sampled operators interpolate samples of the rig's own world
// delta: exact at the samples, and exact in between wherever the delta is itself smooth and well sampled.

#include <cmath>
#include <limits>
#include <optional>
#include <string_view>

#include <Eigen/Core>

#include "inversion/cubic_spline.h"

namespace rig {

enum class OperatorKind { translation, rotation, axisScale, uniformScale, sampledRigid, sampledAffine };

std::string_view operatorKindName(OperatorKind kind);
std::optional<OperatorKind> operatorKindFromName(std::string_view name);

struct Operator {
    OperatorKind kind = OperatorKind::translation;
    Eigen::Vector3d axis = Eigen::Vector3d::UnitX();        // unit; translation, rotation, axisScale
    Eigen::Vector3d pivot = Eigen::Vector3d::Zero();        // rotation and the scales, world space, cm
    double slope = 0.0;                                     // linear magnitude, when `curve` is empty
    CubicSpline<1> curve;                                   // magnitude through (0, 0) and the samples
    CubicSpline<6> rigid;                                   // sampledRigid: rotation vector, translation
    CubicSpline<12> affine;                                 // sampledAffine: the 3x4 block of P - I, row by row
    double low = -std::numeric_limits<double>::infinity();  // offsets beyond which P is held (saturation)
    double high = std::numeric_limits<double>::infinity();

    bool held() const { return std::isfinite(low) || std::isfinite(high); }
    // Whether P changes at a (false beyond the held ends).
    bool acts(double a) const { return a >= low && a <= high; }

    bool linear() const { return curve.empty(); }
    double magnitude(double a) const;
    double magnitudeDerivative(double a) const;
    Eigen::Matrix4d matrix(double a) const;
    // matrix(a)'s top three rows (its last row is 0 0 0 1), without making the 4x4.
    Eigen::Matrix<double, 3, 4> affineRows(double a) const;
    // dP/da, analytic.
    Eigen::Matrix4d derivative(double a) const;
};

// The rotation matrix of a rotation vector (angle * unit axis), and the left Jacobian of SO(3) that
// turns a rotation vector's rate into the angular velocity: d exp(r)/da = [J(r) r']x exp(r).
Eigen::Matrix3d rotationFromVector(const Eigen::Vector3d& r);
Eigen::Vector3d rotationVector(const Eigen::Matrix3d& rotation);
Eigen::Matrix3d leftJacobian(const Eigen::Vector3d& r);

}  // namespace rig
