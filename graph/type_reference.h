#pragma once
// A Markdown reference of node types, written from the registry itself so that the documentation
// (docs/nodes.md) cannot drift from what is built.

#include <string>

#include "graph/node_registry.h"

namespace rig {

// One section per type (in name order): description, then a table of attributes with direction,
// type, unit, default, limits, keyable, and description, and the affects table.
std::string nodeTypeReference(const NodeRegistry& registry);

}  // namespace rig
