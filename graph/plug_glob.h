#pragma once
// Plugs by shell-style glob over their names ('*.worldMatrix', 'L_arm_*.rotate?', 'spine[12].rotateX').

#include <string>
#include <string_view>
#include <vector>

#include "graph/graph.h"

namespace rig {

// Every plug of the graph by name: attributes, vector3 components, existing array elements.
std::vector<Plug> allPlugs(const Graph& graph);

// Plugs whose name matches `pattern` (fnmatch rules: * ? [set]), where an array index is not a set:
// `[*]` matches every element of an array attribute (`inverter.value[*]`) and `[N]` the element N
// (`*.matrixIn[0]`); any other bracket is a set (`[LR]_arm_ctrl.rotate?`). A pattern without wildcards
// names one plug, resolved with Graph::plug (its errors name the node or attribute that is wrong).
// Throws rig::Error when nothing matches.
std::vector<Plug> matchPlugs(const Graph& graph, std::string_view pattern);

bool isGlobPattern(std::string_view pattern);

}  // namespace rig
