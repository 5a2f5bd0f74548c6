#pragma once
// Plugs by shell-style glob over their names ('*.worldMatrix', 'L_arm_*.rotate?', 'spine[12].rotateX').

#include <string>
#include <string_view>
#include <vector>

#include "graph/graph.h"

namespace rig {

// Calls f(plug) for every plug of the graph by name: attributes, vector3 components, existing array elements, in
// node order. Without a list of them: a crowd of 256 bipeds has 1.7 million, up to 50 MB in a list that grows
// (allPlugs).
template <class F>
void forEachPlug(const Graph& graph, F&& f)
{
    for (NodeId n = 0; n < graph.nodeCount(); ++n) {
        const auto& specs = graph.attributes(n);
        for (AttrId a = 0; a < static_cast<AttrId>(specs.size()); ++a) {
            const AttributeSpec& spec = specs[static_cast<std::size_t>(a)];
            auto visit = [&](int index) {
                f(Plug{n, a, index, -1});
                if (spec.type == ValueType::Vector3)
                    for (int c = 0; c < 3; ++c) f(Plug{n, a, index, c});
            };
            if (!spec.array) visit(-1);
            else
                for (int i : graph.elementIndices(n, a)) visit(i);
        }
    }
}

// Every plug of the graph, as forEachPlug visits them.
std::vector<Plug> allPlugs(const Graph& graph);

// Plugs whose name matches `pattern` (fnmatch rules: * ? [set]), where an array index is not a set:
// `[*]` matches every element of an array attribute (`inverter.value[*]`) and `[N]` the element N
// (`*.matrixIn[0]`); any other bracket is a set (`[LR]_arm_ctrl.rotate?`). A pattern without wildcards
// names one plug, resolved with Graph::plug (its errors name the node or attribute that is wrong).
// Throws rig::Error when nothing matches.
std::vector<Plug> matchPlugs(const Graph& graph, std::string_view pattern);

bool isGlobPattern(std::string_view pattern);

}  // namespace rig
