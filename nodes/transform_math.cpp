#include "nodes/transform_math.h"

#include <array>
#include <cmath>
#include <numbers>

#include "core/rotation_math.h"

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

// Below this, a length is treated as zero (scale collapse, gimbal lock).
constexpr double tinyLength = 1e-12;

Eigen::Matrix4d translation(const Eigen::Vector3d& offset)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topRightCorner<3, 1>() = offset;
    return m;
}

Eigen::Matrix4d embed(const Eigen::Matrix3d& linear)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = linear;
    return m;
}

// Column-vector form of Maya's shear (transpose of its row-vector matrix).
Eigen::Matrix3d shearMatrix(const Eigen::Vector3d& shear)
{
    Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
    m(0, 1) = shear.x();
    m(0, 2) = shear.y();
    m(1, 2) = shear.z();
    return m;
}

// value shifted by a multiple of 2*pi to lie within pi of reference.
}  // namespace

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

Eigen::Matrix4d transformMatrix(const TransformInputs& in)
{
    const Eigen::Matrix3d rotation =
        eulerToMatrix(in.rotate, in.rotateOrder) * eulerToMatrix(in.rotateAxis, RotateOrder::xyz);
    const Eigen::Matrix3d shearScale = shearMatrix(in.shear) * in.scale.asDiagonal();
    return translation(in.translate) * translation(in.rotatePivotTranslate) * translation(in.rotatePivot) *
           embed(rotation) * translation(-in.rotatePivot) * translation(in.scalePivotTranslate) *
           translation(in.scalePivot) * embed(shearScale) * translation(-in.scalePivot);
}

Eigen::Matrix4d jointMatrix(const JointInputs& in)
{
    Eigen::Vector3d compensation = Eigen::Vector3d::Ones();
    if (in.segmentScaleCompensate) {
        for (int axis = 0; axis < 3; ++axis) {
            const double parentScale = in.inverseScale[axis];
            if (parentScale != 0.0) compensation[axis] = 1.0 / parentScale;
        }
    }
    const Eigen::Matrix3d linear = compensation.asDiagonal() * eulerToMatrix(in.jointOrient, RotateOrder::xyz) *
                                   eulerToMatrix(in.rotate, in.rotateOrder) *
                                   eulerToMatrix(in.rotateAxis, RotateOrder::xyz) * in.scale.asDiagonal();
    Eigen::Matrix4d m = embed(linear);
    m.topRightCorner<3, 1>() = in.translate;
    return m;
}

Eigen::Matrix4d composeTRS(const Eigen::Vector3d& translate, const Eigen::Vector3d& rotateRadians, RotateOrder order,
                           const Eigen::Vector3d& scale, const Eigen::Vector3d& shear)
{
    Eigen::Matrix4d m = embed(eulerToMatrix(rotateRadians, order) * shearMatrix(shear) * scale.asDiagonal());
    m.topRightCorner<3, 1>() = translate;
    return m;
}

DecomposedMatrix decomposeMatrix(const Eigen::Matrix4d& matrix, RotateOrder order)
{
    const Eigen::Matrix3d linear = matrix.topLeftCorner<3, 3>();

    // Gram-Schmidt on the columns gives linear = rotation * upper, where the
    // upper-triangular factor is exactly SH * S of composeTRS.
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    std::array<bool, 3> found{};
    int foundCount = 0;
    for (int col = 0; col < 3; ++col) {
        Eigen::Vector3d v = linear.col(col);
        for (int prev = 0; prev < col; ++prev)
            if (found[prev]) v -= rotation.col(prev).dot(v) * rotation.col(prev);
        const double length = v.norm();
        if (length > tinyLength) {
            rotation.col(col) = v / length;
            found[col] = true;
            ++foundCount;
        }
    }
    // Collapsed axes (zero scale) are completed right-handed from the others,
    // which keeps them orthogonal to every column and so adds no shear.
    if (foundCount == 1) {
        const int known = found[0] ? 0 : (found[1] ? 1 : 2);
        const int next = (known + 1) % 3;
        rotation.col(next) = rotation.col(known).unitOrthogonal();
        rotation.col((known + 2) % 3) = rotation.col(known).cross(rotation.col(next));
    } else if (foundCount == 2) {
        const int missing = !found[0] ? 0 : (!found[1] ? 1 : 2);
        rotation.col(missing) = rotation.col((missing + 1) % 3).cross(rotation.col((missing + 2) % 3));
    }
    if (rotation.determinant() < 0.0) rotation.col(0) = -rotation.col(0);

    const Eigen::Matrix3d upper = rotation.transpose() * linear;
    DecomposedMatrix out;
    out.translate = matrix.topRightCorner<3, 1>();
    out.scale = upper.diagonal();
    auto ratio = [](double num, double den) { return std::abs(den) > tinyLength ? num / den : 0.0; };
    out.shear = Eigen::Vector3d(ratio(upper(0, 1), upper(1, 1)), ratio(upper(0, 2), upper(2, 2)),
                                ratio(upper(1, 2), upper(2, 2)));
    out.rotate = matrixToEuler(rotation, order);
    out.quat = Eigen::Quaterniond(rotation).normalized();
    return out;
}

}  // namespace rig
