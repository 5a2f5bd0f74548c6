// docs/nodes.md carries the node reference generated from the registry; it must match the code.
#include <doctest/doctest.h>

#include <fstream>
#include <sstream>

#include "app/eval/eval_run.h"
#include "graph/type_reference.h"
#include "test_support.h"

TEST_CASE("docs/nodes.md holds the current node reference (run scripts/update-node-docs.sh)")
{
    std::ifstream in(rig::test::sourceDir() / "docs" / "nodes.md");
    std::stringstream text;
    text << in.rdbuf();
    const std::string page = text.str();
    const std::string begin = "<!-- BEGIN GENERATED: scripts/update-node-docs.sh -->\n\n";
    const std::string end = "\n<!-- END GENERATED -->";
    const auto from = page.find(begin);
    const auto to = page.find(end);
    REQUIRE(from != std::string::npos);
    REQUIRE(to != std::string::npos);
    auto trimmed = [](std::string s) { return s.erase(s.find_last_not_of('\n') + 1); };
    const std::string committed = page.substr(from + begin.size(), to - from - begin.size());
    // Every node type, as graph-eval --types lists them: the built-in ones and the bundled rigInversion plugin's.
    CHECK(trimmed(committed) == trimmed(rig::nodeTypeReference(*rig::app::typesRegistry({}))));
}
