#pragma once
// graph-eval's loading, setting, plug selection and evaluation, shared by the command line
// (tools/graph_eval.cpp) and the Python module's Graph (python/riginv.cpp): the same values and the same
// one-line errors (docs/graph-eval.md, docs/python.md).

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "graph/graph.h"

namespace YAML {
class Node;
}

namespace rig::app {

// The built-in node types and those of `plugins` (graph-eval --plugin), loaded before any rig is read.
std::shared_ptr<NodeRegistry> nodeRegistry(const std::vector<std::string>& plugins);
// The plugins built and installed with the project (found without a path: NodeRegistry::loadPlugin).
inline const std::vector<std::string> bundledPlugins{"rigInversion"};
// Every node type graph-eval --types lists: the built-in ones, the bundled plugins' and those of `plugins`.
std::shared_ptr<NodeRegistry> typesRegistry(const std::vector<std::string>& plugins);

// graph-eval --set NAME=VALUE: the plug NAME, which must be an input (rig::Error otherwise) ...
Plug settablePlug(const Graph& graph, std::string_view name);
// ... set to `value` written as in a rig file (degrees for angles), checked against its type and limits;
// `name` as the user wrote it, for messages.
void setPlug(Graph& graph, const Plug& plug, std::string_view name, const YAML::Node& value);

// graph-eval --anim FILE: every curve of the Maya .anim file drives its plug (NODE.LEAF, as the file's anim
// lines name it) through a new animCurve node of the curve's type, as Maya's import connects them; the nodes
// are named anim_NODE_LEAF. rig::Error "FILE:LINE:COL: ..." (the curve's anim line) for a plug the rig lacks,
// one that is not a free number input, or a curve whose kind does not fit it.
void applyAnimFile(Graph& graph, const std::string& file);

// graph-eval --get PATTERN...: the plugs the patterns match, each once, in their order; no pattern: every
// output plug (whole values). The graph is evaluated first (at `firstFrame` when given), since array
// outputs have elements only once computed. `rigName` names the rig in errors.
std::vector<Plug> selectPlugs(Graph& graph, const std::string& rigName, const std::vector<std::string>& patterns,
                              std::optional<double> firstFrame);

// A player's step between selecting its plugs (the graph built, its nodes' state made by selectPlugs' evaluation) and
// its frames: a graph of hugePageNodes nodes or more has the process's memory collapsed into huge pages
// (core/huge_pages.h), once. graph-eval and rig-bench's crowd row call it; the Python module does not, since it would
// collapse the whole interpreter's memory, the user's arrays with it.
void settleLargeGraph(const Graph& graph);
// A crowd of 36 bipeds: at 16 a frame gained nothing from huge pages here (its memory is within what 4 KB pages map),
// and collapsing fills the unused rest of each 2 MB range.
inline constexpr int hugePageNodes = 10'000;

// The plugs' values at `frame`, the scene time set to it when `setTime`. `check`: graph-eval --check (a
// value differing from a full recompute is an internal error). An error a node meets names the rig and
// the frame.
std::vector<Value> evaluateFrame(Graph& graph, const std::string& rigName, double frame, bool setTime,
                                 std::span<const Plug> plugs, bool check = false);
// The same into `values` (a player's loop keeps it: a frame then allocates nothing for its values).
void evaluateFrame(Graph& graph, const std::string& rigName, double frame, bool setTime, std::span<const Plug> plugs,
                   std::vector<Value>& values, bool check = false);

// graph-eval's output and the Python module's arrays are built in memory: past this size the request is
// refused rather than exhausting the memory. A CSV of every joint matrix of the biped over 10000 frames is
// about 300 MB.
inline constexpr std::size_t maxOutputBytes = std::size_t{1} << 30;

// rig::Error when `bytes` (an output's size, or its estimate) is over maxOutputBytes, naming the request.
void checkOutputSize(double bytes, std::size_t frames, std::size_t plugs);

// The size of graph-eval's JSON output for `frames` frames like this first one (`values` of `plugs` at
// `frame`): what Graph.evaluate checks, so that it refuses what graph-eval refuses.
double jsonOutputEstimate(const Graph& graph, std::span<const Plug> plugs, double frame,
                          const std::vector<Value>& values, std::size_t frames);

}  // namespace rig::app
