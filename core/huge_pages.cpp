#include "core/huge_pages.h"

#include <sys/mman.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>

namespace rig {

namespace {

// Linux 6.1; older C libraries do not name it.
constexpr int adviseCollapse = 25;
constexpr std::uintptr_t hugePage = std::uintptr_t{2} << 20;

// [first, last) of a private anonymous writable mapping of /proc/self/maps, or an empty range.
std::pair<std::uintptr_t, std::uintptr_t> anonymousRange(const std::string& line)
{
    std::istringstream in(line);
    std::string range, permissions, offset, device, inode, path;
    in >> range >> permissions >> offset >> device >> inode;
    std::getline(in >> std::ws, path);
    // The heap and the mappings malloc makes for large blocks; not the stack, vdso or files.
    if (permissions.rfind("rw", 0) != 0 || permissions.size() < 4 || permissions[3] != 'p' || inode != "0" ||
        !(path.empty() || path == "[heap]"))
        return {0, 0};
    const std::size_t dash = range.find('-');
    return {std::stoull(range.substr(0, dash), nullptr, 16), std::stoull(range.substr(dash + 1), nullptr, 16)};
}

}  // namespace

std::size_t collapseIntoHugePages()
{
    std::ifstream maps("/proc/self/maps");
    std::size_t collapsed = 0;
    for (std::string line; std::getline(maps, line);) {
        const auto [first, last] = anonymousRange(line);
        const std::uintptr_t begin = (first + hugePage - 1) & ~(hugePage - 1), end = last & ~(hugePage - 1);
        // A range that fails (EINVAL: no such advice on this kernel, huge pages off, a thread's stack) stays in small
        // pages; the others are still tried.
        if (end > begin && madvise(reinterpret_cast<void*>(begin), end - begin, adviseCollapse) == 0)
            collapsed += end - begin;
    }
    return collapsed;
}

}  // namespace rig
