// Text tables: widths from the widest cell, alignment per column, no trailing spaces.
#include <doctest/doctest.h>

#include "core/table.h"

using namespace rig;

TEST_CASE("table: numbers right-aligned by default, chosen columns left-aligned, rows indented")
{
    const std::vector<std::vector<std::string>> rows{{"#", "name", "value"}, {"10", "a", "1.5"}, {"2", "longer", "20"}};
    CHECK(alignTable(rows) ==
          " #    name  value\n"
          "10       a    1.5\n"
          " 2  longer     20\n");
    CHECK(alignTable(rows, {"  ", {Align::right, Align::left, Align::left}}) ==
          "   #  name    value\n"
          "  10  a       1.5\n"
          "   2  longer  20\n");
}
