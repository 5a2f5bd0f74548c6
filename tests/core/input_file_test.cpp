// Input files read with their checks: the bytes, and one line naming the file for what cannot be read.
#include <doctest/doctest.h>

#include "core/error.h"
#include "core/input_file.h"
#include "test_support.h"

using namespace rig;

TEST_CASE("input file: the bytes of a file, and a folder, a device, a missing or too big file refused by name")
{
    const auto dir = test::scratchDir("input-file");
    const InputFileKind kind{"a clip file", "a .clip file", 16, "cut it"};
    const auto file = test::writeFile(dir / "a.clip", std::string("one\0two", 7));
    CHECK(readInputFile(file, kind) == std::string("one\0two", 7));
    CHECK_THROWS_WITH_AS(readInputFile(dir, kind),
                         (dir.string() + ": is a folder, not a clip file; give the path of a .clip file").c_str(),
                         Error);
    CHECK_THROWS_WITH_AS(readInputFile("/dev/null", kind),
                         "/dev/null: is not a regular file (a device or a pipe?); give the path of a .clip file",
                         Error);
    const auto big = test::writeFile(dir / "big.clip", std::string(std::size_t{2} << 20, 'x'));
    CHECK_THROWS_WITH_AS(readInputFile(big, kind),
                         (big.string() + ": 2 MB is more than the 0 MB a clip file may have; cut it").c_str(), Error);
    CHECK_THROWS_WITH_AS(readInputFile(dir / "none.clip", kind),
                         ((dir / "none.clip").string() +
                          ": cannot open (No such file or directory); check the path (a relative path is read from "
                          "the current folder)")
                             .c_str(),
                         Error);
}
