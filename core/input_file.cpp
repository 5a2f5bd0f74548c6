#include "core/input_file.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {

std::string readInputFile(const std::filesystem::path& file, const InputFileKind& kind)
{
    std::error_code ec;
    const auto status = std::filesystem::status(file, ec);
    if (std::filesystem::is_directory(status))
        throw Error(fmt::format("{}: is a folder, not {}; give the path of {}", file.string(), kind.name, kind.path));
    if (std::filesystem::exists(status) && !std::filesystem::is_regular_file(status))
        throw Error(fmt::format("{}: is not a regular file (a device or a pipe?); give the path of {}", file.string(),
                                kind.path));
    if (const auto size = std::filesystem::file_size(file, ec); !ec && size > kind.maxBytes)
        throw Error(fmt::format("{}: {} MB is more than the {} MB {} may have; {}", file.string(), size >> 20,
                                kind.maxBytes >> 20, kind.name, kind.tooBig));
    std::ifstream in(file, std::ios::binary);
    if (!in && errno == EACCES)
        throw Error(fmt::format("{}: cannot open ({}); check its permissions", file.string(), std::strerror(errno)));
    if (!in)
        throw Error(
            fmt::format("{}: cannot open ({}); check the path (a relative path is read from the current "
                        "folder)",
                        file.string(), std::strerror(errno)));
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) throw Error(fmt::format("{}: cannot be read (a read error); check the file", file.string()));
    return text.str();
}

}  // namespace rig
