#include "adapter/rig_switches.h"

#include <algorithm>
#include <map>
#include <set>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {
namespace {

bool isDag(const GraphModel& m, NodeId n)
{
    const std::string& type = m.topology(n).type->name();
    return type == "joint" || type == "transform";
}

// The connection feeding `plug` (or its whole vector when `plug` is a component), or null.
const Connection* feeding(const GraphModel& m, const Plug& plug)
{
    for (const Connection& connection : m.topology(plug.node).incoming) {
        const Plug& d = connection.destination;
        if (d == plug || (d.node == plug.node && d.attr == plug.attr && d.index == plug.index && d.child < 0))
            return &connection;
    }
    return nullptr;
}

// The parameter whose plug drives `plug` through plain connections (input to input), or -1.
int drivingParameter(const GraphModel& m, Plug plug, const std::vector<Plug>& parameters)
{
    // The graph is acyclic: the walk ends.
    while (true) {
        const auto it = std::find(parameters.begin(), parameters.end(), plug);
        if (it != parameters.end()) return static_cast<int>(it - parameters.begin());
        const Connection* c = feeding(m, plug);
        if (!c || !m.spec(c->source).input) return -1;  // undriven, or computed by a node
        plug = c->source;
    }
}

// Per blendColors node whose blender a parameter drives: that parameter.
std::map<NodeId, int> switchedBlends(const GraphModel& m, const std::vector<Plug>& parameters)
{
    std::map<NodeId, int> blends;
    for (NodeId n = 0; n < m.nodeCount(); ++n) {
        const auto& topology = m.topology(n);
        if (topology.type->name() != "blendColors") continue;
        const auto& specs = topology.specs();
        for (AttrId a = 0; a < static_cast<AttrId>(specs.size()); ++a)
            if (specs[static_cast<std::size_t>(a)].name == "blender")
                if (const int p = drivingParameter(m, Plug{n, a}, parameters); p >= 0) blends[n] = p;
    }
    return blends;
}

// The switches of the blendColors nodes feeding joint `joint`'s own inputs, up through nodes that are not DAG nodes.
std::set<int> switchesOf(const GraphModel& m, NodeId joint, const std::map<NodeId, int>& blends)
{
    std::set<int> found;
    std::vector<NodeId> stack;
    std::set<NodeId> seen;
    for (const Connection& connection : m.topology(joint).incoming) {
        if (m.spec(connection.destination).name != "parentMatrix") stack.push_back(connection.source.node);
    }
    while (!stack.empty()) {
        const NodeId n = stack.back();
        stack.pop_back();
        if (!seen.insert(n).second || isDag(m, n)) continue;
        if (const auto b = blends.find(n); b != blends.end()) found.insert(b->second);
        for (const Connection& c : m.topology(n).incoming) stack.push_back(c.source.node);
    }
    return found;
}

}  // namespace

RigSwitches findSwitches(GraphRigFunction& rig, const std::string& rigName)
{
    const GraphModel& m = rig.graph().model();
    const std::map<NodeId, int> blends = switchedBlends(m, rig.parameterPlugs());
    RigSwitches out{{}, std::vector<int>(rig.outputs().size(), -1)};
    if (blends.empty()) return out;
    const std::vector<char> helper = rig.helperOutputs();
    std::set<int> used;
    for (std::size_t k = 0; k < rig.outputs().size(); ++k) {
        if (helper[k]) continue;
        const std::set<int> switches = switchesOf(m, rig.outputPlugs()[k].node, blends);
        if (switches.size() > 1) {
            const auto name = [&](int p) { return rig.parameters()[static_cast<std::size_t>(p)].name; };
            throw Error(fmt::format(
                "{}: output '{}' is blended by two switches, {} and {}; rig-learn blends an output by one switch: "
                "hold the other with the spec's `set:` (or --set)",
                rigName, rig.outputs()[k], name(*switches.begin()), name(*std::next(switches.begin()))));
        }
        if (switches.empty()) continue;
        out.switchOfOutput[k] = *switches.begin();
        used.insert(*switches.begin());
    }
    // A blend's weight goes from the FK branch (0) to the IK branch (1): the solver must not take it past them.
    for (const int p : used) {
        const RigParameter& r = rig.parameters()[static_cast<std::size_t>(p)];
        if (!r.limited || r.min < 0.0 || r.max > 1.0)
            throw Error(fmt::format(
                "{}: switch '{}' (it drives a blendColors blender) is not limited to [0, 1]; give its attribute min 0 "
                "and max 1, or hold it with the spec's `set:` (or --set)",
                rigName, r.name));
    }
    out.switches.assign(used.begin(), used.end());
    return out;
}

}  // namespace rig
