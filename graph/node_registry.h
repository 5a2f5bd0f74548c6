#pragma once
// The node types a graph can instantiate: built-ins registered at start-up, others from plugins
// (shared libraries exporting `extern "C" void initializePlugin(rig::NodeRegistry&)`, Maya's
// loadPlugin).

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "graph/node_type.h"

namespace rig {

class NodeRegistry {
public:
    // Throws an internal rig::Error when the name is taken: two plugins must not fight over a type.
    void add(std::shared_ptr<const NodeType> type);
    // nullptr when unknown.
    const NodeType* find(std::string_view name) const;
    std::shared_ptr<const NodeType> get(std::string_view name) const;
    std::vector<std::string> typeNames() const;

    // Loads a plugin once (a second call with the same resolved file does nothing) and returns the
    // file loaded. `name` is a path (contains '/' or ends in ".so") or a plugin name looked up as
    // NAME.so in `searchPath`, then in $RIG_PLUGIN_PATH (':'-separated), then in the folder of
    // this library's plugins (build/lib). Throws rig::Error when it cannot be found or loaded.
    std::filesystem::path loadPlugin(std::string_view name, const std::vector<std::filesystem::path>& searchPath = {});
    const std::vector<std::filesystem::path>& loadedPlugins() const { return loadedPlugins_; }

private:
    std::map<std::string, std::shared_ptr<const NodeType>, std::less<>> types_;
    std::vector<std::filesystem::path> loadedPlugins_;
};

}  // namespace rig
