#pragma once
// Plug values as command lines print them: in the file's units (degrees for angles), matrices as
// four rows (column-vector convention: translation in the last column).

#include <string>
#include <vector>

#include "graph/graph.h"

namespace rig::cli {

// JSON of a value of `plug` (null for a non-finite number).
std::string valueToJson(const Graph& graph, const Plug& plug, const Value& value);

// CSV column names for `plug` (one per number) and the matching fields of a value.
std::vector<std::string> csvColumns(const Graph& graph, const Plug& plug, const Value& value);
// `digits` > 0 rounds to that many significant digits (for tables meant to be read).
std::vector<std::string> csvFields(const Graph& graph, const Plug& plug, const Value& value, int digits = 0);

}  // namespace rig::cli
