// The one error type: kinds, context, messages kept to one line.
#include <doctest/doctest.h>

#include <string>

#include "core/error.h"

using namespace rig;

TEST_CASE("error: a user-input error by default, its kind kept when a caller names where it was")
{
    const Error plain("file.yaml:3:1: no such node; check the name");
    CHECK(plain.kind() == ErrorKind::userInput);
    const Error numerical("the real rig evaluates to NaN", ErrorKind::numerical);
    const Error placed = numerical.in("rig.yaml");
    CHECK(placed.kind() == ErrorKind::numerical);
    CHECK(std::string(placed.what()) == "rig.yaml: the real rig evaluates to NaN");
    const Error internal = internalError("sizes differ");
    CHECK(internal.kind() == ErrorKind::internal);
    CHECK(internal.in("solve").kind() == ErrorKind::internal);
}

TEST_CASE("error: a NUL byte in a message is kept as text, and oneLine escapes control characters")
{
    const Error e(std::string("name a\0b", 8));
    CHECK(std::string(e.what()) == "name a\\x00b");
    CHECK(oneLine("line\nnext\t\x01") == "line\\nnext\\t\\x01");
}
