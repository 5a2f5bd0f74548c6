// squashStretch: volume-preserving scale along a bone (cartoon squash and stretch).

#include <algorithm>
#include <cmath>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Stretch, Length, RestLength, Axis, Volume, OutScale, OutStretch };

// The smallest stretch factor: keeps s^(-volume/2) finite.
constexpr double minStretch = 1e-3;

class SquashStretchNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        double s = context.getDouble(Stretch);
        const double restLength = context.getDouble(RestLength);
        if (restLength > 0.0) s *= context.getDouble(Length) / restLength;
        s = std::max(s, minStretch);  // connections bypass the attribute's minimum
        if (!std::isfinite(s)) s = 1.0;
        const double volume = context.getDouble(Volume);
        const int axisIndex = context.getEnum(Axis);
        const int axis = axisIndex >= 0 && axisIndex < 3 ? axisIndex : 0;
        const double across = std::pow(s, -0.5 * volume);
        Eigen::Vector3d scale(across, across, across);
        scale[axis] = s;
        context.setOutput(OutScale, scale.allFinite() ? scale : Eigen::Vector3d(1, 1, 1));
        context.setOutput(OutStretch, s);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeSquashStretchType()
{
    NodeTypeBuilder b("squashStretch");
    b.description(
        "Volume-preserving squash and stretch of a bone: s = stretch * (length / restLength when restLength "
        "> 0), at least 0.001; outScale = s along `axis` and s^(-volume / 2) across it, so the product of "
        "the three scales is s^(1 - volume): 1 (volume kept) at volume = 1. Connect outScale to the joint's "
        "scale. No single Maya node (riggers build it from multiplyDivide power nodes).");
    b.input(Stretch, "stretch", ValueType::Double)
        .defaultValue(1.0)
        .min(minStretch)
        .keyable()
        .doc("The stretch factor along the bone (1 = rest, 2 = twice as long); values below 0.001 act as 0.001.");
    b.input(Length, "length", ValueType::Double)
        .unit(Unit::Distance)
        .min(0.0)
        .doc("The bone's current length (a distance measurement); used only when restLength > 0.");
    b.input(RestLength, "restLength", ValueType::Double)
        .unit(Unit::Distance)
        .min(0.0)
        .doc(
            "The bone's rest length; when > 0 the stretch factor is multiplied by length / restLength. "
            "0 (the default) ignores length.");
    b.input(Axis, "axis", ValueType::Enum)
        .enumNames({"x", "y", "z"})
        .doc("The bone's axis: the component of outScale that stretches.");
    b.input(Volume, "volume", ValueType::Double)
        .defaultValue(1.0)
        .range(0.0, 10.0)
        .keyable()
        .doc(
            "Volume preservation: 0 = none (the cross axes stay 1), 1 = full (product of scales 1); above 1 "
            "(up to 10) exaggerates the squash.");
    b.output(OutScale, "outScale", ValueType::Vector3).doc("s along axis, s^(-volume / 2) on the two others.");
    b.output(OutStretch, "outStretch", ValueType::Double)
        .doc("The stretch factor s used (after the length ratio and the floor).");
    b.affects(Stretch, {OutScale, OutStretch}).affects(Length, {OutScale, OutStretch});
    b.affects(RestLength, {OutScale, OutStretch}).affects(Axis, {OutScale}).affects(Volume, {OutScale});
    b.factory<SquashStretchNode>();
    return b.build();
}

}  // namespace rig
