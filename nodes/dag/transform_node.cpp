// transform: Maya's transform node (translate, rotate with a rotate order, scale, shear, pivots).
#include "nodes/builtin_nodes.h"
#include "nodes/enum_names.h"
#include "nodes/transform_math.h"

namespace rig {
namespace {

enum Attr : AttrId {
    translate,
    rotate,
    rotateOrder,
    scale,
    shear,
    rotatePivot,
    rotatePivotTranslate,
    scalePivot,
    scalePivotTranslate,
    rotateAxis,
    parentMatrix,
    matrix,
    worldMatrix,
    worldInverseMatrix
};

class TransformNode : public Node {
public:
    void compute(ComputeContext& c) override
    {
        TransformInputs in;
        in.translate = c.getVector3(translate);
        in.rotate = c.getVector3(rotate);
        in.rotateOrder = static_cast<RotateOrder>(c.getEnum(rotateOrder));
        in.scale = c.getVector3(scale);
        in.shear = c.getVector3(shear);
        in.rotatePivot = c.getVector3(rotatePivot);
        in.rotatePivotTranslate = c.getVector3(rotatePivotTranslate);
        in.scalePivot = c.getVector3(scalePivot);
        in.scalePivotTranslate = c.getVector3(scalePivotTranslate);
        in.rotateAxis = c.getVector3(rotateAxis);
        const Eigen::Matrix4d local = transformMatrix(in);
        const Eigen::Matrix4d world = c.getMatrix(parentMatrix) * local;
        c.setOutput(matrix, local);
        c.setOutput(worldMatrix, world);
        c.setOutput(worldInverseMatrix, Eigen::Matrix4d(world.inverse()));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeTransformType()
{
    NodeTypeBuilder b("transform");
    b.description(
        "A DAG transform, as Maya's transform node: local matrix "
        "T * RT * RP * R * RA * RP^-1 * ST * SP * SH * S * SP^-1 (column vectors), "
        "world = parentMatrix * local.");
    b.input(translate, "translate", ValueType::Vector3)
        .shortName("t")
        .unit(Unit::Distance)
        .keyable()
        .doc("Translation, cm.");
    b.input(rotate, "rotate", ValueType::Vector3)
        .shortName("r")
        .unit(Unit::Angle)
        .keyable()
        .doc("Euler angles, degrees in files.");
    b.input(rotateOrder, "rotateOrder", ValueType::Enum)
        .shortName("ro")
        .enumNames(rotateOrderEnumNames())
        .doc("Order in which the rotate angles apply: xyz applies X first.");
    b.input(scale, "scale", ValueType::Vector3)
        .shortName("s")
        .defaultValue(Eigen::Vector3d(1, 1, 1))
        .keyable()
        .doc("Scale factors.");
    b.input(shear, "shear", ValueType::Vector3)
        .shortName("sh")
        .children("shearXY", "shearXZ", "shearYZ")
        .doc("Shear xy, xz, yz.");
    b.input(rotatePivot, "rotatePivot", ValueType::Vector3)
        .shortName("rp")
        .unit(Unit::Distance)
        .doc("Pivot of rotation, cm, local.");
    b.input(rotatePivotTranslate, "rotatePivotTranslate", ValueType::Vector3)
        .shortName("rpt")
        .unit(Unit::Distance)
        .doc("Offset keeping the object in place when the rotate pivot moves, cm.");
    b.input(scalePivot, "scalePivot", ValueType::Vector3)
        .shortName("sp")
        .unit(Unit::Distance)
        .doc("Pivot of scale and shear, cm.");
    b.input(scalePivotTranslate, "scalePivotTranslate", ValueType::Vector3)
        .shortName("spt")
        .unit(Unit::Distance)
        .doc("Offset keeping the object in place when the scale pivot moves, cm.");
    b.input(rotateAxis, "rotateAxis", ValueType::Vector3)
        .shortName("ra")
        .unit(Unit::Angle)
        .doc("Orientation of the rotation axes (xyz order), applied before rotate.");
    b.input(parentMatrix, "parentMatrix", ValueType::Matrix4)
        .shortName("pm")
        .doc("World matrix of the parent (identity at the root).");
    b.output(matrix, "matrix", ValueType::Matrix4).shortName("m").doc("Local matrix.");
    b.output(worldMatrix, "worldMatrix", ValueType::Matrix4).shortName("wm").doc("parentMatrix * matrix.");
    b.output(worldInverseMatrix, "worldInverseMatrix", ValueType::Matrix4)
        .shortName("wim")
        .doc("Inverse of worldMatrix.");
    for (AttrId in = translate; in < parentMatrix; ++in) b.affects(in, {matrix, worldMatrix, worldInverseMatrix});
    b.affects(parentMatrix, {worldMatrix, worldInverseMatrix});
    return b.factory<TransformNode>().build();
}

}  // namespace rig
