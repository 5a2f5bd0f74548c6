// Targets too far for the solver's cost (docs/robustness.md): graph-eval's world matrices of rigs/examples/arm.yaml
// with every translation shifted by 1e160 cm (residuals finite, their squares not) and by 1e300 cm. rig-invert and
// rig-batch must call every frame a failure with exit code 3 and report the error as it is, never 0 and never a
// best fit (tests/python/test_invert.py checks Python's report on the same arrays).
#include <doctest/doctest.h>

#include <filesystem>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "test_support.h"

using namespace rig;
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

constexpr int frames = 4;

// The arm's world matrices over frames 1..4 as graph-eval writes them, each translation moved by `shift` cm on
// every axis, into `file` (graph-eval's own output in `dir`).
void farClip(const fs::path& dir, const fs::path& file, double shift)
{
    const fs::path plain = dir / "plain.json";
    const auto r = test::run(fmt::format("{} rigs/examples/arm.yaml --frames 1:{} --get '*.worldMatrix' -o '{}'",
                                         test::tool("graph-eval"), frames, plain.string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    Json clip = Json::parse(test::readFile(plain));
    REQUIRE(clip.size() == static_cast<std::size_t>(frames));
    for (Json& frame : clip)
        for (auto& [plug, value] : frame.items())
            if (plug.ends_with(".worldMatrix"))
                for (int row = 0; row < 3; ++row) value[row][3] = value[row][3].get<double>() + shift;
    test::writeFile(file, clip.dump());
}

fs::path learnArm(const fs::path& dir)
{
    const fs::path approx = dir / "arm.approx.yaml";
    const auto r =
        test::run(fmt::format("{} rigs/examples/arm.yaml --params 'shoulder.rotate?' 'wrist.rotate?' -o '{}'",
                              test::tool("rig-learn"), approx.string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    return approx;
}

}  // namespace

TEST_CASE("rig-invert and rig-batch: targets 1e160 and 1e300 cm away fail every frame with their error as it is")
{
    const auto dir = test::scratchDir("far-targets");
    const fs::path approx = learnArm(dir);
    fs::create_directories(dir / "clips");
    for (const double shift : {1e160, 1e300}) {
        CAPTURE(shift);
        const fs::path clip = dir / "clips" / fmt::format("far{:.0e}.json", shift);
        farClip(dir, clip, shift);
        const fs::path curves = dir / "curves.json", report = dir / "report.json";
        const auto r = test::run(
            fmt::format("{} '{}' --rig rigs/examples/arm.yaml --clip '{}' -o '{}' --report-json "
                        "'{}' -q",
                        test::tool("rig-invert"), approx.string(), clip.string(), curves.string(), report.string()));
        CHECK(r.exitCode == 3);
        CHECK(r.err ==
              "error: 4 of 4 frames are not an answer on the real rig (first: frame 1, non-finite, "
              "shoulder): the real rig gives a non-finite matrix, error or cost there\n");
        const Json json = Json::parse(test::readFile(report));
        CHECK(json["status_frames"]["non_finite"] == frames);
        CHECK(json["status_frames"]["best_fit"] == 0);
        CHECK(json["failed_frames"] == frames);
        CHECK(json["first_failure"] ==
              Json{{"frame", 1}, {"status", "non-finite"}, {"joint", "shoulder"}, {"left_range", nullptr}});
        // The distance of a shift on each axis, sqrt(3) * shift, measured without overflow.
        REQUIRE(json["max_position_error_cm"].is_number());
        CHECK(json["max_position_error_cm"].get<double>() >= 1.7 * shift);
        CHECK(json["max_position_error_cm"].get<double>() <= 1.8 * shift);
        for (const Json& frame : json["per_frame"]) {
            CHECK(frame["status"] == "non-finite");
            CHECK(frame["termination"] == "noConvergence");
            CHECK(frame["position_error_cm"].get<double>() >= 1.7 * shift);
        }
    }

    // rig-batch over both clips: exit code 3, each clip's frames failed, the first failure named.
    const auto r = test::run(fmt::format("{} '{}' --rig rigs/examples/arm.yaml --clips '{}' --out '{}' --jobs 1",
                                         test::tool("rig-batch"), approx.string(), (dir / "clips").string(),
                                         (dir / "batch").string()));
    CHECK(r.exitCode == 3);
    CHECK(r.err ==
          "error: 2 clips have frames that are not an answer on the real rig (failed_frames in report.json); "
          "the first: far1e+160: 4 of 4 frames are not an answer on the real rig (first: frame 1, non-finite, "
          "shoulder): the real rig gives a non-finite matrix, error or cost there\n");
    const Json batch = Json::parse(test::readFile(dir / "batch" / "report.json"));
    REQUIRE(batch["clips"].size() == 2);
    for (const Json& clip : batch["clips"]) {
        const std::string name = clip["name"];
        CAPTURE(name);
        const double shift = name == "far1e+160" ? 1e160 : 1e300;
        CHECK(clip["failed_frames"] == frames);
        CHECK(clip["status_frames"]["non_finite"] == frames);
        CHECK(clip["first_failure"] ==
              Json{{"frame", 1}, {"status", "non-finite"}, {"joint", "shoulder"}, {"left_range", nullptr}});
        CHECK(clip["max_position_error_cm"].get<double>() >= 1.7 * shift);
    }
}
