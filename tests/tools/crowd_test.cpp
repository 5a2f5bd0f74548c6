// The look-at crowd (docs/crowds.md): scripts/make_crowd.py writes rigs/examples/crowd_lookat.yaml, each
// member's rigInversion node drives its own namespace, and each member's curves played by graph-eval equal
// rig-invert's on that member's edited targets (split by scripts/crowd_targets.py), the first member's
// those of the single biped of rigs/examples/biped_lookat.yaml.

#include <doctest/doctest.h>

#include <filesystem>
#include <string>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "app/eval/eval_run.h"
#include "core/error.h"
#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "learned_fixtures.h"
#include "test_support.h"

namespace {

namespace fs = std::filesystem;

// Each frame's values of the plugs named `NS.value[i]` (graph-eval JSON), in order, against rig-invert's
// curves (JSON: "frame" then the controls in the approximation's order).
void checkSameCurves(const YAML::Node& graph, const std::string& node, const YAML::Node& inverted)
{
    REQUIRE(graph.size() == inverted.size());
    for (std::size_t f = 0; f < graph.size(); ++f) {
        CAPTURE(f);
        int i = 0;
        for (const auto& entry : inverted[f]) {
            const std::string control = entry.first.as<std::string>();
            if (control == "frame") continue;
            CAPTURE(control);
            CHECK(graph[f][fmt::format("{}.value[{}]", node, i++)].as<double>() == entry.second.as<double>());
        }
        CHECK(i > 70);
    }
}

}  // namespace

TEST_CASE("rigs/examples/crowd_lookat.yaml is what scripts/make_crowd.py 2 writes")
{
    const auto out = rig::test::scratchDir("crowd-generated") / "crowd_lookat.yaml";
    const auto r =
        rig::test::run(fmt::format("python3 scripts/make_crowd.py 2 -o '{}' && cmp -s '{}' "
                                   "rigs/examples/crowd_lookat.yaml",
                                   out.string(), out.string()));
    CHECK(r.exitCode == 0);
    const auto none = rig::test::run("python3 scripts/make_crowd.py 0");
    CHECK(none.exitCode == 2);
    CHECK(none.err.find("make_crowd.py: error: the crowd has 0 bipeds; give 1 or more") != std::string::npos);
}

TEST_CASE("the look-at crowd: each member's curves are rig-invert's on its edited targets")
{
    if (!fs::exists(rig::test::cmuClip)) return;
    const auto dir = rig::test::scratchDir("crowd-lookat");
    const fs::path crowd = rig::test::writeCrowd(dir, 2);
    const fs::path played = dir / "played.json";
    const auto eval = rig::test::run(
        fmt::format("{} '{}' --frames 1:6 --threads 2 --get '*:inverter.target[*]' --get '*:inverter.outputNames' "
                    "--get '*:inverter.value[*]' -o '{}'",
                    rig::test::tool("graph-eval"), crowd.string(), played.string()));
    INFO(eval.err);
    REQUIRE(eval.exitCode == 0);
    const auto split = rig::test::run(
        fmt::format("python3 scripts/crowd_targets.py '{}' -o '{}'", played.string(), (dir / "targets").string()));
    INFO(split.err);
    REQUIRE(split.exitCode == 0);
    const YAML::Node graph = YAML::LoadFile(played.string());
    for (const std::string ns : {"c0000", "c0001"}) {
        CAPTURE(ns);
        const fs::path curves = dir / (ns + ".curves.json");
        const auto inverted = rig::test::run(
            fmt::format("{} '{}' --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped_lookat.yaml --clip '{}' -q -o '{}'",
                        rig::test::tool("rig-invert"), rig::test::bipedApproximation().string(),
                        (dir / "targets" / (ns + ".json")).string(), curves.string()));
        INFO(inverted.err);
        REQUIRE(inverted.exitCode == 0);
        checkSameCurves(graph, ns + ":inverter", YAML::LoadFile(curves.string()));
    }

    // The first member starts at frame 1 under the same camera path: the single biped's graph, value for value.
    const auto source = rig::test::sourceDir();
    std::string single = rig::test::readFile(source / "rigs/examples/biped_lookat.yaml");
    for (const auto& [from, to] :
         {std::pair<std::string, fs::path>{"../biped.yaml", source / "rigs/biped.yaml"},
          {"../../build/biped.approx.yaml", rig::test::bipedApproximation()},
          {"../maps/cmu_to_biped_lookat.yaml", source / "rigs/maps/cmu_to_biped_lookat.yaml"}}) {
        const auto at = single.find(from);
        REQUIRE(at != std::string::npos);
        single.replace(at, from.size(), to.string());
    }
    const auto lookat = rig::test::writeFile(dir / "biped_lookat.yaml", single);
    const auto one = rig::test::run(
        fmt::format("{} '{}' --frames 1:6 --get 'inverter.value[*]'", rig::test::tool("graph-eval"), lookat.string()));
    REQUIRE(one.exitCode == 0);
    const YAML::Node reference = YAML::Load(one.out);
    REQUIRE(reference.size() == graph.size());
    for (std::size_t f = 0; f < graph.size(); ++f)
        for (int i = 0; reference[f][fmt::format("inverter.value[{}]", i)]; ++i)
            CHECK(graph[f][fmt::format("c0000:inverter.value[{}]", i)].as<double>() ==
                  reference[f][fmt::format("inverter.value[{}]", i)].as<double>());
}

TEST_CASE("rigInversion connect: a namespace the graph lacks is one line naming the plug")
{
    if (!fs::exists(rig::test::cmuClip)) return;
    const auto dir = rig::test::scratchDir("crowd-namespace");
    std::string text = rig::test::readFile(rig::test::writeCrowd(dir, 1));
    const std::string from = "parameters: true, namespace: c0000}";
    const auto at = text.find(from);
    REQUIRE(at != std::string::npos);
    text.replace(at, from.size(), "parameters: true, namespace: extra}");
    const auto bad = rig::test::writeFile(dir / "bad.yaml", text);
    const auto r = rig::test::run(fmt::format("{} '{}'", rig::test::tool("graph-eval"), bad.string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err.find("the approximation drives 'extra:root_ctrl.translateX', which this graph does not have") !=
          std::string::npos);
    CHECK(r.err.find('\n') == r.err.size() - 1);
}

TEST_CASE("rigInversion: nodes share one approximation file's model, read again when the file is written again")
{
    const auto dir = rig::test::scratchDir("crowd-shared-model");
    const fs::path approximation = dir / "biped.approx.yaml";
    fs::copy_file(rig::test::bipedApproximation(), approximation);
    const auto graph = rig::test::writeFile(
        dir / "two.yaml",
        "plugins: [rigInversion]\nnodes:\n  - {name: a, type: rigInversion, file: biped.approx.yaml}\n"
        "  - {name: b, type: rigInversion, file: biped.approx.yaml}\n");
    const auto registry = rig::app::nodeRegistry({});
    auto first = rig::loadGraphFile(graph, registry);
    CHECK(std::get<int>(first->getValue(first->plug("a.iterations"))) == 0);  // no targets: nothing to solve
    CHECK(std::get<std::string>(first->getValue(first->plug("b.parameterNames"))).starts_with("root_ctrl."));
    // While the first graph holds the model, the file is written again: a node that reads it now reads the new
    // file (here not an approximation), not the model in memory.
    rig::test::writeFile(approximation, "format: something else\n");
    auto second = rig::loadGraphFile(graph, registry);
    std::string message;
    try {
        second->getValue(second->plug("a.iterations"));
    }
    catch (const rig::Error& e) {
        message = e.what();
    }
    INFO(message);
    CHECK(message == fmt::format("a.file: {}:1:9: format: not an approximation file (expected format: "
                                 "rigInversionApproximation)",
                                 approximation.string()));
}
