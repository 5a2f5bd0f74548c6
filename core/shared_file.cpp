#include "core/shared_file.h"

#include <fmt/format.h>

namespace rig {

std::string fileIdentity(const std::filesystem::path& path)
{
    std::error_code error;
    const auto size = std::filesystem::file_size(path, error);
    if (error) return fmt::format("{}\n0\n0", path.string());
    const auto time = std::filesystem::last_write_time(path, error);
    return fmt::format("{}\n{}\n{}", path.string(), size, error ? 0 : time.time_since_epoch().count());
}

}  // namespace rig
