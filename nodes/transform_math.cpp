#include "nodes/transform_math.h"

#include <cmath>

namespace rig {

namespace {

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

}  // namespace

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
