#pragma once
// A user's input file read whole, refused by name when it cannot be one (docs/robustness.md): a folder,
// a device or a pipe (endless, or blocking forever), a file over its kind's size limit, or one that
// cannot be opened or read. Every message is one line that says what to do.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace rig {

struct InputFileKind {
    std::string_view name;  // as in "is a folder, not a BVH file"
    std::string_view path;  // as in "give the path of a .bvh file"
    std::uintmax_t maxBytes = 0;
    std::string_view tooBig;  // what to do with a file over maxBytes: "cut the clip into shorter ones"
};

// The file's bytes. Throws rig::Error naming the file.
std::string readInputFile(const std::filesystem::path& file, const InputFileKind& kind);

}  // namespace rig
