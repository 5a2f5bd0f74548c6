// decomposeMatrix: Maya's decomposeMatrix, translate/rotate/scale/shear/quaternion out of a matrix.

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"
#include "nodes/enum_names.h"
#include "nodes/transform_math.h"

namespace rig {
namespace {

enum Attr : AttrId {
    InputMatrix,
    InputRotateOrder,
    OutputTranslate,
    OutputRotate,
    OutputScale,
    OutputShear,
    OutputQuatX,
    OutputQuatY,
    OutputQuatZ,
    OutputQuatW
};

class DecomposeMatrixNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const auto order = rotateOrderFromIndex(context.getEnum(InputRotateOrder)).value_or(RotateOrder::xyz);
        const DecomposedMatrix d = decomposeMatrix(context.getMatrix(InputMatrix), order);
        context.setOutput(OutputTranslate, d.translate);
        context.setOutput(OutputRotate, d.rotate);
        context.setOutput(OutputScale, d.scale);
        context.setOutput(OutputShear, d.shear);
        context.setOutput(OutputQuatX, d.quat.x());
        context.setOutput(OutputQuatY, d.quat.y());
        context.setOutput(OutputQuatZ, d.quat.z());
        context.setOutput(OutputQuatW, d.quat.w());
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeDecomposeMatrixType()
{
    NodeTypeBuilder b("decomposeMatrix");
    b.description(
        "Splits a matrix into translate, rotate, scale, shear and a rotation quaternion (Maya's decomposeMatrix "
        "node), the inverse of composeMatrix: inputMatrix = T * R * SH * S in column-vector form. A reflection "
        "(negative determinant) shows as a negative outputScaleX; a zero scale axis gives 0 scale and no shear "
        "on it. The projective row is ignored. Maya's compound outputQuat is the four doubles "
        "outputQuatX..outputQuatW here.");
    b.input(InputMatrix, "inputMatrix", ValueType::Matrix4).shortName("imat").doc("The matrix decomposed.");
    b.input(InputRotateOrder, "inputRotateOrder", ValueType::Enum)
        .shortName("ro")
        .enumNames(rotateOrderEnumNames())
        .doc("The rotate order outputRotate is expressed in (xyz applies X first).");
    b.output(OutputTranslate, "outputTranslate", ValueType::Vector3)
        .shortName("ot")
        .unit(Unit::Distance)
        .doc("Translation, the matrix's last column (outputTranslateX, outputTranslateY, outputTranslateZ).");
    b.output(OutputRotate, "outputRotate", ValueType::Vector3)
        .shortName("or")
        .unit(Unit::Angle)
        .doc(
            "Euler rotation in inputRotateOrder (outputRotateX, outputRotateY, outputRotateZ); the middle "
            "angle lies in [-90, 90] degrees, the others in [-180, 180].");
    b.output(OutputScale, "outputScale", ValueType::Vector3)
        .shortName("os")
        .doc("Scale (outputScaleX, outputScaleY, outputScaleZ); a reflection makes outputScaleX negative.");
    b.output(OutputShear, "outputShear", ValueType::Vector3)
        .shortName("osh")
        .doc("Shear (outputShearX = xy, outputShearY = xz, outputShearZ = yz), as composeMatrix's inputShear.");
    b.output(OutputQuatX, "outputQuatX", ValueType::Double)
        .shortName("oqx")
        .doc("The rotation as a unit quaternion, x part.");
    b.output(OutputQuatY, "outputQuatY", ValueType::Double)
        .shortName("oqy")
        .doc("The rotation as a unit quaternion, y part.");
    b.output(OutputQuatZ, "outputQuatZ", ValueType::Double)
        .shortName("oqz")
        .doc("The rotation as a unit quaternion, z part.");
    b.output(OutputQuatW, "outputQuatW", ValueType::Double)
        .shortName("oqw")
        .doc("The rotation as a unit quaternion, w (real) part.");
    b.affects(InputMatrix, {OutputTranslate, OutputRotate, OutputScale, OutputShear, OutputQuatX, OutputQuatY,
                            OutputQuatZ, OutputQuatW});
    b.affects(InputRotateOrder, {OutputRotate});
    b.factory<DecomposeMatrixNode>();
    return b.build();
}

}  // namespace rig
