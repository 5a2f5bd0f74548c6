// A large block collapsed into huge pages keeps its contents, and is then mapped by them where the system has them.
#include <doctest/doctest.h>

#include <sys/utsname.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "core/huge_pages.h"

using namespace rig;

namespace {

// /proc/self/smaps_rollup's AnonHugePages, in kB.
long anonHugePagesKb()
{
    std::ifstream rollup("/proc/self/smaps_rollup");
    for (std::string key; rollup >> key;) {
        long kb = 0;
        if (key == "AnonHugePages:" && rollup >> kb) return kb;
    }
    return 0;
}

// Transparent huge pages available to an madvise (mode 'always' or 'madvise', not 'never').
bool hugePagesOn()
{
    std::ifstream mode("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string text;
    std::getline(mode, text);
    return !text.empty() && text.find("[never]") == std::string::npos;
}

}  // namespace

TEST_CASE("huge pages: a 32 MB block keeps every value when its pages are collapsed")
{
    constexpr std::size_t count = std::size_t{4} << 20;  // 32 MB of numbers, touched page by page
    std::vector<std::uint64_t> block(count);
    for (std::size_t i = 0; i < count; ++i) block[i] = i * 0x9E3779B97F4A7C15ull;
    const long before = anonHugePagesKb();
    const std::size_t collapsed = collapseIntoHugePages();
    bool same = true;
    for (std::size_t i = 0; i < count; ++i) same = same && block[i] == i * 0x9E3779B97F4A7C15ull;
    CHECK(same);
    utsname host{};
    uname(&host);
    MESSAGE("kernel ", host.release, ", collapsed ", collapsed >> 20, " MB");
    // MADV_COLLAPSE (Linux 6.1) with huge pages on: the block lies over at least 14 whole 2 MB ranges.
    if (hugePagesOn() && collapsed > 0) {
        CHECK(collapsed >= (std::size_t{28} << 20));
        CHECK(anonHugePagesKb() - before >= 28 * 1024);
    }
}
