// Learning ranges that cover the motion (docs/rig-learn.md, Ranges): rig-learn --range and --ranges-from, and the
// model-mismatch error of rig-invert and rig-batch that names the control outside its learned range and the fix.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "inversion/model/approximation_io.h"
#include "inversion/model/learned_range.h"
#include "learned_fixtures.h"
#include "test_support.h"

using rig::test::run;
namespace fs = std::filesystem;

namespace {

const std::string arm = "rigs/examples/arm.yaml";

std::string rigLearn(const std::string& args) { return fmt::format("{} {}", rig::test::tool("rig-learn"), args); }

// The learned range of `parameter` in an approximation file, in degrees.
std::pair<double, double> learnedDegrees(const fs::path& file, const std::string& parameter)
{
    for (const auto& m : rig::readApproximationFile(file).parameters)
        if (m.parameter.name == parameter) return {m.parameter.min * 180 / M_PI, m.parameter.max * 180 / M_PI};
    FAIL("no parameter " << parameter);
    return {};
}

// rigs/biped_inversion.yaml without its `ranges:`: the tutorial's globs, the knees learned over the default +-90.
fs::path specWithoutRanges(const fs::path& dir)
{
    std::string spec = rig::test::readFile("rigs/biped_inversion.yaml");
    spec.erase(spec.find("\nranges:"));
    return rig::test::writeFile(dir / "spec.yaml", spec + "\n");
}

}  // namespace

TEST_CASE("rig-learn --range: a parameter learned over the range given, ahead of the spec's")
{
    const auto dir = rig::test::scratchDir("learn-range");
    const auto out = dir / "arm.approx.yaml";
    const auto spec =
        rig::test::writeFile(dir / "spec.yaml", "params: ['elbow.rotate?']\nranges: {'elbow.*': [-10, 10]}\n");
    const auto r = run(rigLearn(
        fmt::format("{} --spec '{}' --range 'elbow.rotateY=-30:150' -o '{}'", arm, spec.string(), out.string())));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    // The command line's range wins over the spec's for the plug it names; the spec's holds for the others.
    CHECK(r.out.find("  elbow.rotateY  rotation  (0, 1, 0)") != std::string::npos);
    const auto [low, high] = learnedDegrees(out, "elbow.rotateY");
    CHECK(low == doctest::Approx(-30));
    CHECK(high == doctest::Approx(150));
    CHECK(learnedDegrees(out, "elbow.rotateX").second == doctest::Approx(10));
}

TEST_CASE("rig-learn --range and --ranges-from: bad values are one line each, exit code 2")
{
    const auto dir = rig::test::scratchDir("learn-range-errors");
    const auto out = (dir / "a.yaml").string();
    const struct {
        std::string args, message;
    } cases[] = {
        {fmt::format("{} --params 'elbow.rotate?' --range elbow.rotateX -o {}", arm, out),
         "--range 'elbow.rotateX': expected PLUG=MIN:MAX (a parameter glob), e.g. --range "
         "L_knee_fk_ctrl.rotateX=-90:160"},
        {fmt::format("{} --params 'elbow.rotate?' --range elbow.rotateX=5:1 -o {}", arm, out),
         "--range elbow.rotateX: '5:1' is no MIN:MAX of two finite numbers with MIN < MAX (the rig file's units, "
         "degrees for angles), e.g. --range L_knee_fk_ctrl.rotateX=-90:160"},
        {fmt::format("{} --params 'elbow.rotate?' --range elbow.rotateX=-5:nan -o {}", arm, out),
         "--range elbow.rotateX: '-5:nan' is no MIN:MAX of two finite numbers with MIN < MAX (the rig file's units, "
         "degrees for angles), e.g. --range L_knee_fk_ctrl.rotateX=-90:160"},
        {fmt::format("{} --params 'elbow.rotate?' --range 'wrist.*=0:1' -o {}", arm, out),
         "--range wrist.*: matches no parameter; name one of those the parameter globs choose (--params, the spec's "
         "params:)"},
        {fmt::format("rigs/nasty.yaml --params nasty_ctrl.kneeBend --range nasty_ctrl.kneeBend=0:1 -o {}", out),
         "--range nasty_ctrl.kneeBend: every parameter it matches declares its own limits (min, max), which learning "
         "uses; a range is for a control without limits"},
        {fmt::format("{} --params 'elbow.rotate?' --map rigs/maps/cmu_to_biped.yaml -o {}", arm, out),
         "--map requires --ranges-from; run 'rig-learn --help' for usage"},
        {fmt::format("{} --params 'elbow.rotate?' --ranges-from {}/none.bvh -o {}", arm, dir.string(), out),
         fmt::format("{}/none.bvh: cannot open (No such file or directory); check the path (a relative path is read "
                     "from the current folder)",
                     dir.string())},
    };
    for (const auto& c : cases) {
        CAPTURE(c.args);
        const auto r = run(rigLearn(c.args));
        CHECK(r.exitCode == 2);
        CHECK(r.err == "error: " + c.message + "\n");
        CHECK(!fs::exists(out));
    }
}

TEST_CASE("learned ranges: widened to cover the values reached, by a margin, never narrower")
{
    // The knees of CMU 01_01: 93.15 degrees past a -90..90 range, widened by 18 degrees to whole degrees.
    CHECK(rig::widenedRange(-90, 90, 0, 93.15) == std::pair<double, double>{-90, 112});
    CHECK(rig::widenedRange(-90, 90, -95, 10) == std::pair<double, double>{-113, 90});
    CHECK(rig::widenedRange(-90, 90, -10, 10) == std::pair<double, double>{-90, 90});
    // A unitless +-1: a margin of 0.2, to hundredths.
    CHECK(rig::widenedRange(-1, 1, 0, 1.234) == std::pair<double, double>{-1, 1.44});
    CHECK(rig::exactGlob("blendShape1.weight[0]") == "blendShape1.weight\\[0]");
}

TEST_CASE("rig-learn --ranges-from: the tutorial's knees learned over what CMU 01_01 bends them to")
{
    if (!fs::exists(rig::test::cmuClip)) {
        MESSAGE("[skipped] " << rig::test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto dir = rig::test::scratchDir("learn-ranges-from");
    const auto spec = specWithoutRanges(dir);
    const auto narrow = dir / "narrow.approx.yaml", wide = dir / "wide.approx.yaml";
    REQUIRE(
        run(rigLearn(fmt::format("rigs/biped.yaml --spec '{}' -o '{}'", spec.string(), narrow.string()))).exitCode ==
        0);
    const std::string clip = fmt::format("--clip {} --map rigs/maps/cmu_to_biped.yaml", rig::test::cmuClip.string());
    const auto invert = [&](const fs::path& approximation, const std::string& more) {
        return run(fmt::format("{} '{}' --rig rigs/biped.yaml {} -o '{}' -q {}", rig::test::tool("rig-invert"),
                               approximation.string(), clip, (dir / "curves.json").string(), more));
    };
    // Learned over +-90, the knees are extrapolated where the clip bends them past it: the error names the joint,
    // the knee and the flags that fix it.
    const auto before = invert(narrow, fmt::format("--frames 1:240 --report-json '{}'", (dir / "r.json").string()));
    CHECK(before.exitCode == 3);
    CHECK(before.err ==
          fmt::format("error: 9 of 240 frames are not an answer on the real rig (first: frame 193, model mismatch, "
                      "RightToeBase): the approximation disagrees with the real rig at RightToeBase, which "
                      "R_knee_fk_ctrl.rotateX moves, at up to 93.16 deg on the failed frames, outside the -90..90 deg "
                      "it was learned over; learn the rig again over the range the clip uses: rig-learn "
                      "rigs/biped.yaml ... --range R_knee_fk_ctrl.rotateX=-90:112 (... your other flags), or "
                      "rig-learn ... --ranges-from {} --map rigs/maps/cmu_to_biped.yaml --frames 1:240 for every "
                      "control\n",
                      rig::test::cmuClip.string()));
    const auto report = nlohmann::json::parse(rig::test::readFile(dir / "r.json"));
    CHECK(report["first_failure"]["left_range"] ==
          nlohmann::json{{"parameter", "R_knee_fk_ctrl.rotateX"},
                         {"unit", "deg"},
                         {"learned", {-90, 90}},
                         {"reached", report["first_failure"]["left_range"]["reached"]},
                         {"suggested", {-90, 112}}});

    // --ranges-from: learned again over the ranges the whole clip reaches, each widened range on one line.
    const auto learned = run(rigLearn(
        fmt::format("rigs/biped.yaml --spec '{}' --ranges-from {} --map rigs/maps/cmu_to_biped.yaml -o "
                    "'{}' --report-json '{}'",
                    spec.string(), rig::test::cmuClip.string(), wide.string(), (dir / "learn.json").string())));
    INFO(learned.err);
    REQUIRE(learned.exitCode == 0);
    CHECK(learned.out.find(fmt::format("\nRanges from {}: on a first approximation 1 reached, 2742 best fit, 9 model "
                                       "mismatch; 13 learning ranges widened to the values reached and 10% of the "
                                       "range's width, then learned again\n",
                                       rig::test::cmuClip.string())) != std::string::npos);
    CHECK(learned.out.find("\n  L_knee_fk_ctrl.rotateX: -90..90 deg -> -90..111 deg (reached 0..92.63)\n") !=
          std::string::npos);
    CHECK(learned.out.find("\n  R_knee_fk_ctrl.rotateX: -90..90 deg -> -90..112 deg (reached 0..93.16)\n") !=
          std::string::npos);
    CHECK(learnedDegrees(wide, "R_knee_fk_ctrl.rotateX").second == doctest::Approx(112));
    const auto learnReport = nlohmann::json::parse(rig::test::readFile(dir / "learn.json"));
    CHECK(learnReport["ranges_from"]["widened"].size() == 13);
    CHECK(learnReport["ranges_from"]["first_statuses"] == "1 reached, 2742 best fit, 9 model mismatch");
    // Every frame of the clip is now an answer on the real rig.
    const auto after = invert(wide, "");
    INFO(after.err);
    CHECK(after.exitCode == 0);

    // rig-batch says the same of the clip, with its absolute path.
    const auto batch = run(fmt::format(
        "{} '{}' --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml --clips {} "
        "--out '{}' --jobs 1",
        rig::test::tool("rig-batch"), narrow.string(), rig::test::cmuClip.string(), (dir / "library").string()));
    CHECK(batch.exitCode == 3);
    CHECK(batch.err.find("--range R_knee_fk_ctrl.rotateX=-90:112 (... your other flags), or rig-learn ... "
                         "--ranges-from /usr/share/assimp/models/BVH/01_01.bvh --map ") != std::string::npos);
}
