// coupledBend: a bend whose axis is itself turned by a second parameter (a "bend direction" dial, as
// on tentacle and spine rigs). Deliberately not a composition of one rotation per parameter.

#include <cmath>

#include <Eigen/Geometry>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"
#include "nodes/transform_math.h"

namespace rig {
namespace {

enum Attr : AttrId { Bend, Turn, OutRotate };

class CoupledBendNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const double bend = context.getDouble(Bend);
        const double turn = context.getDouble(Turn);
        const Eigen::Vector3d axis(std::cos(turn), std::sin(turn), 0.0);
        const Eigen::Matrix3d r = Eigen::AngleAxisd(bend, axis).toRotationMatrix();
        const Eigen::Vector3d euler =
            closestEuler(matrixToEuler(r, RotateOrder::xyz), Eigen::Vector3d::Zero(), RotateOrder::xyz);
        context.setOutput(OutRotate, euler);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeCoupledBendType()
{
    NodeTypeBuilder b("coupledBend");
    b.description(
        "A bend about an axis that a second parameter turns: R(bend, turn) = rotation by bend about axis = "
        "Rz(turn) * (1, 0, 0) = Rz(turn) * Rx(bend) * Rz(-turn); outRotate is R as xyz Euler angles (the "
        "triple nearest zero). Deliberately not invertible by composition: turn alone (bend = 0) does "
        "nothing, and the rotation bend produces depends on turn, so R(bend, turn) is neither "
        "Rx(bend) * Rturn nor Rturn * Rx(bend) for the rotation Rturn = R(0, turn) = I that turn makes alone, "
        "and no fixed axis per parameter describes it. No single Maya node (riggers build it with "
        "expressions or a rotated parent group that is counter-rotated).");
    b.input(Bend, "bend", ValueType::Double).unit(Unit::Angle).keyable().doc("The bend angle about the turned axis.");
    b.input(Turn, "turn", ValueType::Double)
        .unit(Unit::Angle)
        .keyable()
        .doc("The direction of the bend: the bend axis is X turned by this angle about Z.");
    b.output(OutRotate, "outRotate", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc("The rotation as xyz Euler angles; connect to a joint's rotate (rotateOrder xyz).");
    b.affects(Bend, {OutRotate}).affects(Turn, {OutRotate});
    b.factory<CoupledBendNode>();
    return b.build();
}

}  // namespace rig
