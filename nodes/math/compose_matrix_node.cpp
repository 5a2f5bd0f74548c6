// composeMatrix: Maya's composeMatrix, a matrix from translate, rotate (Euler or quaternion), scale, shear.

#include <Eigen/Geometry>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"
#include "nodes/enum_names.h"
#include "nodes/transform_math.h"

namespace rig {
namespace {

enum Attr : AttrId {
    InputTranslate,
    InputRotate,
    InputScale,
    InputShear,
    InputRotateOrder,
    UseEulerRotation,
    InputQuatX,
    InputQuatY,
    InputQuatZ,
    InputQuatW,
    OutputMatrix
};

class ComposeMatrixNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const bool euler = context.getBool(UseEulerRotation);
        const Eigen::Vector3d rotate = euler ? context.getVector3(InputRotate) : Eigen::Vector3d::Zero();
        const auto order = rotateOrderFromIndex(context.getEnum(InputRotateOrder)).value_or(RotateOrder::xyz);
        Eigen::Matrix4d m = composeTRS(context.getVector3(InputTranslate), rotate, order,
                                       context.getVector3(InputScale), context.getVector3(InputShear));
        if (!euler) {
            // T * R * SH * S with R from the quaternion: left-multiply the linear part of T * SH * S.
            const Eigen::Quaterniond q(context.getDouble(InputQuatW), context.getDouble(InputQuatX),
                                       context.getDouble(InputQuatY), context.getDouble(InputQuatZ));
            if (q.norm() > 0.0) {
                const Eigen::Matrix3d r = q.normalized().toRotationMatrix();
                m.topLeftCorner<3, 3>() = (r * m.topLeftCorner<3, 3>()).eval();
            }
        }
        context.setOutput(OutputMatrix, m);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeComposeMatrixType()
{
    NodeTypeBuilder b("composeMatrix");
    b.description(
        "Builds a matrix from translate, rotate, scale and shear (Maya's composeMatrix node): in column-vector "
        "form outputMatrix = T * R * SH * S (Maya's row-form S * SH * R * T), the inverse of decomposeMatrix. "
        "R comes from inputRotate in inputRotateOrder, or from the quaternion inputQuatX..W when "
        "useEulerRotation is off.");
    b.input(InputTranslate, "inputTranslate", ValueType::Vector3)
        .shortName("it")
        .unit(Unit::Distance)
        .keyable()
        .doc("Translation (inputTranslateX, inputTranslateY, inputTranslateZ).");
    b.input(InputRotate, "inputRotate", ValueType::Vector3)
        .shortName("ir")
        .unit(Unit::Angle)
        .keyable()
        .doc(
            "Euler rotation, applied in inputRotateOrder (inputRotateX, inputRotateY, inputRotateZ); used when "
            "useEulerRotation is on.");
    b.input(InputScale, "inputScale", ValueType::Vector3)
        .shortName("is")
        .defaultValue(Eigen::Vector3d(1.0, 1.0, 1.0))
        .keyable()
        .doc("Scale along the local axes (inputScaleX, inputScaleY, inputScaleZ).");
    b.input(InputShear, "inputShear", ValueType::Vector3)
        .shortName("ish")
        .keyable()
        .doc(
            "Shear (inputShearX = xy, inputShearY = xz, inputShearZ = yz), applied after scale as Maya's "
            "transform shear.");
    b.input(InputRotateOrder, "inputRotateOrder", ValueType::Enum)
        .shortName("iro")
        .enumNames(rotateOrderEnumNames())
        .doc("The order the inputRotate axes are applied in; xyz applies X first.");
    b.input(UseEulerRotation, "useEulerRotation", ValueType::Bool)
        .shortName("uer")
        .defaultValue(true)
        .doc("On: rotation from inputRotate; off: from the quaternion inputQuatX..W.");
    b.input(InputQuatX, "inputQuatX", ValueType::Double)
        .shortName("iqx")
        .keyable()
        .doc("Quaternion rotation, x (imaginary i) part.");
    b.input(InputQuatY, "inputQuatY", ValueType::Double)
        .shortName("iqy")
        .keyable()
        .doc("Quaternion rotation, y (imaginary j) part.");
    b.input(InputQuatZ, "inputQuatZ", ValueType::Double)
        .shortName("iqz")
        .keyable()
        .doc("Quaternion rotation, z (imaginary k) part.");
    b.input(InputQuatW, "inputQuatW", ValueType::Double)
        .shortName("iqw")
        .defaultValue(1.0)
        .keyable()
        .doc(
            "Quaternion rotation, w (real) part. The quaternion is normalized before use; all four zero gives "
            "no rotation. Used when useEulerRotation is off.");
    b.output(OutputMatrix, "outputMatrix", ValueType::Matrix4)
        .shortName("omat")
        .doc("T * R * SH * S (column vectors).");
    for (AttrId in : {InputTranslate, InputRotate, InputScale, InputShear, InputRotateOrder, UseEulerRotation,
                      InputQuatX, InputQuatY, InputQuatZ, InputQuatW})
        b.affects(in, {OutputMatrix});
    b.factory<ComposeMatrixNode>();
    return b.build();
}

}  // namespace rig
