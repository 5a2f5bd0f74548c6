// eulerToQuat: Maya's eulerToQuat (quatNodes plugin), the quaternion of Euler angles.

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"
#include "nodes/enum_names.h"
#include "nodes/math/rotation_blend.h"

namespace rig {
namespace {

enum Attr : AttrId { InputRotate, InputRotateOrder, OutputQuatX, OutputQuatY, OutputQuatZ, OutputQuatW };

class EulerToQuatNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const auto order = rotateOrderFromIndex(context.getEnum(InputRotateOrder)).value_or(RotateOrder::xyz);
        const Eigen::Quaterniond q = eulerQuaternion(context.getVector3(InputRotate), order);
        context.setOutput(OutputQuatX, q.x());
        context.setOutput(OutputQuatY, q.y());
        context.setOutput(OutputQuatZ, q.z());
        context.setOutput(OutputQuatW, q.w());
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeEulerToQuatType()
{
    NodeTypeBuilder b("eulerToQuat");
    b.description(
        "The quaternion of Euler angles (Maya's eulerToQuat node), composed axis by axis in inputRotateOrder "
        "(xyz: qz * qy * qx), so its sign follows the angles (a turn past 180 degrees gives w < 0). Maya's "
        "compound outputQuat is the four doubles outputQuatX..W here.");
    b.input(InputRotate, "inputRotate", ValueType::Vector3)
        .shortName("irt")
        .unit(Unit::Angle)
        .keyable()
        .doc("The Euler angles (inputRotateX, inputRotateY, inputRotateZ).");
    b.input(InputRotateOrder, "inputRotateOrder", ValueType::Enum)
        .shortName("iro")
        .enumNames(rotateOrderEnumNames())
        .doc("The order the angles apply in (xyz applies X first).");
    b.output(OutputQuatX, "outputQuatX", ValueType::Double).shortName("oqx").doc("The quaternion's x part.");
    b.output(OutputQuatY, "outputQuatY", ValueType::Double).shortName("oqy").doc("The quaternion's y part.");
    b.output(OutputQuatZ, "outputQuatZ", ValueType::Double).shortName("oqz").doc("The quaternion's z part.");
    b.output(OutputQuatW, "outputQuatW", ValueType::Double).shortName("oqw").doc("The quaternion's w (real) part.");
    for (AttrId in : {InputRotate, InputRotateOrder})
        b.affects(in, {OutputQuatX, OutputQuatY, OutputQuatZ, OutputQuatW});
    b.factory<EulerToQuatNode>();
    return b.build();
}

}  // namespace rig
