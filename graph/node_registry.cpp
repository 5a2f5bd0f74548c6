#include "graph/node_registry.h"

#include <algorithm>
#include <cstdlib>

#include <dlfcn.h>
#include <fmt/format.h>

#include "core/error.h"
#include "graph/suggest.h"

namespace rig {

void NodeRegistry::add(std::shared_ptr<const NodeType> type)
{
    const std::string name = type->name();
    if (!types_.emplace(name, std::move(type)).second)
        throw internalError(fmt::format("node type '{}' is registered twice", name));
}

const NodeType* NodeRegistry::find(std::string_view name) const
{
    const auto it = types_.find(name);
    return it == types_.end() ? nullptr : it->second.get();
}

std::shared_ptr<const NodeType> NodeRegistry::get(std::string_view name) const
{
    const auto it = types_.find(name);
    if (it == types_.end())
        throw Error(fmt::format("unknown node type '{}'{}", messageExcerpt(name), didYouMean(name, typeNames())));
    return it->second;
}

std::vector<std::string> NodeRegistry::typeNames() const
{
    std::vector<std::string> names;
    for (const auto& entry : types_) names.push_back(entry.first);
    return names;
}

namespace {

// The folder holding the library this function is compiled into: plugins are built beside it.
std::filesystem::path ownLibraryFolder()
{
    Dl_info info{};
    if (dladdr(reinterpret_cast<void*>(&ownLibraryFolder), &info) == 0 || info.dli_fname == nullptr) return {};
    return std::filesystem::path(info.dli_fname).parent_path();
}

std::vector<std::filesystem::path> candidates(std::string_view name,
                                              const std::vector<std::filesystem::path>& searchPath)
{
    const std::string text(name);
    if (text.find('/') != std::string::npos || text.ends_with(".so")) return {std::filesystem::path(text)};
    std::vector<std::filesystem::path> folders = searchPath;
    if (const char* env = std::getenv("RIG_PLUGIN_PATH")) {
        std::string_view rest(env);
        while (!rest.empty()) {
            const auto colon = rest.find(':');
            if (colon != 0) folders.emplace_back(std::string(rest.substr(0, colon)));
            if (colon == std::string_view::npos) break;
            rest.remove_prefix(colon + 1);
        }
    }
    if (auto own = ownLibraryFolder(); !own.empty()) folders.push_back(own);
    std::vector<std::filesystem::path> files;
    for (const auto& folder : folders) files.push_back(folder / (text + ".so"));
    return files;
}

}  // namespace

std::filesystem::path NodeRegistry::loadPlugin(std::string_view name,
                                               const std::vector<std::filesystem::path>& searchPath)
{
    if (name.empty()) throw Error("a plugin name is empty; give a name (myNodes) or a path (./myNodes.so)");
    const auto files = candidates(name, searchPath);
    const auto found = std::find_if(files.begin(), files.end(),
                                    [](const std::filesystem::path& f) { return std::filesystem::is_regular_file(f); });
    if (found == files.end()) {
        std::string looked;
        for (const auto& f : files) looked += (looked.empty() ? "" : ", ") + f.string();
        throw Error(fmt::format("plugin '{}' not found (looked for {}); build it, or add its folder to RIG_PLUGIN_PATH",
                                name, looked));
    }
    const auto file = std::filesystem::canonical(*found);
    if (std::find(loadedPlugins_.begin(), loadedPlugins_.end(), file) != loadedPlugins_.end()) return file;

    // Never unloaded: node instances run code from the library until the process ends.
    void* handle = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) throw Error(fmt::format("plugin '{}' could not be loaded: {}", name, dlerror()));
    using Entry = void (*)(NodeRegistry&);
    auto entry = reinterpret_cast<Entry>(dlsym(handle, "initializePlugin"));
    if (entry == nullptr)
        throw Error(
            fmt::format("plugin '{}' ({}) has no initializePlugin entry point; export "
                        "extern \"C\" void initializePlugin(rig::NodeRegistry&)",
                        name, file.string()));
    try {
        entry(*this);
    }
    catch (const Error& e) {
        throw Error(
            fmt::format("plugin '{}' ({}) failed to register its node types: {}", name, file.string(), e.what()));
    }
    loadedPlugins_.push_back(file);
    return file;
}

}  // namespace rig
