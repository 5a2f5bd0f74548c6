#pragma once

// Maya transform/joint matrix math. Conventions: column vectors (a point p maps
// to M * p, world = parentWorld * local), angles in radians, lengths in cm.

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include <optional>
#include <string_view>

namespace rig {

// Values match Maya's rotateOrder enum indices as stored in scenes.
enum class RotateOrder { xyz = 0, yzx = 1, zxy = 2, xzy = 3, yxz = 4, zyx = 5 };

// Accepts "xyz".."zyx" in any letter case.
std::optional<RotateOrder> rotateOrderFromName(std::string_view name);
// Maya's integer enum index (0..5).
std::optional<RotateOrder> rotateOrderFromIndex(int index);
std::string_view rotateOrderName(RotateOrder order);

// radians = (rx, ry, rz). The first letter of the order is applied first, so
// xyz gives R = Rz * Ry * Rx.
Eigen::Matrix3d eulerToMatrix(const Eigen::Vector3d& radians, RotateOrder order);

// Inverse of eulerToMatrix for a proper rotation. The middle angle lies in
// [-pi/2, pi/2], the others in [-pi, pi]. At gimbal lock the first-applied
// angle is set to zero and the last-applied one carries the rotation.
Eigen::Vector3d matrixToEuler(const Eigen::Matrix3d& rotation, RotateOrder order);

// Among the rotation-equivalent triples of `euler` (2*pi multiples per axis and
// the flipped (a + pi, pi - b, c + pi) solution in application order), the one
// nearest to `reference`; keeps animation curves continuous.
Eigen::Vector3d closestEuler(const Eigen::Vector3d& euler, const Eigen::Vector3d& reference, RotateOrder order);

// Inputs of Maya's transform node.
struct TransformInputs {
    Eigen::Vector3d translate = Eigen::Vector3d::Zero();
    Eigen::Vector3d rotate = Eigen::Vector3d::Zero();  // radians, in rotateOrder
    RotateOrder rotateOrder = RotateOrder::xyz;
    Eigen::Vector3d scale = Eigen::Vector3d::Ones();
    Eigen::Vector3d shear = Eigen::Vector3d::Zero();  // (xy, xz, yz)
    Eigen::Vector3d rotatePivot = Eigen::Vector3d::Zero();
    // Offset Maya adds when a pivot moves so the object does not jump.
    Eigen::Vector3d rotatePivotTranslate = Eigen::Vector3d::Zero();
    Eigen::Vector3d scalePivot = Eigen::Vector3d::Zero();
    Eigen::Vector3d scalePivotTranslate = Eigen::Vector3d::Zero();
    Eigen::Vector3d rotateAxis = Eigen::Vector3d::Zero();  // radians, always xyz order
};

// M = T * RT * RP * R * RA * RP^-1 * ST * SP * SH * S * SP^-1
// (Maya's row-vector SP^-1 * S * SH * SP * ST * RP^-1 * RA * R * RP * RT * T, transposed).
Eigen::Matrix4d transformMatrix(const TransformInputs& inputs);

// Inputs of Maya's joint node.
struct JointInputs {
    Eigen::Vector3d translate = Eigen::Vector3d::Zero();
    Eigen::Vector3d rotate = Eigen::Vector3d::Zero();  // radians, in rotateOrder
    RotateOrder rotateOrder = RotateOrder::xyz;
    Eigen::Vector3d jointOrient = Eigen::Vector3d::Zero();  // radians, xyz order
    Eigen::Vector3d rotateAxis = Eigen::Vector3d::Zero();   // radians, xyz order
    Eigen::Vector3d scale = Eigen::Vector3d::Ones();
    // The parent's scale; its inverse is applied so the parent's scale does not
    // reach this joint's orientation. Zero components are left uncompensated.
    Eigen::Vector3d inverseScale = Eigen::Vector3d::Ones();
    bool segmentScaleCompensate = true;
};

// M = T * IS * JO * R * RA * S, IS = identity unless segmentScaleCompensate
// (Maya's row-vector S * RO * R * JO * IS * T, transposed).
Eigen::Matrix4d jointMatrix(const JointInputs& inputs);

// Maya's composeMatrix node: M = T * R * SH * S, shear = (xy, xz, yz) with
// SH = [[1, xy, xz], [0, 1, yz], [0, 0, 1]] in column-vector form.
Eigen::Matrix4d composeTRS(const Eigen::Vector3d& translate, const Eigen::Vector3d& rotateRadians, RotateOrder order,
                           const Eigen::Vector3d& scale, const Eigen::Vector3d& shear);

struct DecomposedMatrix {
    Eigen::Vector3d translate = Eigen::Vector3d::Zero();
    Eigen::Vector3d rotate = Eigen::Vector3d::Zero();  // radians, in the requested order
    Eigen::Vector3d scale = Eigen::Vector3d::Ones();
    Eigen::Vector3d shear = Eigen::Vector3d::Zero();  // (xy, xz, yz)
    Eigen::Quaterniond quat = Eigen::Quaterniond::Identity();
};

// Maya's decomposeMatrix node, the inverse of composeTRS. A reflection
// (negative determinant) is folded into scale.x. The projective row is ignored.
DecomposedMatrix decomposeMatrix(const Eigen::Matrix4d& matrix, RotateOrder order);

}  // namespace rig
