#pragma once
// Rig graphs written as YAML (docs/rig-format.md): plugins, included files with namespaces, nodes
// with attribute values and `parent:` sugar, dynamic attributes, connections. Every error names
// file:line:column.

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "graph/graph.h"

namespace YAML {
class Node;
}

namespace rig {

// Loads a rig file into a new graph whose types come from `registry` (plugins named by the file are
// loaded into it). Throws rig::Error with "file:line:col: ..." for any problem in the file. When
// `filesRead` is given, it is cleared and receives every rig file read, in reading order: `file`
// first, then each included file (the including file's folder joined with the include's name), once
// per include (a crowd lists its biped file once per namespace), so a caller can tell when any of
// them changes (RigFunction::fingerprint). Plugins are not files read and are not listed.
std::unique_ptr<Graph> loadGraphFile(const std::filesystem::path& file, std::shared_ptr<NodeRegistry> registry,
                                     std::vector<std::filesystem::path>* filesRead = nullptr);

// The same from text; `fileName` is used in messages and its folder to look for plugins.
std::unique_ptr<Graph> loadGraphText(std::string_view text, const std::string& fileName,
                                     std::shared_ptr<NodeRegistry> registry);

// Where a second YAML document begins in `text` (a '---' line followed by content), as 0-based line and
// column; nothing when the text holds one document. Throws YAML::ParserException on a syntax error.
std::optional<std::pair<int, int>> secondYamlDocument(const std::string& text);

// Parses a value for `plug` written in the file's units (degrees for angles): a number, a bool, an
// enum name or index, a string, [x, y, z], a 4x4 matrix as four rows, or a list for arrays.
// `where` prefixes error messages. Used by the loader and by command lines (--set).
Value parseYamlValue(const YAML::Node& node, const Graph& graph, const Plug& plug, const std::string& where);

}  // namespace rig
