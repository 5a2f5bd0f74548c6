// rig-invert --restart-every 1 on the production-style biped (a restart, and so a checked continuity shift, at
// every frame): CMU 01_01's first 20 frames are each reached or a best fit, and the approximation agrees with the
// real rig at every answer. The biped's chest control shares spine joints with the spine's bend, the case where an
// Euler triple's other solution is not the same pose (docs/solver.md, Curves without flips).
#include <doctest/doctest.h>

#include <filesystem>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "learned_fixtures.h"
#include "test_support.h"

using namespace rig;
namespace fs = std::filesystem;
using Json = nlohmann::json;

TEST_CASE("rig-invert --restart-every 1: the biped on CMU 01_01 frames 1:20, each frame reached or a best fit")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto dir = test::scratchDir("restart-every-frame");
    const fs::path curves = dir / "curves.json", report = dir / "report.json";
    const auto r =
        test::run(fmt::format("{} '{}' --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml --clip {} "
                              "--frames 1:20 --restart-every 1 -o '{}' --report-json '{}' -q",
                              test::tool("rig-invert"), test::bipedApproximation().string(), test::cmuClip.string(),
                              curves.string(), report.string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK(r.err.empty());
    const Json json = Json::parse(test::readFile(report));
    CHECK(json["frames"] == 20);
    CHECK(json["lead_in_frames"] == 0);
    CHECK(json["failed_frames"] == 0);
    CHECK(json["first_failure"].is_null());
    const Json& counts = json["status_frames"];
    CHECK(counts["reached"].get<int>() + counts["best_fit"].get<int>() == 20);
    REQUIRE(json["per_frame"].size() == 20);
    for (const Json& frame : json["per_frame"]) {
        CAPTURE(frame.dump());
        CHECK((frame["status"] == "reached" || frame["status"] == "best fit"));
        CHECK(frame["model_gap_cm"].get<double>() < 1e-3);
    }
    CHECK(json["max_model_gap_cm"].get<double>() < 1e-3);
}
