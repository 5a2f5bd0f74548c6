#include "adapter/graph_rig_function.h"

#include <fnmatch.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/plug_glob.h"
#include "graph/rig_file.h"
#include "graph/suggest.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "nodes/clips/maya_clip.h"

namespace rig {

std::uint64_t fnv1a64(std::string_view bytes, std::uint64_t hash)
{
    for (const char c : bytes) {
        hash ^= static_cast<unsigned char>(c);
        hash *= 0x100000001b3ull;
    }
    return hash;
}

namespace {

bool globMatches(const std::string& glob, const std::string& name)
{
    return fnmatch(glob.c_str(), name.c_str(), 0) == 0;
}

// Why a scalar plug cannot be a parameter, or "" when it can: a time curve's channel can when `cutTimeCurves`. Keyable
// by its attribute or by the scene (a Maya scene's `setAttr -k on` on an added attribute, as --params auto reads it,
// so that an approximation learned with auto parameters loads its rig by their names).
std::string whyNotParameter(const Graph& g, const MayaSceneInfo& info, const Plug& p, bool cutTimeCurves)
{
    const AttributeSpec& s = g.spec(p);
    if (!s.input) return "an output, computed by its node";
    if (g.plugType(p) != ValueType::Double)
        return fmt::format("a {} value, not a number", valueTypeName(g.plugType(p)));
    if (!s.keyable && !sceneKeyable(g, info, p)) return "not keyable (not an animator control)";
    if (const Connection* c = g.incomingConnection(p); c && !(cutTimeCurves && timeCurveInput(g, p)))
        return fmt::format("driven by {}", g.plugName(c->source));
    return {};
}

// A vector attribute stands for its components.
std::vector<Plug> scalars(const Graph& g, const Plug& p)
{
    if (p.child >= 0 || g.spec(p).type != ValueType::Vector3) return {p};
    return {{p.node, p.attr, p.index, 0}, {p.node, p.attr, p.index, 1}, {p.node, p.attr, p.index, 2}};
}

// What to say about a glob that matches no plug: which half of node.attribute is wrong, and a
// suggestion for a typo.
std::string noPlugHint(const Graph& g, const MayaSceneInfo& info, const std::string& glob, bool cutTimeCurves)
{
    const auto dot = glob.find('.');
    if (dot == std::string::npos) return "a parameter is node.attribute, e.g. 'L_arm_*.rotate?' or 'hips.translateX'";
    const std::string nodePart = glob.substr(0, dot), attrPart = glob.substr(dot + 1);
    std::vector<std::string> nodeNames;
    std::vector<NodeId> nodes;
    for (NodeId n = 0; n < g.nodeCount(); ++n) {
        nodeNames.push_back(g.nodeName(n));
        if (globMatches(nodePart, nodeNames.back())) nodes.push_back(n);
    }
    if (nodes.empty()) return fmt::format("no node matches '{}'{}", nodePart, didYouMean(nodePart, nodeNames));
    std::set<std::string> attributes;
    forEachPlug(g, [&](const Plug& p) {
        if (std::find(nodes.begin(), nodes.end(), p.node) != nodes.end() &&
            whyNotParameter(g, info, p, cutTimeCurves).empty()) {
            const std::string name = g.plugName(p);
            attributes.insert(name.substr(name.find('.') + 1));
        }
    });
    const std::vector<std::string> candidates(attributes.begin(), attributes.end());
    const std::string suggestion = closestName(attrPart, candidates);
    const std::string where =
        nodes.size() == 1
            ? fmt::format("node '{}' has no keyable attribute", g.nodeName(nodes.front()))
            : fmt::format("{} nodes match '{}', but none has a keyable attribute", nodes.size(), nodePart);
    return fmt::format(
        "{} matching '{}'{}", where, attrPart,
        suggestion.empty() ? std::string() : fmt::format("; did you mean '{}.{}'?", nodePart, suggestion));
}

std::string readBytes(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    if (!in) throw Error(fmt::format("{}: cannot read it to fingerprint the rig", file.string()));
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

// A held plug's value as the graph stores it (internal units, the plug's own type). `refuse(reason,
// advice)` throws for a value the plug cannot hold.
template <class Refuse>
Value heldValue(const Graph& g, const Plug& p, double value, const Refuse& refuse)
{
    const AttributeSpec& s = g.spec(p);
    const ValueType type = g.plugType(p);
    if (!std::isfinite(value))
        refuse(fmt::format("{} is not a finite number", value),
               "give a number in the rig file's units (degrees for angles)");
    if (type == ValueType::Int && (value != std::floor(value) || std::abs(value) > 2e9))
        refuse(fmt::format("{} is not a whole number from -2e9 to 2e9 (an int attribute)", value),
               "give a whole number");
    if (type == ValueType::Bool && value != 0.0 && value != 1.0)
        refuse(fmt::format("{} is not 0 or 1 (a bool attribute)", value), "give 0 (false) or 1 (true)");
    if (type == ValueType::Enum &&
        (value != std::floor(value) || value < 0 || value >= static_cast<double>(s.enumNames.size()))) {
        std::string names;
        for (std::size_t i = 0; i < s.enumNames.size(); ++i)
            names += fmt::format("{}{} ({})", i ? ", " : "", i, s.enumNames[i]);
        refuse(fmt::format("{} is not one of its enum values", value),
               fmt::format("give the index of one of its names: {}", names));
    }
    // As a rig file's value is read: degrees to radians for an angle, other units as they are.
    const double scale = unitFactor(s.unit == Unit::Angle ? Unit::None : s.unit, s.unit);
    const double x = value * scale;
    if ((s.min && x < *s.min) || (s.max && x > *s.max)) {
        const std::string range = s.min && s.max ? fmt::format("from {:g} to {:g}", *s.min / scale, *s.max / scale)
                                  : s.min        ? fmt::format("of {:g} or more", *s.min / scale)
                                                 : fmt::format("of {:g} or less", *s.max / scale);
        refuse(s.min && x < *s.min ? fmt::format("{} is below its minimum {:g}", value, *s.min / scale)
                                   : fmt::format("{} is above its maximum {:g}", value, *s.max / scale),
               "give a value " + range);
    }
    return convertValue(x, ValueType::Double, type, 1.0);
}

// The span of the key times of the set-driven-key curves plug p drives (Maya's animCurveU*, whose input is the driver's
// value): a foot control's FootRoll keyed from -10 to 10. Nullopt where it drives none.
std::optional<std::pair<double, double>> drivenKeySpan(Graph& g, const Plug& p)
{
    const GraphModel::NodeTopology& node = g.model().topology(p.node);
    std::optional<std::pair<double, double>> span;
    for (const GraphModel::NodeTopology::Edge& e : node.outgoingFrom(p.attr)) {
        const Connection& connection = g.connections()[static_cast<std::size_t>(e.connection)];
        if (connection.source != p) continue;
        const NodeId curve = connection.destination.node;
        const GraphModel::NodeTopology& to = g.model().topology(curve);
        if (!to.type->name().starts_with("animCurveU") || to.spec(connection.destination.attr).name != "input")
            continue;
        const AttrId keyTime = to.type->findAttribute("keyTime");
        if (keyTime < 0) continue;
        const Value value = g.getValue(Plug{curve, keyTime});
        const auto* times = std::get_if<std::vector<double>>(&value);
        if (!times || times->empty()) continue;
        const auto [lo, hi] = std::minmax_element(times->begin(), times->end());
        span = span ? std::pair{std::min(span->first, *lo), std::max(span->second, *hi)} : std::pair{*lo, *hi};
    }
    return span;
}

// Parameter plug p as a parameter: its default, and its range (declared limits, else `ranges`' first match, else
// a default range around the default, a scale's from half to twice it, a number's that drives set-driven keys widened
// to their span).
RigParameter parameterOf(Graph& g, const Plug& p, const std::vector<GraphRigOptions::LearnRange>& ranges)
{
    const AttributeSpec& s = g.spec(p);
    RigParameter param;
    param.name = g.plugName(p);
    param.defaultValue = toDouble(g.getValue(p));
    param.angular = s.unit == Unit::Angle;
    param.scale = s.unit == Unit::None && s.name == "scale";
    const double half = param.angular              ? defaultAngleRangeDegrees * std::numbers::pi / 180.0
                        : s.unit == Unit::Distance ? defaultDistanceRangeCm
                                                   : defaultUnitlessRange;
    // A scale through 0 is singular: every world matrix below it has no inverse. A mirrored one (-1) keeps its sign.
    const bool scale = s.unit == Unit::None && s.name.starts_with("scale") && param.defaultValue != 0;
    const double shrink = param.defaultValue / defaultScaleFactor, grow = param.defaultValue * defaultScaleFactor;
    param.min = s.min ? *s.min : scale ? std::min(shrink, grow) : param.defaultValue - half;
    param.max = s.max ? *s.max : scale ? std::max(shrink, grow) : param.defaultValue + half;
    // A declared limit binds the solver; a default range, or one the spec gives, is only where learning
    // samples.
    param.limited = s.min.has_value() || s.max.has_value();
    const auto range =
        std::find_if(ranges.begin(), ranges.end(), [&](const auto& r) { return globMatches(r.glob, param.name); });
    if (!param.limited && range != ranges.end()) {
        const double unit = param.angular ? std::numbers::pi / 180.0 : 1.0;
        param.min = range->min * unit;
        param.max = range->max * unit;
    } else if (!param.limited && !param.angular && s.unit == Unit::None && !scale)
        // A custom attribute driving set-driven keys (a foot roll): learned over the keys, where a sampled operator
        // of its curve is exact, not extrapolated past +-1.
        if (const auto span = drivenKeySpan(g, p)) {
            param.min = std::min(param.min, span->first);
            param.max = std::max(param.max, span->second);
        }
    return param;
}

// The plugs a parameter glob (or plug name) matches, vectors as they are; none is an error.
std::vector<Plug> matchParameterGlob(const Graph& g, const MayaSceneInfo& info, const std::string& glob,
                                     const std::string& rigName, bool cutTimeCurves)
{
    std::vector<Plug> matched;
    if (!isGlobPattern(glob)) {
        try {
            matched.push_back(g.plug(glob));
        }
        catch (const Error& e) {
            throw RigSelectionError(fmt::format("{}: parameter '{}': {}", rigName, glob, e.what()), "parameter", glob,
                                    e.what());
        }
    } else
        forEachPlug(g, [&](const Plug& p) {
            if (globMatches(glob, g.plugName(p))) matched.push_back(p);
        });
    if (matched.empty()) {
        const std::string reason = fmt::format("matches no plug: {}", noPlugHint(g, info, glob, cutTimeCurves));
        throw RigSelectionError(fmt::format("{}: parameter glob '{}' {}", rigName, glob, reason), "parameter", glob,
                                reason);
    }
    return matched;
}

// The parameters the globs name, each plug once (in `seen`, with the glob that named it first), in glob order.
struct SelectedParameters {
    std::vector<RigParameter> parameters;
    std::vector<Plug> plugs;
    std::map<Plug, std::string> seen;
};

SelectedParameters selectParameters(Graph& g, const MayaSceneInfo& info, const GraphRigOptions& options,
                                    const std::string& rigName)
{
    if (options.parameterGlobs.empty() && !options.autoParameters)
        throw Error(
            fmt::format("{}: no parameters given; name them with plug globs such as 'L_arm_*.rotate?'", rigName));
    SelectedParameters selected;
    for (const std::string& glob : options.parameterGlobs) {
        std::size_t usable = 0;
        std::string refusedPlug, refusedWhy;  // the first plug matched that cannot be a parameter
        for (const Plug& whole : matchParameterGlob(g, info, glob, rigName, options.cutTimeCurves))
            for (const Plug& p : scalars(g, whole)) {
                const std::string why = whyNotParameter(g, info, p, options.cutTimeCurves);
                if (!why.empty()) {
                    if (refusedPlug.empty()) {
                        refusedPlug = g.plugName(p);
                        refusedWhy = why;
                    }
                    continue;
                }
                ++usable;
                if (!selected.seen.emplace(p, glob).second) continue;
                selected.parameters.push_back(parameterOf(g, p, options.ranges));
                selected.plugs.push_back(p);
            }
        if (usable == 0 && !isGlobPattern(glob))
            throw RigSelectionError(
                fmt::format("{}: parameter '{}' is {}; parameters are animator controls that nothing "
                            "drives",
                            rigName, refusedPlug, refusedWhy),
                "parameter", refusedPlug, fmt::format("it is {}", refusedWhy));
        if (usable == 0) {
            const std::string reason =
                fmt::format("matches no free keyable number ({} is {})", refusedPlug, refusedWhy);
            throw RigSelectionError(fmt::format("{}: parameter glob '{}' {}; parameters are animator controls that "
                                                "nothing drives",
                                                rigName, glob, reason),
                                    "parameter", glob, reason);
        }
    }
    return selected;
}

// Held plugs, all checked before any is set: each once, by the name the rig gives it; none a parameter (`seen`).
struct Held {
    Plug plug;
    Value stored;  // internal units
    double value;  // as given
};

std::map<std::string, Held> checkHeldPlugs(const Graph& g, const std::vector<HeldPlug>& plugs,
                                           const std::map<Plug, std::string>& seen, const std::string& rigName)
{
    std::map<std::string, Held> held;
    for (const HeldPlug& h : plugs) {
        const auto refuse = [&](const std::string& reason, const std::string& advice) {
            throw RigSelectionError(
                fmt::format("{}: held plug '{}': {}{}{}", rigName, h.plug, reason, advice.empty() ? "" : "; ", advice),
                "held plug", h.plug, reason);
        };
        if (isGlobPattern(h.plug)) refuse("it is a glob", "name each held plug in full");
        Plug p;
        try {
            p = g.plug(h.plug);
        }
        catch (const Error& e) {
            refuse(e.what(), "");
        }
        if (!g.spec(p).input)
            refuse("it is an output, computed by its node", "a held plug is an input that nothing drives");
        if (const Connection* c = g.incomingConnection(p))
            refuse(fmt::format("it is driven by {}", g.plugName(c->source)),
                   "a held plug is an input that nothing drives (hold what drives it instead)");
        if (g.spec(p).array && p.index < 0)
            refuse("it is an array attribute", fmt::format("hold one element, e.g. {}[0]", g.plugName(p)));
        if (g.plugType(p) == ValueType::Vector3)
            refuse("it is a vector3 value, not a number",
                   fmt::format("hold its components one by one ({}, ...)", g.plugName(scalars(g, p).front())));
        if (!isNumeric(g.plugType(p)))
            refuse(fmt::format("it is a {} value, not a number", valueTypeName(g.plugType(p))),
                   "a held plug is one number (a switch or a setting)");
        if (const auto parameter = seen.find(p); parameter != seen.end())
            refuse(fmt::format("it is also a parameter{}", parameter->second == g.plugName(p)
                                                               ? std::string()
                                                               : fmt::format(" (glob '{}')", parameter->second)),
                   "a plug is inverted or held, not both: take it out of one");
        const double value = h.value + 0.0;  // -0 is 0: one state, one fingerprint
        const Value stored = heldValue(g, p, value, refuse);
        const auto [at, added] = held.emplace(g.plugName(p), Held{p, stored, value});
        if (!added && at->second.value != value)
            refuse(fmt::format("it is held at {} and at {}", at->second.value, value), "give one value");
    }
    return held;
}

// The output joints the globs name (every joint without globs), in node order.
std::set<NodeId> chooseOutputs(const Graph& g, const std::vector<std::string>& globs, const std::string& rigName)
{
    std::vector<std::string> jointNames;
    std::vector<NodeId> joints;
    for (NodeId n = 0; n < g.nodeCount(); ++n)
        if (g.nodeType(n).name() == "joint") {
            joints.push_back(n);
            jointNames.push_back(g.nodeName(n));
        }
    std::set<NodeId> chosen;
    if (globs.empty()) chosen.insert(joints.begin(), joints.end());
    for (const std::string& glob : globs) {
        std::size_t found = 0;
        for (std::size_t j = 0; j < joints.size(); ++j)
            if (globMatches(glob, jointNames[j])) {
                chosen.insert(joints[j]);
                ++found;
            }
        if (found > 0) continue;
        const NodeId other = isGlobPattern(glob) ? -1 : g.findNode(glob);
        if (other >= 0) {
            const std::string reason = fmt::format("it is a {}, not a joint", g.nodeType(other).name());
            throw RigSelectionError(fmt::format("{}: output '{}' is a {}, not a joint; outputs are joints", rigName,
                                                glob, g.nodeType(other).name()),
                                    "output", glob, reason);
        }
        const std::string reason =
            fmt::format("matches no joint{}", isGlobPattern(glob) ? std::string() : didYouMean(glob, jointNames));
        throw RigSelectionError(fmt::format("{}: output glob '{}' {}", rigName, glob, reason), "output", glob, reason);
    }
    if (chosen.empty()) throw Error(fmt::format("{}: the rig has no joints to use as outputs", rigName));
    return chosen;
}

bool isDagNode(const GraphModel& m, NodeId n)
{
    const std::string& type = m.topology(n).type->name();
    return type == "joint" || type == "transform" || type == "mayaIkHandle";
}

// A Maya ikHandle: a transform whose world position is its solver's goal, read inside the node, not through a plug.
bool isIkGoal(const GraphModel& m, NodeId n) { return m.topology(n).type->name() == "mayaIkHandle"; }

// A constraint node (pointConstraint, poleVectorConstraint, ...): what reads its targets' channels is a target.
bool isConstraint(const GraphModel& m, NodeId n) { return m.topology(n).type->name().ends_with("Constraint"); }

// The helpers the globs name: transforms and joints that are not outputs, each glob matching at least one.
std::set<NodeId> chooseHelpers(const Graph& g, const std::vector<std::string>& globs, const std::set<NodeId>& outputs,
                               const std::string& rigName)
{
    std::vector<std::string> candidates;  // for a typo's suggestion
    for (NodeId n = 0; n < g.nodeCount(); ++n)
        if (isDagNode(g.model(), n) && !outputs.contains(n)) candidates.push_back(g.nodeName(n));
    std::set<NodeId> chosen;
    for (const std::string& glob : globs) {
        const auto refuse = [&](const std::string& reason, const std::string& advice) {
            throw RigSelectionError(fmt::format("{}: helper {}'{}' {}{}{}", rigName, isGlobPattern(glob) ? "glob " : "",
                                                glob, reason, advice.empty() ? "" : "; ", advice),
                                    "helper", glob, reason);
        };
        std::string outputMatched;  // the first output the glob matches
        std::size_t found = 0;
        for (NodeId n = 0; n < g.nodeCount(); ++n) {
            if (!isDagNode(g.model(), n) || !globMatches(glob, g.nodeName(n))) continue;
            if (!outputs.contains(n)) {
                chosen.insert(n);
                ++found;
            } else if (outputMatched.empty()) outputMatched = g.nodeName(n);
        }
        if (found > 0) continue;
        if (!outputMatched.empty())
            refuse(
                isGlobPattern(glob) ? fmt::format("matches only outputs, such as {}", outputMatched) : "is an output",
                "a helper is a transform or joint that is not an output");
        if (const NodeId other = isGlobPattern(glob) ? -1 : g.findNode(glob); other >= 0)
            refuse(fmt::format("is a {}, not a transform or joint", g.nodeType(other).name()),
                   "helpers are transforms or joints (nodes with a worldMatrix)");
        // A suggestion ends the line, as for an output.
        const std::string suggestion = isGlobPattern(glob) ? std::string() : didYouMean(glob, candidates);
        refuse("matches no transform or joint" + suggestion,
               suggestion.empty() ? "helpers are transforms or joints (nodes with a worldMatrix)" : "");
    }
    return chosen;
}

}  // namespace

int parentOutput(const Graph& g, NodeId node, const std::map<NodeId, int>& outputOfNode)
{
    std::set<NodeId> visited{node};
    while (true) {
        const auto& attributes = g.attributes(node);
        const auto it = std::find_if(attributes.begin(), attributes.end(),
                                     [](const AttributeSpec& a) { return a.name == "parentMatrix"; });
        if (it == attributes.end()) return -1;
        const Connection* c = g.incomingConnection({node, static_cast<AttrId>(it - attributes.begin()), -1, -1});
        if (!c || g.spec(c->source).name != "worldMatrix") return -1;
        node = c->source.node;
        if (!visited.insert(node).second) return -1;
        if (const auto out = outputOfNode.find(node); out != outputOfNode.end()) return out->second;
        const std::string& type = g.nodeType(node).name();
        if (type != "joint" && type != "transform") return -1;
    }
}

std::vector<NodeId> discoverHelpers(const GraphModel& model, const std::vector<NodeId>& outputs,
                                    const std::vector<Plug>& parameterPlugs)
{
    std::vector<NodeId> parameterNodes;
    for (const Plug& p : parameterPlugs) parameterNodes.push_back(p.node);
    const std::vector<char> moved = reachableNodes(model, parameterNodes, true);
    const std::vector<char> upstreamOfOutput = reachableNodes(model, outputs, false);
    std::vector<char> isOutput(static_cast<std::size_t>(model.nodeCount()), 0);  // a crowd has thousands
    for (NodeId n : outputs) isOutput[static_cast<std::size_t>(n)] = 1;
    std::map<std::string, NodeId> found;  // by name
    for (NodeId n = 0; n < model.nodeCount(); ++n) {
        if (isOutput[static_cast<std::size_t>(n)] || !isDagNode(model, n)) continue;
        // A transform no parameter moves is a helper only where a constraint or a solver reads it (a fixed aim
        // target), not as the parent of other transforms (a world control).
        const bool fixed = !moved[static_cast<std::size_t>(n)];
        const auto& topology = model.topology(n);
        if (isIkGoal(model, n) && !fixed && upstreamOfOutput[static_cast<std::size_t>(n)])
            found.emplace(topology.name, n);
        for (const GraphModel::NodeTopology::Edge& e : topology.outgoing) {
            // Its world matrix read anywhere, or its own channels read by a constraint or a solver (Maya's
            // constraints read a target's translate, pivots and parent matrix apart).
            const std::string& attribute = topology.spec(e.from).name;
            const bool world = attribute == "worldMatrix" || attribute == "worldInverseMatrix";
            if (!upstreamOfOutput[static_cast<std::size_t>(e.node)]) continue;
            if (world ? !(fixed && isDagNode(model, e.node)) : isConstraint(model, e.node))
                found.emplace(topology.name, n);
        }
    }
    std::vector<NodeId> helpers;
    for (const auto& [name, n] : found) helpers.push_back(n);
    return helpers;
}

namespace {

// The output joints: the globs' (every joint with neither globs nor auto) and auto's, in node order.
std::vector<NodeId> outputJoints(const Graph& g, const GraphRigOptions& options, const MayaSceneInfo& info,
                                 const std::string& rigName, AutoChoice& choice)
{
    std::set<NodeId> joints;
    if (!options.outputGlobs.empty() || !options.autoOutputs) joints = chooseOutputs(g, options.outputGlobs, rigName);
    if (options.autoOutputs) {
        const AutoOutputs found = autoOutputJoints(g, info);
        joints.insert(found.joints.begin(), found.joints.end());
        choice.skins = found.skins;
    }
    if (joints.empty()) throw Error(fmt::format("{}: the rig has no joints to use as outputs", rigName));
    return {joints.begin(), joints.end()};
}

// The helpers the globs name and, with autoHelpers, those the rig shows, in name order.
std::vector<NodeId> helperNodes(const Graph& g, const GraphRigOptions& options, const std::vector<NodeId>& joints,
                                const std::vector<Plug>& parameters, const std::string& rigName)
{
    std::map<std::string, NodeId> helpers;
    for (NodeId n : chooseHelpers(g, options.helperGlobs, {joints.begin(), joints.end()}, rigName))
        helpers.emplace(g.nodeName(n), n);
    if (options.autoHelpers)
        for (NodeId n : discoverHelpers(g.model(), joints, parameters)) helpers.emplace(g.nodeName(n), n);
    std::vector<NodeId> nodes;
    for (const auto& [name, n] : helpers) nodes.push_back(n);
    return nodes;
}

// Below this, a matrix entry moved by a probe is no movement (an output a channel does not reach is bitwise the same).
constexpr double probeTolerance = 1e-9;

// Moves each plug in `which` alone off its value by a tenth of its learning range each way (within it), from the
// pose the graph holds, and marks in `moves` those that move one of the `worlds` matrices; each is put back.
void probeFrom(Graph& g, const std::vector<Plug>& plugs, const std::vector<char>& which,
               const std::vector<Plug>& worlds, const std::vector<GraphRigOptions::LearnRange>& ranges,
               std::vector<char>& moves, std::uint64_t& evaluations)
{
    std::vector<Eigen::Matrix4d> read(worlds.size());
    const auto evaluate = [&] {
        g.evaluate(worlds);
        ++evaluations;
        for (std::size_t k = 0; k < worlds.size(); ++k) read[k] = std::get<Eigen::Matrix4d>(g.getValue(worlds[k]));
    };
    evaluate();
    const std::vector<Eigen::Matrix4d> rest = read;
    for (std::size_t i = 0; i < plugs.size(); ++i) {
        if (!which[i]) continue;
        const RigParameter param = parameterOf(g, plugs[i], ranges);
        const double value = toDouble(g.getValue(plugs[i])), step = 0.1 * (param.max - param.min);
        for (const double moved : {std::min(param.max, value + step), std::max(param.min, value - step)}) {
            if (moved == value || moves[i]) continue;
            g.setValue(plugs[i], moved);
            evaluate();
            for (std::size_t k = 0; k < read.size() && !moves[i]; ++k)
                moves[i] = (read[k] - rest[k]).cwiseAbs().maxCoeff() > probeTolerance;
        }
        g.setValue(plugs[i], value);
    }
}

// Whether each plug moves one of the joints' world matrices: probed alone at rest, then those that did not from two
// poses where every one that did is moved by a fiftieth of its range, one way then the other (a pole control moves
// a straight IK chain only once its goal comes closer and the chain bends). The plugs are put back and the graph's
// history reset.
std::vector<char> probeMoves(Graph& g, const std::vector<Plug>& plugs, const std::vector<NodeId>& joints,
                             const std::vector<GraphRigOptions::LearnRange>& ranges, std::uint64_t& evaluations)
{
    std::vector<Plug> worlds;
    for (NodeId j : joints) worlds.push_back(g.plug(g.nodeName(j) + ".worldMatrix"));
    std::vector<char> moves(plugs.size(), 0);
    probeFrom(g, plugs, std::vector<char>(plugs.size(), 1), worlds, ranges, moves, evaluations);
    const std::vector<char> movedAtRest = moves;
    std::vector<double> rest(plugs.size());
    for (std::size_t i = 0; i < plugs.size(); ++i) rest[i] = toDouble(g.getValue(plugs[i]));
    for (const double way : {1.0, -1.0}) {
        std::vector<char> still(plugs.size(), 0);
        for (std::size_t i = 0; i < plugs.size(); ++i) {
            still[i] = !moves[i];
            if (!movedAtRest[i]) continue;
            const RigParameter param = parameterOf(g, plugs[i], ranges);
            g.setValue(plugs[i], std::clamp(rest[i] + way * 0.02 * (param.max - param.min), param.min, param.max));
        }
        if (std::count(still.begin(), still.end(), 1) > 0 && std::count(movedAtRest.begin(), movedAtRest.end(), 1) > 0)
            probeFrom(g, plugs, still, worlds, ranges, moves, evaluations);
    }
    for (std::size_t i = 0; i < plugs.size(); ++i) g.setValue(plugs[i], rest[i]);
    g.resetState();
    return moves;
}

// --params auto: the channels of the scene's controls that move an output joint, after the globs' parameters (their
// time curves cut; put back on those that move nothing); the controls' settings held at the scene's values (after
// `held`, the user's, which auto leaves alone).
void addAutoParameters(Graph& g, const MayaSceneInfo& info, const std::vector<NodeId>& joints,
                       const GraphRigOptions& options, SelectedParameters& selected, std::vector<HeldPlug>& held,
                       AutoChoice& choice)
{
    const ControlChannels channels = controlChannels(g, info, joints);
    choice.controls = channels.controls;
    choice.passed = channels.passed;
    std::set<Plug> taken;  // the globs' parameters and the user's held plugs
    for (const auto& [p, glob] : selected.seen) taken.insert(p);
    for (const HeldPlug& h : held) taken.insert(g.plug(h.plug));
    for (const Plug& p : channels.settings)
        if (!taken.contains(p)) {
            held.push_back({g.plugName(p), userValue(g, p)});
            choice.settings.push_back(g.plugName(p));
        }
    std::vector<Plug> candidates;
    std::map<Plug, CutCurve> cuts;
    for (const Plug& p : channels.candidates) {
        if (taken.contains(p)) continue;
        candidates.push_back(p);
        if (g.incomingConnection(p)) cuts.emplace(p, cutTimeCurve(g, p));
    }
    const std::vector<char> moves = probeMoves(g, candidates, joints, options.ranges, choice.probeEvaluations);
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        const Plug& p = candidates[i];
        const auto cut = cuts.find(p);
        if (!moves[i]) {
            choice.passed.push_back({g.plugName(p), "moves no output"});
            if (cut != cuts.end()) g.connect(cut->second.source, cut->second.destination, !cut->second.rawUnits);
            continue;
        }
        selected.seen.emplace(p, "auto");
        selected.parameters.push_back(parameterOf(g, p, options.ranges));
        selected.plugs.push_back(p);
        if (cut != cuts.end()) choice.cutCurves.push_back(g.plugName(p));
    }
}

// The values a scene's time curves give the plugs they key, lowest and highest over the frames a clip of the scene
// plays (internal units); the graph back at its time after. Read before the curves are cut from the parameters.
std::map<Plug, std::pair<double, double>> keyedSpans(Graph& g, const MayaSceneInfo& info, const std::string& rigName)
{
    std::map<Plug, std::pair<double, double>> spans;
    std::vector<Plug> plugs;
    for (const auto& curve : info.timeCurves)
        if (!curve.plug.empty()) plugs.push_back(g.plug(curve.plug));
    if (plugs.empty()) return spans;
    const double time = g.time();
    for (const double frame : sceneClipFrames(g, info, rigName)) {
        g.setTime(frame);
        for (const Plug& p : plugs) {
            const double v = toDouble(g.getValue(p));
            const auto [it, fresh] = spans.try_emplace(p, v, v);
            if (!fresh) it->second = {std::min(it->second.first, v), std::max(it->second.second, v)};
        }
    }
    g.setTime(time);
    return spans;
}

// A parameter the scene's animation moves past its default range is learned over what the animation reaches (its
// clip asks those values), unless it has declared limits or the spec gives its range. A range on one side of 0 that is
// not an angle's (a scale's, mirrored or not) stays there: through 0 a scale is singular.
void widenToKeyedSpans(std::vector<RigParameter>& parameters, const std::vector<Plug>& plugs,
                       const std::map<Plug, std::pair<double, double>>& spans,
                       const std::vector<GraphRigOptions::LearnRange>& ranges)
{
    for (std::size_t i = 0; i < parameters.size(); ++i) {
        RigParameter& param = parameters[i];
        const auto span = spans.find(plugs[i]);
        if (param.limited || span == spans.end() ||
            std::any_of(ranges.begin(), ranges.end(), [&](const auto& r) { return globMatches(r.glob, param.name); }))
            continue;
        const bool positive = param.min > 0.0, negative = !param.angular && param.max < 0.0;
        if (!positive || span->second.first > 0.0) param.min = std::min(param.min, span->second.first);
        if (!negative || span->second.second < 0.0) param.max = std::max(param.max, span->second.second);
    }
}

}  // namespace

GraphRigOptions rigOptionsFor(const Approximation& approximation, std::vector<std::string> plugins)
{
    GraphRigOptions options;
    for (const auto& p : approximation.parameters) options.parameterGlobs.push_back(p.parameter.name);
    for (const auto& o : approximation.outputs)
        if (!o.helper || rigOutputName(o.name) == o.name)  // a blend's branch copy is the joint it copies
            (o.helper ? options.helperGlobs : options.outputGlobs).push_back(o.name);
    options.plugins = std::move(plugins);
    options.held = approximation.held;
    // Parameters are named in full: one a time curve keys was learned with its curve cut.
    options.cutTimeCurves = true;
    return options;
}

GraphRigFunction::GraphRigFunction(const std::filesystem::path& rigFile, const GraphRigOptions& options)
{
    auto registry = makeBuiltinRegistry();
    for (const auto& plugin : options.plugins) registry->loadPlugin(plugin);
    std::vector<std::filesystem::path> filesRead;
    MayaSceneInfo info;
    graph_ = loadRigFile(rigFile, registry, &filesRead, &info);
    std::uint64_t hash = fnv1a64({});
    for (const auto& file : filesRead) hash = fnv1a64(readBytes(file), hash);
    files_ = filesRead;
    Graph& g = *graph_;
    const std::string rigName = rigFile.string();
    if (options.autoParameters && !isMayaFile(rigFile))
        throw Error(
            fmt::format("{}: parameters 'auto' are the keyable channels of a Maya scene's controls (transforms with a "
                        "nurbsCurve shape), and this is a YAML rig; name its parameters with plug globs such as "
                        "'L_arm_*.rotate?'",
                        rigName));

    const auto spans =
        options.cutTimeCurves ? keyedSpans(g, info, rigName) : std::map<Plug, std::pair<double, double>>{};
    SelectedParameters selected = selectParameters(g, info, options, rigName);
    for (const Plug& p : selected.plugs)
        if (options.cutTimeCurves && g.incomingConnection(p)) {
            cutTimeCurve(g, p);
            auto_.cutCurves.push_back(g.plugName(p));
        }
    std::vector<HeldPlug> held = options.held;
    for (const auto& [name, h] : checkHeldPlugs(g, held, selected.seen, rigName)) g.setValue(h.plug, h.stored);
    const std::vector<NodeId> joints = outputJoints(g, options, info, rigName, auto_);
    if (options.autoParameters) addAutoParameters(g, info, joints, options, selected, held, auto_);
    if (selected.parameters.empty())
        throw Error(fmt::format(
            "{}: parameters 'auto' found no channel that moves an output joint ({} controls: transforms with a "
            "nurbsCurve shape or keyed by a time curve); name the parameters with plug globs",
            rigName, auto_.controls.size()));
    widenToKeyedSpans(selected.parameters, selected.plugs, spans, options.ranges);
    parameters_ = std::move(selected.parameters);
    parameterPlugs_ = std::move(selected.plugs);
    for (const RigParameter& param : parameters_) current_.push_back(param.defaultValue);
    for (const auto& [name, h] : checkHeldPlugs(g, held, selected.seen, rigName)) {
        g.setValue(h.plug, h.stored);
        held_.push_back({name, h.value});
        hash = fnv1a64(fmt::format("\nheld {}={}", name, h.value), hash);
    }
    fingerprint_ = fmt::format("{:016x}", hash);
    setOutputs(joints, helperNodes(g, options, joints, parameterPlugs_, rigName));
}

void GraphRigFunction::setOutputs(const std::vector<NodeId>& joints, const std::vector<NodeId>& helpers)
{
    const Graph& g = *graph_;
    std::map<NodeId, int> jointOutputOfNode;  // a joint's parent walk passes helpers by
    for (std::size_t k = 0; k < joints.size(); ++k) jointOutputOfNode[joints[k]] = static_cast<int>(k);
    // A helper joint's walk stops at a helper too: the joints of a control chain that drives the bound joints through
    // constraints (an IK leg's thigh, calf and foot) are learned relative to each other, as the bound joints are.
    std::map<NodeId, int> anyOutputOfNode = jointOutputOfNode;
    for (std::size_t k = 0; k < helpers.size(); ++k) anyOutputOfNode[helpers[k]] = static_cast<int>(joints.size() + k);
    for (std::size_t k = 0; k < joints.size() + helpers.size(); ++k) {
        const bool joint = k < joints.size();
        const NodeId n = joint ? joints[k] : helpers[k - joints.size()];
        outputNames_.push_back(g.nodeName(n));
        outputPlugs_.push_back(g.plug(g.nodeName(n) + ".worldMatrix"));
        helperFlags_.push_back(joint ? 0 : 1);
        const AttrId pivot = joint ? -1 : g.model().topology(n).type->findAttribute("rotatePivot");
        pivotPlugs_.push_back(
            pivot >= 0 && g.model().topology(n).spec(pivot).type == ValueType::Vector3 ? Plug{n, pivot} : Plug{});
        const bool helperJoint = !joint && g.nodeType(n).name() == "joint";
        outputParents_.push_back(joint         ? parentOutput(g, n, jointOutputOfNode)
                                 : helperJoint ? parentOutput(g, n, anyOutputOfNode)
                                               : -1);
    }
}

GraphRigFunction::GraphRigFunction(const GraphRigFunction& other)
    : graph_(other.graph_->instance()),
      parameters_(other.parameters_),
      parameterPlugs_(other.parameterPlugs_),
      current_(other.current_),
      outputNames_(other.outputNames_),
      outputPlugs_(other.outputPlugs_),
      outputParents_(other.outputParents_),
      helperFlags_(other.helperFlags_),
      pivotPlugs_(other.pivotPlugs_),
      outputWorlds_(other.outputWorlds_.size()),
      computesSeen_(other.computesSeen_.size(), notRead),
      fingerprint_(other.fingerprint_),
      files_(other.files_),
      held_(other.held_),
      auto_(other.auto_)
{
}

std::unique_ptr<RigFunction> GraphRigFunction::instance() const
{
    return std::unique_ptr<RigFunction>(new GraphRigFunction(*this));
}

void GraphRigFunction::resetState() { graph_->resetState(); }

void GraphRigFunction::evaluate(std::span<const double> values, std::vector<Eigen::Matrix4d>& worlds)
{
    if (values.size() != parameters_.size())
        throw internalError(
            fmt::format("GraphRigFunction::evaluate: {} values for {} parameters", values.size(), parameters_.size()));
    // Only changed plugs are set: setting one dirties its downstream, and most probes move one or two.
    for (std::size_t i = 0; i < values.size(); ++i)
        if (!(values[i] == current_[i])) {
            graph_->setValue(parameterPlugs_[i], values[i]);
            current_[i] = values[i];
        }
    ++evaluations_;
    graph_->evaluate(outputPlugs_);
    // Only joints computed since the last read are copied out again: a crowd's thousands of joints must
    // not all be read for each probe of one limb. Counting computes also sees evaluations made through
    // graph() behind this object's back.
    outputWorlds_.resize(outputPlugs_.size());
    computesSeen_.resize(outputPlugs_.size(), notRead);
    for (std::size_t k = 0; k < outputPlugs_.size(); ++k) {
        const std::uint64_t computes = graph_->computeCount(outputPlugs_[k].node);
        if (computes == computesSeen_[k]) continue;
        outputWorlds_[k] = std::get<Eigen::Matrix4d>(graph_->getValue(outputPlugs_[k]));
        if (pivotPlugs_[k].node >= 0) {
            const Eigen::Vector3d pivot = std::get<Eigen::Vector3d>(graph_->getValue(pivotPlugs_[k]));
            outputWorlds_[k].block<3, 1>(0, 3) += outputWorlds_[k].block<3, 3>(0, 0) * pivot;
        }
        computesSeen_[k] = computes;
    }
    worlds = outputWorlds_;
}

}  // namespace rig
