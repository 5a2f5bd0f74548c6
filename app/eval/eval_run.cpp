#include "app/eval/eval_run.h"

#include <algorithm>
#include <cctype>
#include <set>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "app/common/value_output.h"
#include "core/error.h"
#include "core/huge_pages.h"
#include "graph/plug_glob.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "nodes/curves/anim_file.h"

namespace rig::app {
namespace {

// Runs an evaluation, naming the rig and the frame in front of an error a node met (a malformed clip,
// a NaN driving an enum): the message alone does not say when it happened.
template <class F>
void evaluating(const std::string& rigName, double frame, F&& f)
{
    try {
        f();
    }
    catch (const Error& e) {
        throw Error(fmt::format("{}: evaluating frame {}: {}", rigName, frame, e.what()));
    }
}

// The unit of the plug a curve may drive: what its output is.
Unit animUnit(const AnimFileCurve& curve)
{
    return curve.output == AnimQuantity::angular  ? Unit::Angle
           : curve.output == AnimQuantity::linear ? Unit::Distance
                                                  : Unit::None;
}

// The plug `curve` drives, refused (with the curve's anim line) when the rig lacks it or it is not a free
// number input of the curve's kind.
Plug animatedPlug(const Graph& graph, const AnimFileCurve& curve)
{
    const std::string where = formatMark(curve.mark);
    const std::string name = curve.plugName();
    if (curve.input != AnimQuantity::time)
        throw Error(
            fmt::format("{}: the curve of {} is driven by a {} value (a set-driven key), and a .anim file "
                        "does not say by what; play it with an {} node in a rig file (animFile, animPlug)",
                        where, name, animQuantityName(curve.input), curve.nodeTypeName()));
    Plug plug;
    try {
        plug = graph.plug(name);
    }
    catch (const Error& e) {
        throw Error(
            fmt::format("{}: the curve drives {}, which the rig does not have ({}); check the file's node "
                        "and attribute names against the rig",
                        where, name, e.what()));
    }
    const AttributeSpec& spec = graph.spec(plug);
    if (!spec.input || graph.plugType(plug) != ValueType::Double)
        throw Error(fmt::format("{}: the curve drives {}, {}; a curve drives a number input", where, name,
                                spec.input ? fmt::format("a plug of type {}", valueTypeName(graph.plugType(plug)))
                                           : "an output, computed by its node"));
    if (const Connection* c = graph.incomingConnection(plug))
        throw Error(fmt::format("{}: the curve drives {}, which {} already drives; a plug has one source", where, name,
                                graph.plugName(c->source)));
    if (spec.unit != animUnit(curve))
        throw Error(
            fmt::format("{}: the curve of {} is {} but the plug is {}; export the curve from a plug of the "
                        "same kind",
                        where, name, animQuantityName(curve.output),
                        spec.unit == Unit::Angle      ? "an angle"
                        : spec.unit == Unit::Distance ? "a distance"
                                                      : "unitless"));
    return plug;
}

// A new animCurve node playing `curve`, named after its plug, connected to `plug`.
void connectCurve(Graph& graph, const AnimFileCurve& curve, const Plug& plug)
{
    std::string nodeName = "anim_" + curve.node + "_" + curve.leaf;
    std::replace_if(
        nodeName.begin(), nodeName.end(), [](char c) { return !std::isalnum(static_cast<unsigned char>(c)); }, '_');
    for (int n = 2; graph.findNode(nodeName) >= 0; ++n) nodeName = fmt::format("{}_{}", nodeName, n);
    const NodeId node = graph.addNode(curve.nodeTypeName(), nodeName);
    const NodeType& type = graph.nodeType(node);
    const auto set = [&](const char* attribute, Value value) {
        graph.setValue(Plug{node, type.findAttribute(attribute)}, std::move(value));
    };
    std::vector<double> times, values, ins, outs;
    const double scale = unitFactor(Unit::None, animUnit(curve));  // degrees to radians for an angle
    for (const AnimKey& k : curve.keys) {
        times.push_back(k.x);
        values.push_back(k.y * scale);
        ins.push_back(static_cast<double>(k.inTangent));
        outs.push_back(static_cast<double>(k.outTangent));
    }
    set("keyTime", times);
    set("keyValue", values);
    set("keyInTangent", ins);
    set("keyOutTangent", outs);
    set("preInfinity", static_cast<int>(curve.pre));
    set("postInfinity", static_cast<int>(curve.post));
    graph.connect(Plug{node, type.findAttribute("output")}, plug);
}

}  // namespace

std::shared_ptr<NodeRegistry> nodeRegistry(const std::vector<std::string>& plugins)
{
    auto registry = makeBuiltinRegistry();
    for (const auto& plugin : plugins) registry->loadPlugin(plugin);
    return registry;
}

std::shared_ptr<NodeRegistry> typesRegistry(const std::vector<std::string>& plugins)
{
    auto registry = nodeRegistry(plugins);
    for (const auto& plugin : bundledPlugins) registry->loadPlugin(plugin);
    return registry;
}

Plug settablePlug(const Graph& graph, std::string_view name)
{
    const Plug plug = graph.plug(name);
    if (!graph.spec(plug).input)
        throw Error(fmt::format("cannot set {}: it is an output, computed by its node", graph.plugName(plug)));
    return plug;
}

void setPlug(Graph& graph, const Plug& plug, std::string_view name, const YAML::Node& value)
{
    graph.setValue(plug, parseYamlValue(value, graph, plug, fmt::format("--set {}", name)));
}

void applyAnimFile(Graph& graph, const std::string& file)
{
    // Each curve is checked against the rig as it is read, so that a wrong one stops the reading there; the
    // rig is changed only once the whole file is good.
    std::vector<Plug> plugs;
    const AnimFile anim =
        readAnimFile(file, [&](const AnimFileCurve& curve) { plugs.push_back(animatedPlug(graph, curve)); });
    for (std::size_t i = 0; i < anim.curves.size(); ++i) connectCurve(graph, anim.curves[i], plugs[i]);
}

std::vector<Plug> selectPlugs(Graph& graph, const std::string& rigName, const std::vector<std::string>& patterns,
                              std::optional<double> firstFrame)
{
    if (firstFrame) graph.setTime(*firstFrame);
    evaluating(rigName, graph.time(), [&] { graph.evaluateAll(); });
    std::vector<Plug> plugs;
    if (patterns.empty()) {
        forEachPlug(graph, [&](const Plug& p) {
            if (!graph.spec(p).input && p.child < 0) plugs.push_back(p);
        });
    }
    // A plug named by several patterns is listed once (JSON objects must not repeat a key).
    std::set<Plug> seen;
    for (const auto& pattern : patterns)
        for (const Plug& p : matchPlugs(graph, pattern)) {
            // Said here, before any frame is evaluated, with the way to take every element.
            if (graph.spec(p).array && p.index < 0)
                throw Error(
                    fmt::format("{} is an array attribute: name an element, e.g. {}[0], or take them all "
                                "with {}[*]",
                                graph.plugName(p), graph.plugName(p), graph.plugName(p)));
            if (seen.insert(p).second) plugs.push_back(p);
        }
    return plugs;
}

void settleLargeGraph(const Graph& graph)
{
    if (graph.nodeCount() >= hugePageNodes) collapseIntoHugePages();
}

std::vector<Value> evaluateFrame(Graph& graph, const std::string& rigName, double frame, bool setTime,
                                 std::span<const Plug> plugs, bool check)
{
    std::vector<Value> values;
    evaluateFrame(graph, rigName, frame, setTime, plugs, values, check);
    return values;
}

void evaluateFrame(Graph& graph, const std::string& rigName, double frame, bool setTime, std::span<const Plug> plugs,
                   std::vector<Value>& values, bool check)
{
    if (setTime) graph.setTime(frame);
    if (check) {
        evaluating(rigName, frame, [&] { graph.evaluate(plugs); });
        const auto mismatches = graph.checkEvaluation();
        if (!mismatches.empty()) {
            std::string list;
            for (const auto& m : mismatches) list += (list.empty() ? "" : ", ") + m;
            throw internalError(
                fmt::format("checked mode, frame {}: cached values differ from a full recompute for {} "
                            "(a node type's affects table misses an entry)",
                            frame, list));
        }
    }
    // The values after the check's recompute where there is one (stateful nodes are not compared).
    evaluating(rigName, frame, [&] { graph.evaluate(plugs, values); });
}

void checkOutputSize(double bytes, std::size_t frames, std::size_t plugs)
{
    if (bytes > static_cast<double>(maxOutputBytes))
        throw Error(
            fmt::format("the output would be about {} MB ({} frames of {} plugs), more than the limit of {} "
                        "MB; ask for fewer frames (--frames) or plugs (--get)",
                        static_cast<long long>(bytes / 1e6), frames, plugs, maxOutputBytes >> 20));
}

double jsonOutputEstimate(const Graph& graph, std::span<const Plug> plugs, double frame,
                          const std::vector<Value>& values, std::size_t frames)
{
    std::vector<std::pair<std::string, Json>> named;
    for (std::size_t i = 0; i < plugs.size(); ++i)
        named.emplace_back(graph.plugName(plugs[i]), valueToJson(graph, plugs[i], values[i]));
    // Each frame comes after "[\n" or ",\n", as graph-eval writes it.
    return static_cast<double>(frameJson(frame, named).size() + 2) * static_cast<double>(frames);
}

}  // namespace rig::app
