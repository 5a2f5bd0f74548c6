// time: the scene time as a plug (Maya's time1.outTime).
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { time, outTime };

class TimeNode : public Node {
public:
    void compute(ComputeContext& c) override { c.setOutput(outTime, c.getDouble(time)); }
};

}  // namespace

std::shared_ptr<const NodeType> makeTimeType()
{
    NodeTypeBuilder b("time");
    b.description(
        "The scene time in frames, as Maya's time node: outTime follows the graph's time "
        "(graph-eval --frames) unless `time` is connected.");
    b.input(time, "time", ValueType::Double).unit(Unit::Time).sceneTime().doc("Current frame.");
    b.output(outTime, "outTime", ValueType::Double).shortName("o").unit(Unit::Time).doc("Current frame.");
    b.affects(time, {outTime});
    // Maya's time1 also saves its unwarped time (the same frame unless a time warp is on, which is not read):
    // dropped, so that the scene's statistics do not count it as unknown.
    b.mayaField("unwarpedTime", "unw", [](const MayaFieldInput&) { return std::vector<std::pair<AttrId, Value>>{}; });
    return b.factory<TimeNode>().build();
}

}  // namespace rig
