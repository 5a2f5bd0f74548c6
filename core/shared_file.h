#pragma once
// Read-only values read from files, shared by every reader of the same file: a crowd of 256 characters that
// play one motion clip and read one approximation holds each once (a parsed CMU clip is 2.1 MB; one copy per
// character was most of a crowd's memory). The key is the file as it is on disk (path, size, modification
// time) and whatever else the value depends on, so a file written again is read again; a value lives while
// some reader holds it.

#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

namespace rig {

// "path\nsize\nmodification time" as the file is now (0 for what cannot be read: the reader then fails with
// its own message).
std::string fileIdentity(const std::filesystem::path& path);

// The value held under fileIdentity(path) + `extra`, or `read()`'s, kept for the next reader. Reads run under
// one lock per type: readers of one file wait for its first reading rather than each reading it.
template <class T, class Read>
std::shared_ptr<const T> sharedFileValue(const std::filesystem::path& path, std::string_view extra, Read&& read)
{
    static std::mutex mutex;
    static std::map<std::string, std::weak_ptr<const T>> values;
    std::string key = fileIdentity(path);
    key += '\n';
    key += extra;
    const std::lock_guard lock(mutex);
    if (const auto it = values.find(key); it != values.end())
        if (auto held = it->second.lock()) return held;
    std::shared_ptr<const T> fresh = std::make_shared<const T>(std::forward<Read>(read)());
    std::erase_if(values, [](const auto& entry) { return entry.second.expired(); });
    values[std::move(key)] = fresh;
    return fresh;
}

}  // namespace rig
