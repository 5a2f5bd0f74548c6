// setRange: Maya's setRange, each component mapped from [oldMin, oldMax] onto [min, max].

#include <algorithm>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Value_, Min, Max, OldMin, OldMax, OutValue };

// One component: the position of value in the old range, held to [0, 1] (Maya's setRange stops at its ends),
// then placed in the new range. An empty old range reads as its far end above it and its near end otherwise.
double setRange(double value, double min, double max, double oldMin, double oldMax)
{
    double t = 0.0;
    if (oldMax != oldMin) t = std::clamp((value - oldMin) / (oldMax - oldMin), 0.0, 1.0);
    else t = value > oldMin ? 1.0 : 0.0;
    return min + t * (max - min);
}

class SetRangeNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const Eigen::Vector3d& v = context.getVector3(Value_);
        const Eigen::Vector3d& lo = context.getVector3(Min);
        const Eigen::Vector3d& hi = context.getVector3(Max);
        const Eigen::Vector3d& oldLo = context.getVector3(OldMin);
        const Eigen::Vector3d& oldHi = context.getVector3(OldMax);
        Eigen::Vector3d out;
        for (int i = 0; i < 3; ++i) out[i] = setRange(v[i], lo[i], hi[i], oldLo[i], oldHi[i]);
        context.setOutput(OutValue, out);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeSetRangeType()
{
    NodeTypeBuilder b("setRange");
    b.description(
        "Maps each component of value from [oldMin, oldMax] onto [min, max] (Maya's setRange node): outValue = "
        "min + t * (max - min), t = (value - oldMin) / (oldMax - oldMin) held to [0, 1], so the output stops at "
        "min and max. Where oldMin == oldMax, t is 1 for value > oldMin and 0 otherwise. Unitless.");
    b.input(Value_, "value", ValueType::Vector3)
        .shortName("v")
        .keyable()
        .doc("The values mapped (valueX, valueY, valueZ).");
    b.input(Min, "min", ValueType::Vector3).shortName("n").keyable().doc("The new range's start (minX, minY, minZ).");
    b.input(Max, "max", ValueType::Vector3).shortName("m").keyable().doc("The new range's end (maxX, maxY, maxZ).");
    b.input(OldMin, "oldMin", ValueType::Vector3)
        .shortName("on")
        .keyable()
        .doc("The old range's start (oldMinX, oldMinY, oldMinZ).");
    b.input(OldMax, "oldMax", ValueType::Vector3)
        .shortName("om")
        .keyable()
        .doc("The old range's end (oldMaxX, oldMaxY, oldMaxZ).");
    b.output(OutValue, "outValue", ValueType::Vector3)
        .shortName("o")
        .doc("The mapped values (outValueX, outValueY, outValueZ).");
    for (AttrId in : {Value_, Min, Max, OldMin, OldMax}) b.affects(in, {OutValue});
    b.factory<SetRangeNode>();
    return b.build();
}

}  // namespace rig
