#include "graph/maya/maya_info.h"

#include <algorithm>
#include <map>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/maya/maya_values.h"

namespace rig {
namespace maya {

void readSkins(const Scene& scene, const std::function<std::string(int)>& graphName, MayaSceneInfo& info)
{
    std::map<int, MayaSceneInfo::Skin> skins;
    for (const Connection& c : scene.connections) {
        const auto [dstName, dstAttr] = splitPlug(c.destination);
        const AttrPath p = splitAttr(dstAttr);
        if ((p.name != "ma" && p.name != "matrix") || !p.valid || p.first < 0) continue;
        int skin = -1, joint = -1;
        try {
            skin = scene.find(dstName);
            joint = scene.find(splitPlug(c.source).first);
        }
        catch (const Error&) {
            continue;  // an ambiguous name: reported where the connection is made
        }
        if (skin < 0 || scene.nodes[static_cast<std::size_t>(skin)].type != "skinCluster") continue;
        auto& s = skins[skin];
        if (s.influences.size() <= static_cast<std::size_t>(p.first))
            s.influences.resize(static_cast<std::size_t>(p.first) + 1);
        if (joint >= 0) s.influences[static_cast<std::size_t>(p.first)] = graphName(joint);
    }
    for (auto& [skin, s] : skins) {
        s.name = scene.nodes[static_cast<std::size_t>(skin)].name;
        s.bindPreMatrix.assign(s.influences.size(), Eigen::Matrix4d::Zero());
        for (const SetAttr& set : scene.nodes[static_cast<std::size_t>(skin)].sets) {
            const AttrPath p = splitAttr(set.plug);
            if ((p.name != "pm" && p.name != "bindPreMatrix") || p.first < 0 || set.type != "matrix") continue;
            if (static_cast<std::size_t>(p.first) >= s.bindPreMatrix.size()) continue;
            ValueReader r(set.values, scene.units[static_cast<std::size_t>(set.where.file)]);
            try {
                s.bindPreMatrix[static_cast<std::size_t>(p.first)] =
                    std::get<Eigen::Matrix4d>(r.read(ValueType::Matrix4, Unit::None));
            }
            catch (const Error&) {
                // a malformed bind matrix only loses this datum
            }
        }
        info.skins.push_back(std::move(s));
    }
}

void readControls(const Scene& scene, const std::function<std::string(int)>& graphName, MayaSceneInfo& info)
{
    std::vector<char> isControl(scene.nodes.size(), 0);
    for (const Node& n : scene.nodes) {
        if (n.type != "nurbsCurve" || n.parent < 0) continue;
        // A deformed curve's original shape (".io" yes) is hidden: it makes no control of its transform.
        const bool intermediate = std::any_of(n.sets.begin(), n.sets.end(), [](const SetAttr& set) {
            return (set.plug == "io" || set.plug == "intermediateObject") && set.values.size() == 1 &&
                   (set.values.front().text == "yes" || set.values.front().text == "on" ||
                    set.values.front().text == "true" || set.values.front().text == "1");
        });
        if (!intermediate) isControl[static_cast<std::size_t>(n.parent)] = 1;
    }
    for (std::size_t i = 0; i < scene.nodes.size(); ++i)
        if (isControl[i])
            if (std::string name = graphName(static_cast<int>(i)); !name.empty())
                info.controls.push_back(std::move(name));
}

}  // namespace maya

std::string mayaStatsText(const MayaSceneInfo& info)
{
    auto list = [](const std::map<std::string, int>& counts) {
        std::vector<std::pair<int, std::string>> sorted;
        for (const auto& [name, n] : counts) sorted.emplace_back(-n, name);
        std::sort(sorted.begin(), sorted.end());
        std::string text;
        for (const auto& [n, name] : sorted) text += fmt::format("{}{} {}", text.empty() ? "" : ", ", name, -n);
        return text.empty() ? std::string("none") : text;
    };
    return fmt::format(
        "maya: {} graph nodes, {} connections; saved time {}, {} fps{}\n"
        "maya: nodes not evaluated (they move no joint), by type: {}\n"
        "maya: statements skipped: {}\n"
        "maya: attributes not evaluated: {}\n",
        info.nodes, info.connections, info.savedTime, info.framesPerSecond,
        info.playbackRange ? fmt::format(", playback {}:{}", info.playbackRange->first, info.playbackRange->second)
                           : std::string(),
        list(info.notEvaluatedTypes), list(info.skippedStatements), list(info.notEvaluatedAttributes));
}

}  // namespace rig
