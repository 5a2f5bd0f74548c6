#include "core/rotation_math.h"

#include <array>
#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/SVD>

namespace rig {
namespace {

struct OrderInfo {
    std::string_view name;
    std::array<int, 3> axes;  // axis indices in application order
    double parity;            // +1 for cyclic orders, -1 for the others
};

// Indexed by the enum value.
constexpr std::array<OrderInfo, 6> orderTable{{
    {"xyz", {0, 1, 2}, 1.0},
    {"yzx", {1, 2, 0}, 1.0},
    {"zxy", {2, 0, 1}, 1.0},
    {"xzy", {0, 2, 1}, -1.0},
    {"yxz", {1, 0, 2}, -1.0},
    {"zyx", {2, 1, 0}, -1.0},
}};

const OrderInfo& info(RotateOrder order) { return orderTable[static_cast<std::size_t>(order)]; }

// Below this, a length is treated as zero (gimbal lock).
constexpr double tinyLength = 1e-12;

// A judge compares thousands of joints a frame, nearly all rotations already: their SVD would be most of its time.
Eigen::Matrix3d orientationOf(const Eigen::Matrix3d& a)
{
    return nearlyOrthonormal(a) ? orthonormalOrientation(a) : polarRotation(a);
}

// The rotation of A = Q S (det A > 0) by Newton's iteration X <- (X + X^-T) / 2 (Higham), from A scaled to
// determinant 1: it converges quadratically to Q, in 2 or 3 steps for a world's block (a scale near uniform, a
// small shear) and under 20 for a strong stretch, at a tenth of a 3x3 SVD's cost (a scaled joint's every residual
// and Jacobian takes one). False for a block near singular (its determinant below 1e-9 of its norm cubed: Q is
// then ill-determined) or one whose steps do not settle: the SVD decides those.
bool polarByNewton(const Eigen::Matrix3d& a, double determinant, Eigen::Matrix3d& q)
{
    const double norm = a.norm();
    if (!(determinant > 1e-9 * norm * norm * norm)) return false;
    q = a / std::cbrt(determinant);
    for (int step = 0; step < 40; ++step) {
        const Eigen::Matrix3d next = 0.5 * (q + q.inverse().transpose());
        const double change = (next - q).cwiseAbs().maxCoeff();
        q = next;
        if (change <= 1e-15) return true;  // Q's entries are at most 1: a change at rounding
    }
    return false;
}

}  // namespace

Eigen::Matrix3d skew(const Eigen::Vector3d& v)
{
    Eigen::Matrix3d s;
    s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return s;
}

Eigen::Matrix3d polarRotation(const Eigen::Matrix3d& a, Eigen::Matrix3d* symmetric)
{
    // A reflection's orientation is that of -A: removing the reflection along the smallest singular value's
    // axis instead would jump by 180 degrees wherever two singular values cross (a uniform scale of -1, a
    // mirrored joint whose scale drifts by 1e-7), so a target and its model could disagree by a half turn.
    const double determinant = a.determinant();
    const Eigen::Matrix3d proper = determinant < 0 ? Eigen::Matrix3d(-a) : a;
    Eigen::Matrix3d q;
    if (!polarByNewton(proper, std::abs(determinant), q)) {
        const Eigen::JacobiSVD<Eigen::Matrix3d> svd(proper, Eigen::ComputeFullU | Eigen::ComputeFullV);
        Eigen::Matrix3d u = svd.matrixU();
        if ((u * svd.matrixV().transpose()).determinant() < 0) u.col(2) = -u.col(2);
        q = u * svd.matrixV().transpose();
    }
    if (symmetric) *symmetric = q.transpose() * a;
    return q;
}

Eigen::Matrix3d orthonormalOrientation(const Eigen::Matrix3d& a)
{
    return a.determinant() < 0 ? Eigen::Matrix3d(-a) : a;
}

bool nearlySingular(const Eigen::Vector3d& sigma) { return !(sigma[0] > 0) || !(sigma[2] > 1e-9 * sigma[0]); }

bool nearlyOrthonormal(const Eigen::Matrix3d& a)
{
    // Below this drift the polar decomposition (an SVD) would move the block by far less than any tolerance.
    constexpr double orthonormalSlack = 1e-10;
    return ((a.transpose() * a) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < orthonormalSlack;
}

double orientationAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b)
{
    const Eigen::Quaterniond relative(Eigen::Matrix3d(orientationOf(a).transpose() * orientationOf(b)));
    return 2.0 * std::atan2(relative.vec().norm(), std::abs(relative.w()));
}

double nearestTurn(double value, double reference, double period)
{
    return value + period * std::round((reference - value) / period);
}

std::optional<RotateOrder> rotateOrderFromName(std::string_view name)
{
    if (name.size() != 3) return std::nullopt;
    std::array<char, 3> lower{};
    for (std::size_t i = 0; i < 3; ++i) {
        const char c = name[i];
        lower[i] = (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
    }
    const std::string_view key(lower.data(), lower.size());
    for (std::size_t i = 0; i < orderTable.size(); ++i)
        if (orderTable[i].name == key) return static_cast<RotateOrder>(i);
    return std::nullopt;
}

std::optional<RotateOrder> rotateOrderFromIndex(int index)
{
    if (index < 0 || index >= static_cast<int>(orderTable.size())) return std::nullopt;
    return static_cast<RotateOrder>(index);
}

std::string_view rotateOrderName(RotateOrder order) { return info(order).name; }

Eigen::Matrix3d eulerToMatrix(const Eigen::Vector3d& radians, RotateOrder order)
{
    const auto& axes = info(order).axes;
    Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
    // Left-multiply so the first axis of the order acts first on column vectors.
    for (const int axis : axes)
        m = Eigen::AngleAxisd(radians[axis], Eigen::Vector3d::Unit(axis)).toRotationMatrix() * m;
    return m;
}

Eigen::Vector3d matrixToEuler(const Eigen::Matrix3d& rotation, RotateOrder order)
{
    const auto& axes = info(order).axes;
    const double parity = info(order).parity;
    // Permuting the axes to x, y, z turns any order into xyz, with angles
    // negated for odd permutations (a reflection flips rotation sense):
    // r = Rz(c) * Ry(b) * Rx(a) with (a, b, c) = parity * (first, middle, last).
    auto r = [&](int row, int col) { return rotation(axes[row], axes[col]); };

    const double cosB = std::hypot(r(0, 0), r(1, 0));
    const double b = std::atan2(-r(2, 0), cosB);
    const double a = cosB > tinyLength ? std::atan2(r(2, 1), r(2, 2)) : 0.0;
    // Solving c given a (from r * Rx(a)^T = Rz(c) * Ry(b)) stays exact at
    // gimbal lock, where only the sum/difference of a and c is determined.
    const double sa = std::sin(a);
    const double ca = std::cos(a);
    const double c = std::atan2(sa * r(0, 2) - ca * r(0, 1), ca * r(1, 1) - sa * r(1, 2));

    Eigen::Vector3d result;
    result[axes[0]] = parity * a;
    result[axes[1]] = parity * b;
    result[axes[2]] = parity * c;
    return result;
}

Eigen::Vector3d closestEuler(const Eigen::Vector3d& euler, const Eigen::Vector3d& reference, RotateOrder order)
{
    const auto& axes = info(order).axes;
    constexpr double pi = std::numbers::pi;

    Eigen::Vector3d flipped;
    flipped[axes[0]] = euler[axes[0]] + pi;
    flipped[axes[1]] = pi - euler[axes[1]];
    flipped[axes[2]] = euler[axes[2]] + pi;

    auto wrapped = [&](const Eigen::Vector3d& candidate) {
        Eigen::Vector3d out;
        for (int axis = 0; axis < 3; ++axis) out[axis] = nearestTurn(candidate[axis], reference[axis]);
        return out;
    };
    const Eigen::Vector3d direct = wrapped(euler);
    const Eigen::Vector3d alternate = wrapped(flipped);
    // Ties keep the direct solution so results do not flicker.
    return (alternate - reference).squaredNorm() < (direct - reference).squaredNorm() ? alternate : direct;
}

}  // namespace rig
