// twistDistribute: the twist of a driver joint's rotation about one of its local axes (swing-twist
// decomposition), shared out to roll joints by weights (forearm and upper-arm twist joints).

#include <cmath>

#include <Eigen/Geometry>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"
#include "nodes/enum_names.h"
#include "nodes/transform_math.h"

namespace rig {
namespace {

enum Attr : AttrId { Rotate, RotateOrderAttr, TwistAxis, Weight, OutTwist, TwistOut };

// The rotation of Euler angles `radians` applied in `order`, as a quaternion built axis by axis (a pure
// single-axis rotation stays exact).
Eigen::Quaterniond eulerToQuaternion(const Eigen::Vector3d& radians, RotateOrder order)
{
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    for (char letter : rotateOrderName(order)) {
        const int axis = letter - 'x';
        q = Eigen::Quaterniond(Eigen::AngleAxisd(radians[axis], Eigen::Vector3d::Unit(axis))) * q;
    }
    return q;
}

class TwistDistributeNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const RotateOrder order = rotateOrderFromIndex(context.getEnum(RotateOrderAttr)).value_or(RotateOrder::xyz);
        const int axisIndex = context.getEnum(TwistAxis);
        const int axis = axisIndex >= 0 && axisIndex < 3 ? axisIndex : 0;
        const Eigen::Quaterniond q = eulerToQuaternion(context.getVector3(Rotate), order);
        // R = swing * twist: the twist quaternion is (w, component along the axis), normalised; its
        // angle, with w >= 0, is 2 * atan2(v_axis, w) in [-pi, pi]. A half turn of pure swing (w = v_axis
        // = 0) has no defined twist and gives 0.
        double w = q.w();
        double v = q.vec()[axis];
        if (w < 0.0) {
            w = -w;
            v = -v;
        }
        const double twist = 2.0 * std::atan2(v, w);
        std::vector<Value> out;
        for (double weight : context.getDoubleArray(Weight)) out.emplace_back(weight * twist);
        context.setOutputElements(OutTwist, std::move(out));
        context.setOutput(TwistOut, twist);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeTwistDistributeType()
{
    NodeTypeBuilder b("twistDistribute");
    b.description(
        "Extracts the twist of a driver rotation about one of its local axes and distributes it to roll "
        "joints: with R = eulerToMatrix(rotate, rotateOrder) written as R = S * T (column vectors: T, a "
        "rotation about twistAxis, applies first; S, the swing, about an axis perpendicular to it), twist = "
        "2 * atan2(q_axis, q_w) from R's quaternion with q_w >= 0, in [-180, 180] degrees, and outTwist[i] = "
        "weight[i] * twist. Connect the driver joint's rotate (a wrist) and outTwist[i] into the roll joints' "
        "rotate about the same axis. No Maya node does this alone (riggers build it from decomposeMatrix "
        "and quatToEuler, or an aimConstraint): the roll joints turn about their own axis only, so with swing "
        "present they are not a fraction of the driver's rotation, only rotation-like.");
    b.input(Rotate, "rotate", ValueType::Vector3)
        .unit(Unit::Angle)
        .keyable()
        .doc(
            "The driver's rotation as Euler angles (connect the driver joint's rotate; its jointOrient is "
            "not part of the twist).");
    b.input(RotateOrderAttr, "rotateOrder", ValueType::Enum)
        .enumNames(rotateOrderEnumNames())
        .doc("Order of the rotate angles (the driver joint's rotateOrder).");
    b.input(TwistAxis, "twistAxis", ValueType::Enum)
        .enumNames({"x", "y", "z"})
        .doc("The driver's local axis the twist is measured about (the bone's axis, usually x).");
    b.input(Weight, "weight", ValueType::DoubleArray)
        .doc("Fraction of the twist for each roll joint, e.g. [0.25, 0.5, 0.75]; one outTwist element each.");
    b.output(OutTwist, "outTwist", ValueType::Double)
        .array()
        .unit(Unit::Angle)
        .doc("outTwist[i] = weight[i] * twist, for each element of weight.");
    b.output(TwistOut, "twist", ValueType::Double)
        .unit(Unit::Angle)
        .doc("The whole extracted twist, in [-180, 180] degrees.");
    b.affects(Rotate, {OutTwist, TwistOut}).affects(RotateOrderAttr, {OutTwist, TwistOut});
    b.affects(TwistAxis, {OutTwist, TwistOut}).affects(Weight, {OutTwist});
    b.factory<TwistDistributeNode>();
    return b.build();
}

}  // namespace rig
