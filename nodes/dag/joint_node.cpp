// joint: Maya's joint node (translate, rotate with a rotate order, jointOrient, rotateAxis, scale
// with segment scale compensation).
#include "nodes/builtin_nodes.h"
#include "nodes/enum_names.h"
#include "nodes/transform_math.h"

namespace rig {
namespace {

enum Attr : AttrId {
    translate,
    rotate,
    rotateOrder,
    jointOrient,
    rotateAxis,
    scale,
    inverseScale,
    segmentScaleCompensate,
    parentMatrix,
    matrix,
    worldMatrix,
    worldInverseMatrix
};

class JointNode : public Node {
public:
    void compute(ComputeContext& c) override
    {
        JointInputs in;
        in.translate = c.getVector3(translate);
        in.rotate = c.getVector3(rotate);
        in.rotateOrder = static_cast<RotateOrder>(c.getEnum(rotateOrder));
        in.jointOrient = c.getVector3(jointOrient);
        in.rotateAxis = c.getVector3(rotateAxis);
        in.scale = c.getVector3(scale);
        in.inverseScale = c.getVector3(inverseScale);
        in.segmentScaleCompensate = c.getBool(segmentScaleCompensate);
        const Eigen::Matrix4d local = jointMatrix(in);
        const Eigen::Matrix4d world = c.getMatrix(parentMatrix) * local;
        c.setOutput(matrix, local);
        c.setOutput(worldMatrix, world);
        c.setOutput(worldInverseMatrix, Eigen::Matrix4d(world.inverse()));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeJointType()
{
    NodeTypeBuilder b("joint");
    b.description(
        "A skeleton joint, as Maya's joint node: local matrix T * IS * JO * R * RA * S (column "
        "vectors; IS the inverse of the parent's scale when segmentScaleCompensate), "
        "world = parentMatrix * local.");
    b.input(translate, "translate", ValueType::Vector3)
        .shortName("t")
        .unit(Unit::Distance)
        .keyable()
        .doc("Offset from the parent, cm.");
    b.input(rotate, "rotate", ValueType::Vector3)
        .shortName("r")
        .unit(Unit::Angle)
        .keyable()
        .doc("Euler angles, degrees in files.");
    b.input(rotateOrder, "rotateOrder", ValueType::Enum)
        .shortName("ro")
        .enumNames(rotateOrderEnumNames())
        .doc("Order in which the rotate angles apply: xyz applies X first.");
    b.input(jointOrient, "jointOrient", ValueType::Vector3)
        .shortName("jo")
        .unit(Unit::Angle)
        .doc("Rest orientation (xyz order), applied after rotate.");
    b.input(rotateAxis, "rotateAxis", ValueType::Vector3)
        .shortName("ra")
        .unit(Unit::Angle)
        .doc("Orientation of the rotation axes (xyz order), applied before rotate.");
    b.input(scale, "scale", ValueType::Vector3)
        .shortName("s")
        .defaultValue(Eigen::Vector3d(1, 1, 1))
        .keyable()
        .doc("Scale factors.");
    b.input(inverseScale, "inverseScale", ValueType::Vector3)
        .shortName("is")
        .defaultValue(Eigen::Vector3d(1, 1, 1))
        .doc("The parent joint's scale (connected by `parent:`), undone when segmentScaleCompensate is on.");
    b.input(segmentScaleCompensate, "segmentScaleCompensate", ValueType::Bool)
        .shortName("ssc")
        .defaultValue(true)
        .doc("Keep the parent's scale from reaching this joint.");
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
    return b.factory<JointNode>().build();
}

}  // namespace rig
