#pragma once

// Maya transform/joint matrix math. Conventions: column vectors (a point p maps
// to M * p, world = parentWorld * local), angles in radians, lengths in cm.

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include <optional>
#include <string_view>

#include "core/rotation_math.h"

namespace rig {

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
