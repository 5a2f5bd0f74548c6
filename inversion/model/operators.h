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

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <string_view>

#include <Eigen/Core>

#include "inversion/model/cubic_spline.h"

namespace rig {

enum class OperatorKind { translation, rotation, axisScale, uniformScale, sampledRigid, sampledAffine };

// What the code that stores, fits, differentiates and reports operators asks of a kind, one row per kind
// (Pinocchio's per-joint-kind traits), so that no caller lists kinds by hand.
struct OperatorKindTraits {
    OperatorKind kind;
    std::string_view name;  // in approximation files, reports and fit forms
    // Interpolates the rig's own world deltas (a spline through knots); an analytic kind is instead an axis, a
    // pivot and a magnitude m(a) (a slope or a curve), the fields every analytic kind stores in files.
    bool sampled;
    bool rigid;         // P is a rigid motion (its 3x3 part a rotation): a twist in the Jacobian
    bool hasAxis;       // `axis` changes P
    bool hasPivot;      // `pivot` changes P
    bool angular;       // the magnitude is an angle: P comes back after every whole turn of it
    int valuesPerKnot;  // of its spline: the magnitude (1), or the sampled kind's rotation vector and translation
                        // (6) or 3x4 block (12)
};

// Adding a kind is: its enum value above, its row here (in enum order, checked below), its matrix and derivative
// (Operator::affineRows and Operator::derivative, operators.cpp), and its fit in the learner (classifier.cpp:
// plausibleKinds and fitStructure for an analytic kind, trySampled for a sampled one). Files, fit forms and the
// learner's choices follow from the row; a sampled kind also needs its spline in Operator and its knots and values
// written and read (approximation_io.cpp).
inline constexpr std::array<OperatorKindTraits, 6> operatorKindTraits{{
    // kind, name, sampled, rigid, hasAxis, hasPivot, angular, valuesPerKnot
    {OperatorKind::translation, "translation", false, true, true, false, false, 1},
    {OperatorKind::rotation, "rotation", false, true, true, true, true, 1},
    {OperatorKind::axisScale, "axisScale", false, false, true, true, false, 1},
    {OperatorKind::uniformScale, "uniformScale", false, false, false, true, false, 1},
    {OperatorKind::sampledRigid, "sampledRigid", true, true, false, false, false, 6},
    {OperatorKind::sampledAffine, "sampledAffine", true, false, false, false, false, 12},
}};

constexpr const OperatorKindTraits& operatorTraits(OperatorKind kind)
{
    return operatorKindTraits[static_cast<std::size_t>(kind)];
}

static_assert(
    [] {
        for (std::size_t k = 0; k < operatorKindTraits.size(); ++k)
            if (static_cast<std::size_t>(operatorKindTraits[k].kind) != k) return false;
        return true;
    }(),
    "operatorKindTraits: one row per OperatorKind, in enum order");

std::string_view operatorKindName(OperatorKind kind);
std::optional<OperatorKind> operatorKindFromName(std::string_view name);

struct Operator {
    OperatorKind kind = OperatorKind::translation;
    Eigen::Vector3d axis = Eigen::Vector3d::UnitX();  // unit; translation, rotation, axisScale
    Eigen::Vector3d pivot = Eigen::Vector3d::Zero();  // rotation and the scales, world space, cm
    double slope = 0.0;                               // linear magnitude, when `curve` is empty
    CubicSpline<1> curve;                             // magnitude through (0, 0) and the samples
    CubicSpline<operatorTraits(OperatorKind::sampledRigid).valuesPerKnot> rigid;    // rotation vector, translation
    CubicSpline<operatorTraits(OperatorKind::sampledAffine).valuesPerKnot> affine;  // 3x4 block of P - I, by rows
    double low = -std::numeric_limits<double>::infinity();  // offsets beyond which P is held (saturation)
    double high = std::numeric_limits<double>::infinity();

    const OperatorKindTraits& traits() const { return operatorTraits(kind); }
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
