// distanceBetween: Maya's distanceBetween, the distance between two points each placed by a matrix.

#include <Eigen/Geometry>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Point1, Point2, InMatrix1, InMatrix2, Distance };

class DistanceBetweenNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const Eigen::Vector3d a =
            (context.getMatrix(InMatrix1) * context.getVector3(Point1).homogeneous()).hnormalized();
        const Eigen::Vector3d b =
            (context.getMatrix(InMatrix2) * context.getVector3(Point2).homogeneous()).hnormalized();
        context.setOutput(Distance, (b - a).norm());
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeDistanceBetweenType()
{
    NodeTypeBuilder b("distanceBetween");
    b.description(
        "The distance between two points (Maya's distanceBetween node): distance = |inMatrix2 * point2 - "
        "inMatrix1 * point1|, cm. Connect a transform's worldMatrix to inMatrix1 and leave point1 at the origin to "
        "measure from that transform's position.");
    b.input(Point1, "point1", ValueType::Vector3)
        .shortName("p1")
        .unit(Unit::Distance)
        .keyable()
        .doc("The first point, in inMatrix1's space (point1X, point1Y, point1Z).");
    b.input(Point2, "point2", ValueType::Vector3)
        .shortName("p2")
        .unit(Unit::Distance)
        .keyable()
        .doc("The second point, in inMatrix2's space (point2X, point2Y, point2Z).");
    b.input(InMatrix1, "inMatrix1", ValueType::Matrix4).shortName("im1").doc("Places point1 (identity: world).");
    b.input(InMatrix2, "inMatrix2", ValueType::Matrix4).shortName("im2").doc("Places point2 (identity: world).");
    b.output(Distance, "distance", ValueType::Double)
        .shortName("d")
        .unit(Unit::Distance)
        .doc("The distance between the placed points, cm.");
    for (AttrId in : {Point1, Point2, InMatrix1, InMatrix2}) b.affects(in, {Distance});
    b.factory<DistanceBetweenNode>();
    return b.build();
}

}  // namespace rig
