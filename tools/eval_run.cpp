#include "tools/eval_run.h"

#include <set>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "core/error.h"
#include "graph/plug_glob.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"

namespace rig::cli {
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

}  // namespace

std::shared_ptr<NodeRegistry> nodeRegistry(const std::vector<std::string>& plugins)
{
    auto registry = makeBuiltinRegistry();
    for (const auto& plugin : plugins) registry->loadPlugin(plugin);
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

std::vector<Plug> selectPlugs(Graph& graph, const std::string& rigName, const std::vector<std::string>& patterns,
                              std::optional<double> firstFrame)
{
    if (firstFrame) graph.setTime(*firstFrame);
    evaluating(rigName, graph.time(), [&] { graph.evaluateAll(); });
    std::vector<Plug> plugs;
    if (patterns.empty()) {
        for (const Plug& p : allPlugs(graph))
            if (!graph.spec(p).input && p.child < 0) plugs.push_back(p);
    }
    // A plug named by several patterns is listed once (JSON objects must not repeat a key).
    std::set<Plug> seen;
    for (const auto& pattern : patterns)
        for (const Plug& p : matchPlugs(graph, pattern))
            if (seen.insert(p).second) plugs.push_back(p);
    return plugs;
}

std::vector<Value> evaluateFrame(Graph& graph, const std::string& rigName, double frame, bool setTime,
                                 std::span<const Plug> plugs, bool check)
{
    if (setTime) graph.setTime(frame);
    evaluating(rigName, frame, [&] { graph.evaluate(plugs); });
    if (check) {
        const auto mismatches = graph.checkEvaluation();
        if (!mismatches.empty()) {
            std::string list;
            for (const auto& m : mismatches) list += (list.empty() ? "" : ", ") + m;
            throw internalError(fmt::format("checked mode, frame {}: cached values differ from a full recompute for {} "
                                            "(a node type's affects table misses an entry)",
                                            frame, list));
        }
    }
    std::vector<Value> values;
    evaluating(rigName, frame, [&] {
        for (const Plug& p : plugs) values.push_back(graph.getValue(p));
    });
    return values;
}

}  // namespace rig::cli
