// rig-learn --params auto, --outputs auto and --write-spec end to end (docs/rig-learn.md, "Controls and joints found
// in the scene"): the spec written alone, the spec learning the same approximation as auto, a YAML rig refused.
#include <doctest/doctest.h>

#include <sstream>

#include <fmt/format.h>

#include "test_support.h"

using rig::test::run;

namespace {

const std::string scene = "tests/corpus/maya/auto_controls.ma";

std::string rigLearn(const std::string& args) { return fmt::format("{} {}", rig::test::tool("rig-learn"), args); }

// The file without its `seconds:` lines, which differ between any two runs.
std::string withoutSeconds(const std::filesystem::path& file)
{
    std::istringstream in(rig::test::readFile(file));
    std::string line, out;
    while (std::getline(in, line))
        if (line.find("seconds:") == std::string::npos) out += line + "\n";
    return out;
}

}  // namespace

TEST_CASE("rig-learn auto: --write-spec alone writes what auto chose and learns nothing")
{
    const auto dir = rig::test::scratchDir("rig-learn-auto-spec");
    const auto spec = dir / "spec.yaml";
    const auto r = run(rigLearn(fmt::format("{} --params auto --write-spec '{}'", scene, spec.string())));
    REQUIRE(r.exitCode == 0);
    CHECK(r.err.empty());
    CHECK(r.out == fmt::format("rig-learn {}: 16 parameters, 2 output joints, 1 held plugs\n"
                               "Auto parameters: the channels of 3 controls that move an output (4 channels passed by: "
                               "locked, not keyable, driven by the rig, or moving no output (1); --write-spec lists "
                               "them)\n"
                               "Auto outputs: the joints 1 skinCluster bind\n"
                               "Time curves cut (the learner sets these channels; the curves are the clip): 1\n"
                               "Wrote {}\n",
                               scene, spec.string()));
    const std::string text = rig::test::readFile(spec);
    CHECK(text.find("#   arm_ctrl.translateX: locked\n#   arm_ctrl.scaleX: not keyable\n#   elbow.rotateY: driven by "
                    "twist_sdk.output\n#   arm_ctrl.bend: moves no output\n") != std::string::npos);
    CHECK(text.find("params:\n  - 'arm_ctrl.translateY'\n") != std::string::npos);
    CHECK(text.find("  - 'elbow.rotateZ'\n") != std::string::npos);
    CHECK(text.find("outputs:\n  - 'shoulder'\n  - 'elbow'\nset:\n  'arm_ctrl.mode': 1\n") != std::string::npos);
}

TEST_CASE("rig-learn auto: the spec written learns the same approximation as auto, and so does params: auto")
{
    const auto dir = rig::test::scratchDir("rig-learn-auto-round-trip");
    const auto spec = dir / "spec.yaml", autoApprox = dir / "auto.yaml", specApprox = dir / "spec_approx.yaml";
    const auto first = run(rigLearn(fmt::format("{} --params auto -o '{}' --write-spec '{}' --allow-inexact", scene,
                                                autoApprox.string(), spec.string())));
    REQUIRE(first.exitCode == 0);
    const auto second =
        run(rigLearn(fmt::format("{} --spec '{}' -o '{}' --allow-inexact", scene, spec.string(), specApprox.string())));
    REQUIRE(second.exitCode == 0);
    CHECK(withoutSeconds(autoApprox) == withoutSeconds(specApprox));
    CHECK(rig::test::readFile(autoApprox).find("held:") != std::string::npos);

    const auto autoSpec = rig::test::writeFile(dir / "auto_spec.yaml", "params: auto\noutputs: auto\n");
    const auto third = run(rigLearn(fmt::format("{} --spec '{}' -o '{}' --allow-inexact", scene, autoSpec.string(),
                                                (dir / "third.yaml").string())));
    REQUIRE(third.exitCode == 0);
    CHECK(withoutSeconds(autoApprox) == withoutSeconds(dir / "third.yaml"));
}

TEST_CASE("rig-learn auto: a YAML rig has no controls to find")
{
    const auto dir = rig::test::scratchDir("rig-learn-auto-yaml");
    const auto out = dir / "approx.yaml";
    const auto r = run(rigLearn(fmt::format("rigs/examples/arm.yaml --params auto -o '{}'", out.string())));
    CHECK(r.exitCode == 2);
    CHECK(r.out.empty());
    CHECK(r.err ==
          "error: rigs/examples/arm.yaml: parameters 'auto' are the keyable channels of a Maya scene's controls "
          "(transforms with a nurbsCurve shape), and this is a YAML rig; name its parameters with plug globs such as "
          "'L_arm_*.rotate?'\n");
    CHECK(!std::filesystem::exists(out));
}
