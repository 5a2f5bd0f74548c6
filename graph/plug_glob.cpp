#include "graph/plug_glob.h"

#include <fnmatch.h>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {

std::vector<Plug> allPlugs(const Graph& graph)
{
    std::vector<Plug> plugs;
    for (NodeId n = 0; n < graph.nodeCount(); ++n) {
        const auto& specs = graph.attributes(n);
        for (AttrId a = 0; a < static_cast<AttrId>(specs.size()); ++a) {
            const AttributeSpec& spec = specs[static_cast<std::size_t>(a)];
            auto add = [&](int index) {
                plugs.push_back({n, a, index, -1});
                if (spec.type == ValueType::Vector3)
                    for (int c = 0; c < 3; ++c) plugs.push_back({n, a, index, c});
            };
            if (!spec.array) add(-1);
            else
                for (int i : graph.elementIndices(n, a)) add(i);
        }
    }
    return plugs;
}

bool isGlobPattern(std::string_view pattern)
{
    if (pattern.find_first_of("*?") != std::string_view::npos) return true;
    // '[' starts a set unless it is an array index such as matrixIn[3].
    for (auto open = pattern.find('['); open != std::string_view::npos; open = pattern.find('[', open + 1)) {
        const auto close = pattern.find(']', open);
        if (close == std::string_view::npos) return false;
        const auto inside = pattern.substr(open + 1, close - open - 1);
        if (inside.empty() || inside.find_first_not_of("0123456789") != std::string_view::npos) return true;
    }
    return false;
}

std::vector<Plug> matchPlugs(const Graph& graph, std::string_view pattern)
{
    if (!isGlobPattern(pattern)) return {graph.plug(pattern)};
    const std::string glob(pattern);
    std::vector<Plug> matches;
    for (const Plug& p : allPlugs(graph))
        if (fnmatch(glob.c_str(), graph.plugName(p).c_str(), 0) == 0) matches.push_back(p);
    if (matches.empty())
        throw Error(
            fmt::format("no plug matches '{}'; patterns look like '*.worldMatrix' or 'L_arm_*.rotate?'", pattern));
    return matches;
}

}  // namespace rig
