// angleBetween: Maya's angleBetween, the rotation that turns vector1 onto vector2.

#include <cmath>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"
#include "nodes/math/rotation_blend.h"

namespace rig {
namespace {

enum Attr : AttrId { Vector1, Vector2, Angle, Axis, Euler };

// A unit vector perpendicular to v (v not zero): v crossed with the world axis it leans on least.
Eigen::Vector3d perpendicular(const Eigen::Vector3d& v)
{
    Eigen::Index least = 0;
    v.cwiseAbs().minCoeff(&least);
    return v.cross(Eigen::Vector3d::Unit(least)).normalized();
}

class AngleBetweenNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const Eigen::Vector3d& a = context.getVector3(Vector1);
        const Eigen::Vector3d& b = context.getVector3(Vector2);
        double angle = 0.0;
        Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
        if (a.norm() > 0.0 && b.norm() > 0.0) {
            const Eigen::Vector3d cross = a.cross(b);
            // atan2 of |a x b| and a . b: accurate near 0 and pi, where acos of the cosine is not.
            angle = std::atan2(cross.norm(), a.dot(b));
            if (cross.norm() > 0.0) axis = cross.normalized();
            else if (a.dot(b) < 0.0) axis = perpendicular(a);
        }
        const Eigen::Quaterniond q(Eigen::AngleAxisd(angle, axis));
        context.setOutput(Angle, angle);
        context.setOutput(Axis, axis);
        context.setOutput(Euler, quaternionEuler(q, RotateOrder::xyz, Eigen::Vector3d::Zero()));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeAngleBetweenType()
{
    NodeTypeBuilder b("angleBetween");
    b.description(
        "The rotation that turns vector1 onto vector2 along the shorter arc (Maya's angleBetween node): angle "
        "between them, axis = vector1 x vector2 normalized, euler the same rotation as xyz Euler angles. A zero "
        "vector gives angle 0 about (0, 0, 1); opposite vectors turn 180 degrees about an axis perpendicular to "
        "vector1. Maya's compound axisAngle is axis and angle here.");
    b.input(Vector1, "vector1", ValueType::Vector3)
        .shortName("v1")
        .defaultValue(Eigen::Vector3d(1, 0, 0))
        .keyable()
        .doc("The vector turned from (vector1X, vector1Y, vector1Z); its length does not matter.");
    b.input(Vector2, "vector2", ValueType::Vector3)
        .shortName("v2")
        .defaultValue(Eigen::Vector3d(1, 0, 0))
        .keyable()
        .doc("The vector turned onto (vector2X, vector2Y, vector2Z); its length does not matter.");
    b.output(Angle, "angle", ValueType::Double).shortName("a").unit(Unit::Angle).doc("The angle, 0 to 180 degrees.");
    b.output(Axis, "axis", ValueType::Vector3)
        .shortName("ax")
        .doc("The unit axis of the turn (axisX, axisY, axisZ); (0, 0, 1) when there is no turn.");
    b.output(Euler, "euler", ValueType::Vector3)
        .shortName("eu")
        .unit(Unit::Angle)
        .doc("The turn as xyz Euler angles (eulerX, eulerY, eulerZ).");
    b.affects(Vector1, {Angle, Axis, Euler}).affects(Vector2, {Angle, Axis, Euler});
    b.factory<AngleBetweenNode>();
    return b.build();
}

}  // namespace rig
