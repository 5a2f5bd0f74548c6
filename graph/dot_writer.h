#pragma once
// Graphviz of a graph: one box per node (name and type), one edge per connection labelled with
// its plugs. `dot -Tsvg` draws it.

#include <string>

#include "graph/graph.h"

namespace rig {

std::string toDot(const Graph& graph);

}  // namespace rig
