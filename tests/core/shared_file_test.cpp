// Values read from files and shared by their readers (core/shared_file.h): one reading per file as it is on disk.
#include <doctest/doctest.h>

#include <memory>
#include <string>

#include "core/error.h"
#include "core/shared_file.h"
#include "test_support.h"

using namespace rig;

TEST_CASE("shared file values: one reading per file and key while held, another once the file changes or is let go")
{
    const auto dir = test::scratchDir("shared-file");
    const auto file = test::writeFile(dir / "a.txt", "one");
    int reads = 0;
    const auto read = [&] { return std::string("read ") + std::to_string(++reads); };

    const auto first = sharedFileValue<std::string>(file, "x", read);
    const auto again = sharedFileValue<std::string>(file, "x", read);
    CHECK(first == again);
    CHECK(*again == "read 1");
    // What else the value depends on is part of the key.
    CHECK(*sharedFileValue<std::string>(file, "y", read) == "read 2");
    // A file written again (another size) is read again, while the readers of the old one keep theirs.
    test::writeFile(file, "three");
    auto rewritten = sharedFileValue<std::string>(file, "x", read);
    CHECK(*rewritten == "read 3");
    CHECK(*first == "read 1");
    // Nothing is kept once no reader holds it.
    const std::weak_ptr<const std::string> watch = rewritten;
    CHECK(!watch.expired());
    rewritten.reset();
    CHECK(watch.expired());
    CHECK(*sharedFileValue<std::string>(file, "x", read) == "read 4");
    // A file that cannot be read is the reader's to refuse: its error reaches the caller, and nothing is kept.
    CHECK(test::errorOf([&] {
              sharedFileValue<std::string>(dir / "none.txt", "x",
                                           []() -> std::string { throw Error("none.txt: no such file"); });
          }) == "none.txt: no such file");
    CHECK(*sharedFileValue<std::string>(dir / "none.txt", "x", read) == "read 5");
}
