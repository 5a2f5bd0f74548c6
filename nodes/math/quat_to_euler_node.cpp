// quatToEuler: Maya's quatToEuler (quatNodes plugin), Euler angles of a quaternion.

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"
#include "nodes/enum_names.h"
#include "nodes/math/rotation_blend.h"

namespace rig {
namespace {

enum Attr : AttrId { InputQuatX, InputQuatY, InputQuatZ, InputQuatW, InputRotateOrder, OutputRotate };

class QuatToEulerNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const Eigen::Quaterniond q(context.getDouble(InputQuatW), context.getDouble(InputQuatX),
                                   context.getDouble(InputQuatY), context.getDouble(InputQuatZ));
        const auto order = rotateOrderFromIndex(context.getEnum(InputRotateOrder)).value_or(RotateOrder::xyz);
        const bool valid = q.norm() > 0.0 && q.coeffs().allFinite();
        context.setOutput(OutputRotate, valid ? matrixToEuler(q.normalized().toRotationMatrix(), order)
                                              : Eigen::Vector3d::Zero().eval());
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeQuatToEulerType()
{
    NodeTypeBuilder b("quatToEuler");
    b.description(
        "Euler angles of a quaternion (Maya's quatToEuler node): the quaternion is normalized, all four zero "
        "gives no rotation. The middle angle lies in [-90, 90] degrees, the others in [-180, 180]. Maya's "
        "compound inputQuat is the four doubles inputQuatX..W here.");
    b.input(InputQuatX, "inputQuatX", ValueType::Double).shortName("iqx").keyable().doc("The quaternion's x part.");
    b.input(InputQuatY, "inputQuatY", ValueType::Double).shortName("iqy").keyable().doc("The quaternion's y part.");
    b.input(InputQuatZ, "inputQuatZ", ValueType::Double).shortName("iqz").keyable().doc("The quaternion's z part.");
    b.input(InputQuatW, "inputQuatW", ValueType::Double)
        .shortName("iqw")
        .defaultValue(1.0)
        .keyable()
        .doc("The quaternion's w (real) part.");
    b.input(InputRotateOrder, "inputRotateOrder", ValueType::Enum)
        .shortName("iro")
        .enumNames(rotateOrderEnumNames())
        .doc("The order outputRotate is expressed in (xyz applies X first).");
    b.output(OutputRotate, "outputRotate", ValueType::Vector3)
        .shortName("ort")
        .unit(Unit::Angle)
        .doc("The rotation as Euler angles (outputRotateX, outputRotateY, outputRotateZ).");
    for (AttrId in : {InputQuatX, InputQuatY, InputQuatZ, InputQuatW, InputRotateOrder}) b.affects(in, {OutputRotate});
    b.factory<QuatToEulerNode>();
    return b.build();
}

}  // namespace rig
