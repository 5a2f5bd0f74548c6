#include "nodes/clips/maya_clip.h"

#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <set>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/rig_file.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

// As an assimp take's (docs/clips.md): a clip past this is refused before it is evaluated.
constexpr double maxJointFrames = 4e6;

using Span = std::optional<std::pair<double, double>>;

Span joined(const Span& a, const Span& b)
{
    if (!a || !b) return a ? a : b;
    return std::pair{std::min(a->first, b->first), std::max(a->second, b->second)};
}

// The span of the scene's time curves' keys, or none.
Span keySpan(Graph& graph, const MayaSceneInfo& info)
{
    Span span;
    for (const auto& curve : info.timeCurves) {
        const NodeId n = graph.findNode(curve.curve);
        const AttrId keyTime = n >= 0 ? graph.nodeType(n).findAttribute("keyTime") : -1;
        if (keyTime < 0) continue;
        const auto times = std::get<std::vector<double>>(graph.getValue(Plug{n, keyTime, -1, -1}));
        if (!times.empty()) span = joined(span, std::pair{times.front(), times.back()});
    }
    return span;
}

// The frames a scene clip plays: the whole frames of its playback range (without one, of the span its time curves'
// keys cover), reaching `asked` where given; without any of these, its saved time.
std::vector<double> sceneFrames(Graph& graph, const MayaSceneInfo& info, const std::string& file, const Span& asked)
{
    const Span range = joined(info.playbackRange ? info.playbackRange : keySpan(graph, info), asked);
    if (range && std::floor(range->second) - std::ceil(range->first) >= maxJointFrames)
        throw Error(
            fmt::format("{}: frames {} to {} are more than the {} joint-frames a clip may have; give the scene "
                        "a shorter playback range",
                        file, range->first, range->second, maxJointFrames));
    std::vector<double> frames;
    if (range)
        for (double f = std::ceil(range->first); f <= std::floor(range->second); ++f) frames.push_back(f);
    if (frames.empty()) frames.push_back(info.savedTime);
    return frames;
}

}  // namespace

std::vector<double> sceneClipFrames(Graph& graph, const MayaSceneInfo& info, const std::string& file)
{
    return sceneFrames(graph, info, file, std::nullopt);
}

namespace {

bool isJoint(const Graph& graph, NodeId node) { return graph.nodeType(node).name() == "joint"; }

// Each joint's nearest joint above it in the DAG (an index into `joints`), -1 for none: a DAG parent drives a node's
// parentMatrix here (docs/maya.md).
std::vector<int> jointParents(const Graph& graph, const std::vector<NodeId>& joints)
{
    std::map<NodeId, int> index;
    for (std::size_t j = 0; j < joints.size(); ++j) index[joints[j]] = static_cast<int>(j);
    std::vector<int> parents;
    for (const NodeId joint : joints) {
        int parent = -1;
        NodeId n = joint;
        for (int depth = 0; parent < 0 && depth < graph.nodeCount(); ++depth) {
            const AttrId pm = graph.nodeType(n).findAttribute("parentMatrix");
            const Connection* in = pm >= 0 ? graph.incomingConnection(Plug{n, pm, -1, -1}) : nullptr;
            if (!in) break;
            n = in->source.node;
            if (const auto it = index.find(n); it != index.end()) parent = it->second;
        }
        parents.push_back(parent);
    }
    return parents;
}

// The plug that feeds each time curve's driven plug (the curve, or the unitConversion after it), or none.
std::vector<std::optional<Plug>> curveSources(const Graph& graph, const MayaSceneInfo& info)
{
    std::vector<std::optional<Plug>> sources;
    for (const auto& curve : info.timeCurves) {
        std::optional<Plug> source;
        if (!curve.plug.empty())
            if (const Connection* in = graph.incomingConnection(graph.plug(curve.plug));
                in && graph.plugType(in->source) == ValueType::Double)
                source = in->source;
        sources.push_back(source);
    }
    return sources;
}

}  // namespace

TargetClip readMayaClip(const std::filesystem::path& file, const TargetMap& map,
                        std::optional<std::pair<double, double>> frames)
{
    auto scene = std::make_shared<ClipScene>();
    const auto graph = loadRigFile(file, makeBuiltinRegistry(), nullptr, &scene->info);
    const MayaSceneInfo& info = scene->info;
    TargetClip raw;
    raw.file = file.string();
    raw.frameNumbers = sceneFrames(*graph, info, raw.file, frames);
    raw.frameTime = 1.0 / info.framesPerSecond;
    std::vector<NodeId> joints;
    std::vector<Plug> plugs;
    for (NodeId n = 0; n < graph->nodeCount(); ++n)
        if (isJoint(*graph, n)) {
            joints.push_back(n);
            raw.joints.push_back(graph->nodeName(n));
            plugs.push_back(graph->plug(graph->nodeName(n) + ".worldMatrix"));
        }
    if (joints.empty())
        throw Error(
            fmt::format("{}: the scene has no joint that this reader evaluates; a Maya scene clip is its "
                        "joints over its playback range",
                        raw.file));
    if (static_cast<double>(joints.size()) * static_cast<double>(raw.frameNumbers.size()) > maxJointFrames)
        throw Error(
            fmt::format("{}: {} frames of {} joints are more than the {} joint-frames a clip may have; give "
                        "the scene a shorter playback range",
                        raw.file, raw.frameNumbers.size(), joints.size(), maxJointFrames));
    raw.parents = jointParents(*graph, joints);
    const auto sources = curveSources(*graph, info);
    scene->curveValues.resize(sources.size());
    for (const double frame : raw.frameNumbers) {
        graph->setTime(frame);
        graph->evaluate(plugs);
        auto& worlds = raw.worlds.emplace_back();
        for (const Plug& p : plugs) worlds.push_back(std::get<Eigen::Matrix4d>(graph->getValue(p)));
        for (std::size_t c = 0; c < sources.size(); ++c)
            if (sources[c]) scene->curveValues[c].push_back(std::get<double>(graph->getValue(*sources[c])));
    }
    raw.source = fmt::format("Maya scene: its {} joints over frames {} to {} at {} fps ({}), in cm ({} in the file)",
                             joints.size(), raw.frameNumbers.front(), raw.frameNumbers.back(), info.framesPerSecond,
                             info.timeUnit, info.linearUnit);
    raw.scene = std::move(scene);
    return applyTargetMap(raw, map);
}

std::string withoutNamespaces(std::string_view name)
{
    std::string out;
    std::size_t start = 0;
    while (start <= name.size()) {
        const std::size_t bar = std::min(name.find('|', start), name.size());
        const std::string_view part = name.substr(start, bar - start);
        // The attribute of a plug holds no ':'; the namespace ends at the component's last one.
        const std::size_t dot = part.find('.');
        const std::size_t colon = part.substr(0, dot).rfind(':');
        out += colon == std::string_view::npos ? part : part.substr(colon + 1);
        if (bar < name.size()) out += '|';
        start = bar + 1;
    }
    return out;
}

int matchNamespaces(TargetClip& clip, std::span<const std::string> rigJoints)
{
    const std::set<std::string> exact(rigJoints.begin(), rigJoints.end());
    std::map<std::string, std::vector<std::string>> bare;
    for (const auto& joint : rigJoints) bare[withoutNamespaces(joint)].push_back(joint);
    // Each clip joint's rig joint by its bare name, where one rig joint has it and no other clip joint takes it.
    std::vector<std::string> to(clip.joints.size());
    std::map<std::string, int> claims;
    for (const auto& joint : clip.joints) ++claims[joint];
    for (std::size_t j = 0; j < clip.joints.size(); ++j) {
        if (exact.count(clip.joints[j])) continue;
        const auto it = bare.find(withoutNamespaces(clip.joints[j]));
        if (it == bare.end() || it->second.size() != 1) continue;
        to[j] = it->second.front();
        ++claims[to[j]];
    }
    int renamed = 0;
    for (std::size_t j = 0; j < clip.joints.size(); ++j)
        if (!to[j].empty() && claims[to[j]] == 1) {
            clip.joints[j] = to[j];
            ++renamed;
        }
    return renamed;
}

}  // namespace rig
