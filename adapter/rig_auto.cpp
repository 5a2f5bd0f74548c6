#include "adapter/rig_auto.h"

#include <algorithm>
#include <set>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {
namespace {

bool isTimeCurve(std::string_view type) { return type.starts_with("animCurveT"); }

// Nodes that carry keys to a channel and nothing of the rig: time curves, the time, unit conversions and the
// blends of animation layers.
bool isAnimationOnly(std::string_view type)
{
    return isTimeCurve(type) || type == "time" || type == "unitConversion" || type.starts_with("animBlendNode");
}

// Whether every node upstream of `start` (itself included) carries animation only, with a time curve among them.
bool animationAlone(const Graph& g, NodeId start)
{
    const std::vector<char> upstream = reachableNodes(g.model(), {start}, false);
    bool curve = false;
    for (NodeId n = 0; n < g.nodeCount(); ++n) {
        if (!upstream[static_cast<std::size_t>(n)]) continue;
        const std::string& type = g.nodeType(n).name();
        if (!isAnimationOnly(type)) return false;
        curve = curve || isTimeCurve(type);
    }
    return curve;
}

// The channel-box state the scene gave a plug, a vector component's falling back to its vector's.
MayaSceneInfo::PlugState stateOf(const Graph& g, const MayaSceneInfo& info, const Plug& p)
{
    MayaSceneInfo::PlugState state;
    if (const auto it = info.plugStates.find(g.plugName(p)); it != info.plugStates.end()) state = it->second;
    if (p.child >= 0)
        if (const auto it = info.plugStates.find(g.plugName({p.node, p.attr, p.index, -1}));
            it != info.plugStates.end()) {
            if (!state.keyable) state.keyable = it->second.keyable;
            if (!state.locked) state.locked = it->second.locked;
            if (!state.channelBox) state.channelBox = it->second.channelBox;
        }
    return state;
}

// Whether a setting can take more than one value: an enum with two names or more, a number whose limits differ.
bool hasChoices(const AttributeSpec& s, ValueType type)
{
    if (type == ValueType::Enum) return s.enumNames.size() >= 2;
    return !(s.min && s.max && *s.min >= *s.max);
}

// The scene's controls: nodes with a nurbsCurve shape, and every node (but the curves' own plumbing) a time curve
// keys, in node order.
std::vector<NodeId> findControls(const Graph& g, const MayaSceneInfo& info)
{
    std::set<NodeId> controls;
    for (const std::string& name : info.controls)
        if (const NodeId n = g.findNode(name); n >= 0) controls.insert(n);
    for (const Connection& c : g.connections())
        if (!isAnimationOnly(g.nodeType(c.destination.node).name()) && timeCurveInput(g, c.destination))
            controls.insert(c.destination.node);
    return {controls.begin(), controls.end()};
}

// The number plugs of an input attribute: itself, or a vector's components; none for arrays and other types.
std::vector<Plug> channelPlugs(const Graph& g, NodeId n, AttrId a)
{
    const AttributeSpec& s = g.attributes(n)[static_cast<std::size_t>(a)];
    if (!s.input || s.array) return {};
    if (s.type == ValueType::Vector3) return {{n, a, -1, 0}, {n, a, -1, 1}, {n, a, -1, 2}};
    if (!isNumeric(s.type)) return {};
    return {{n, a, -1, -1}};
}

void sortChannel(const Graph& g, const MayaSceneInfo& info, const Plug& p, ControlChannels& out)
{
    const AttributeSpec& s = g.spec(p);
    const MayaSceneInfo::PlugState state = stateOf(g, info, p);
    const bool keyable = state.keyable.value_or(s.keyable);
    const bool channelBox = keyable || state.channelBox.value_or(false);
    const std::string name = g.plugName(p);
    // A channel the type makes keyable that the scene locked or took out of the channel box is said.
    if ((channelBox || s.keyable) && state.locked.value_or(false)) return out.passed.push_back({name, "locked"});
    if (!channelBox) {
        if (s.keyable) out.passed.push_back({name, "not keyable"});
        return;
    }
    const ValueType type = g.plugType(p);
    if (const Connection* c = g.incomingConnection(p)) {
        if (keyable && type == ValueType::Double && timeCurveInput(g, p)) out.candidates.push_back(p);
        else out.passed.push_back({name, fmt::format("driven by {}", g.plugName(c->source))});
        return;
    }
    if (keyable && type == ValueType::Double) out.candidates.push_back(p);
    else if (hasChoices(s, type)) out.settings.push_back(p);
}

}  // namespace

bool sceneKeyable(const Graph& g, const MayaSceneInfo& info, const Plug& p)
{
    return stateOf(g, info, p).keyable.value_or(false);
}

std::vector<char> reachableNodes(const GraphModel& m, const std::vector<NodeId>& start, bool downstream)
{
    std::vector<char> seen(static_cast<std::size_t>(m.nodeCount()), 0);
    std::vector<NodeId> stack;
    const auto visit = [&](NodeId n) {
        if (seen[static_cast<std::size_t>(n)]) return;
        seen[static_cast<std::size_t>(n)] = 1;
        stack.push_back(n);
    };
    for (NodeId n : start) visit(n);
    while (!stack.empty()) {
        const auto& topology = m.topology(stack.back());
        stack.pop_back();
        if (!downstream)
            for (const Connection& c : topology.incoming) visit(c.source.node);
        else
            for (const GraphModel::NodeTopology::Edge& e : topology.outgoing) visit(e.node);
    }
    return seen;
}

const Connection* timeCurveInput(const Graph& g, const Plug& p)
{
    const Connection* c = g.incomingConnection(p);
    // A curve keys one channel: a connection into a whole vector is some other node's (a pair blend's) output.
    if (!c || c->destination.child != p.child || !isAnimationOnly(g.nodeType(c->source.node).name()) ||
        !animationAlone(g, c->source.node))
        return nullptr;
    return c;
}

CutCurve cutTimeCurve(Graph& g, const Plug& p)
{
    const Connection* c = timeCurveInput(g, p);
    if (!c) throw internalError(fmt::format("cutTimeCurve: no time curve drives {}", g.plugName(p)));
    const CutCurve cut{c->source, c->destination, c->rawUnits};
    const Value value = g.getValue(p);
    g.disconnect(cut.source, cut.destination);
    g.setValue(p, value);
    return cut;
}

AutoOutputs autoOutputJoints(const Graph& g, const MayaSceneInfo& info)
{
    AutoOutputs out;
    std::set<NodeId> bound;
    for (const MayaSceneInfo::Skin& skin : info.skins) {
        const std::size_t before = bound.size();
        for (const std::string& influence : skin.influences)
            if (const NodeId n = influence.empty() ? -1 : g.findNode(influence);
                n >= 0 && g.nodeType(n).name() == "joint")
                bound.insert(n);
        if (bound.size() > before) ++out.skins;
    }
    if (bound.empty())
        for (NodeId n = 0; n < g.nodeCount(); ++n)
            if (g.nodeType(n).name() == "joint") bound.insert(n);
    out.joints.assign(bound.begin(), bound.end());
    return out;
}

ControlChannels controlChannels(const Graph& g, const MayaSceneInfo& info, const std::vector<NodeId>& outputs)
{
    ControlChannels out;
    const std::vector<char> upstream = reachableNodes(g.model(), outputs, false);
    for (const NodeId n : findControls(g, info)) {
        out.controls.push_back(g.nodeName(n));
        if (!upstream[static_cast<std::size_t>(n)]) continue;
        for (AttrId a = 0; a < static_cast<AttrId>(g.attributes(n).size()); ++a)
            for (const Plug& p : channelPlugs(g, n, a)) sortChannel(g, info, p, out);
    }
    return out;
}

double userValue(Graph& g, const Plug& p)
{
    const AttributeSpec& s = g.spec(p);
    return toDouble(g.getValue(p)) / unitFactor(s.unit == Unit::Angle ? Unit::None : s.unit, s.unit);
}

}  // namespace rig
