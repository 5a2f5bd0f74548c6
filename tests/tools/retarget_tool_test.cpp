// Retargeting end to end (docs/retargeting.md): CMU clip 01_01 with legs 1.15 times longer, inverted through
// rig-invert with and without a map's `retarget:` on the clip's own forward-kinematics rig (which takes any pose of
// its proportions: reached within 1e-3 cm only when retargeted) and on the biped; skel2rig --map-for writing the
// first map for CMU -> biped (rigs/maps/cmu_to_biped.yaml's) and for a renamed clip with other proportions. Skipped
// when the CMU clip (Debian's assimp-testmodels) is absent.
#include <doctest/doctest.h>

#include <filesystem>
#include <sstream>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "learned_fixtures.h"
#include "nodes/clips/target_clip.h"
#include "test_support.h"

using namespace rig;
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

// The clip with the OFFSETs below the thighs (knees, ankles, toes, the toes' End Sites) times 1.15, and some joints
// renamed (`renames`: BVH name -> new name).
std::string longerLegs(const std::vector<std::pair<std::string, std::string>>& renames = {})
{
    std::istringstream in(test::readFile(test::cmuClip));
    std::ostringstream out;
    std::string line, joint;
    const std::vector<std::string> legs{"LeftLeg",  "LeftFoot",  "LeftToeBase",  "LeftToeBase_end",
                                        "RightLeg", "RightFoot", "RightToeBase", "RightToeBase_end"};
    while (std::getline(in, line)) {
        std::istringstream words(line);
        std::string word;
        words >> word;
        if (word == "JOINT" || word == "ROOT") {
            words >> joint;
            for (const auto& [from, to] : renames)
                if (joint == from) line = fmt::format("{} {}", word, to);
        }
        if (word == "End") joint += "_end";
        if (word == "OFFSET" && std::find(legs.begin(), legs.end(), joint) != legs.end()) {
            double x = 0, y = 0, z = 0;
            words >> x >> y >> z;
            line = fmt::format("OFFSET {} {} {}", x * 1.15, y * 1.15, z * 1.15);
        }
        out << line << '\n';
    }
    return out.str();
}

// rig-invert over frames 1:60 (exit code 0 required): its report.
Json invert(const fs::path& approximation, const fs::path& rig, const fs::path& clip, const std::string& map,
            const fs::path& dir)
{
    const auto report = dir / "report.json";
    const auto r =
        test::run(fmt::format("{} {} --rig {} --clip {}{} --frames 1:60 -o {} --report-json {}",
                              test::tool("rig-invert"), approximation.string(), rig.string(), clip.string(),
                              map.empty() ? "" : " --map " + map, (dir / "curves.json").string(), report.string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    return Json::parse(test::readFile(report));
}

const char* const legMap = "retarget:\n  rootScale: auto\n  leg: [LeftUpLeg, LeftLeg, LeftFoot]\n";

}  // namespace

TEST_CASE("retargeting: a clip with longer legs reaches the clip's own rig within 1e-3 cm only when retargeted")
{
    if (!fs::exists(test::cmuClip)) return;
    const auto& cmu = test::cmuSetup();
    const auto dir = test::scratchDir("retarget_tool_fk");
    const auto clip = test::writeFile(dir / "long_legs.bvh", longerLegs());
    const Json plain = invert(cmu.approximation, cmu.rig, clip, "", dir);
    CHECK(plain["status_frames"]["reached"].get<int>() < 60);
    CHECK(plain["max_position_error_cm"].get<double>() > 1.0);
    const Json retargeted = invert(cmu.approximation, cmu.rig, clip, test::writeFile(dir / "map.yaml", legMap), dir);
    CHECK(retargeted["status_frames"]["reached"].get<int>() == 60);
    CHECK(retargeted["max_position_error_cm"].get<double>() < 1e-3);
}

TEST_CASE("retargeting onto the biped: longer legs invert as the clip of the biped's proportions does")
{
    if (!fs::exists(test::cmuClip)) return;
    const auto dir = test::scratchDir("retarget_tool_biped");
    const auto approximation = test::bipedApproximation();
    const auto clip = test::writeFile(dir / "long_legs.bvh", longerLegs());
    const std::string cmuMap = (test::sourceDir() / "rigs/maps/cmu_to_biped.yaml").string();
    const auto retargetMap =
        test::writeFile(dir / "map.yaml", "scale: 5.644444444444445\n" + std::string(legMap)).string();
    const Json original = invert(approximation, "rigs/biped.yaml", test::cmuClip, cmuMap, dir);
    const Json plain = invert(approximation, "rigs/biped.yaml", clip, cmuMap, dir);
    const Json retargeted = invert(approximation, "rigs/biped.yaml", clip, retargetMap, dir);
    // The legs' length is the residual without retargeting; with it, what is left is what the rig cannot take of
    // the original clip too (the spine's and hands' channels it does not have).
    CHECK(plain["max_position_error_cm"].get<double>() > 5.0);
    CHECK(retargeted["max_position_error_cm"].get<double>() ==
          doctest::Approx(original["max_position_error_cm"].get<double>()).epsilon(1e-3));
    CHECK(retargeted["status_frames"] == original["status_frames"]);

    // Weights reach the solve: the hands' rotations, which the biped cannot follow, weighted 0 are not measured.
    REQUIRE(original["worst_rotation_joint"].get<std::string>().ends_with("Hand"));
    const auto weightMap =
        test::writeFile(dir / "weights.yaml",
                        "scale: 5.644444444444445\nweights:\n  LeftHand: {rotation: 0}\n  RightHand: {rotation: 0}\n");
    const Json weighted = invert(approximation, "rigs/biped.yaml", test::cmuClip, weightMap.string(), dir);
    CHECK(!weighted["worst_rotation_joint"].get<std::string>().ends_with("Hand"));
    CHECK(weighted["max_rotation_error_deg"].get<double>() < original["max_rotation_error_deg"].get<double>());
}

TEST_CASE("skel2rig --map-for: the first map for CMU onto the biped is rigs/maps/cmu_to_biped.yaml's")
{
    if (!fs::exists(test::cmuClip)) return;
    const auto dir = test::scratchDir("retarget_tool_first_map");
    const auto out = dir / "map.yaml";
    const auto r = test::run(fmt::format("{} {} --map-for rigs/biped.yaml -o {}", test::tool("skel2rig"),
                                         test::cmuClip.string(), out.string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK(r.out == fmt::format("wrote {}: 31 joints by the same name, 0 by name, 0 by hierarchy, 0 left for a person; "
                               "scale 5.644444444\n",
                               out.string()));
    const TargetMap map = readTargetMap(out);
    const TargetMap reference = readTargetMap(test::sourceDir() / "rigs/maps/cmu_to_biped.yaml");
    CHECK(map.scale == doctest::Approx(reference.scale).epsilon(1e-9));
    CHECK(map.rename.empty());
    CHECK(map.ignore.empty());
    CHECK(!map.retarget.enabled);
    CHECK(map.weights.empty());
}

TEST_CASE("skel2rig --map-for: a rig of prefixed names (skel2rig --prefix) is matched by name")
{
    if (!fs::exists(test::cmuClip)) return;
    const auto dir = test::scratchDir("retarget_tool_prefix");
    const auto rig = dir / "mocap.yaml", out = dir / "map.yaml";
    REQUIRE(test::run(fmt::format("{} {} --prefix mocap_ -o {}", test::tool("skel2rig"), test::cmuClip.string(),
                                  rig.string()))
                .exitCode == 0);
    const auto r = test::run(fmt::format("{} {} --map-for {} -o {}", test::tool("skel2rig"), test::cmuClip.string(),
                                         rig.string(), out.string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    const TargetMap map = readTargetMap(out);
    CHECK(map.rename.size() == 31);
    CHECK(map.rename.at("LeftUpLeg") == "mocap_LeftUpLeg");
    CHECK(map.scale == 1.0);
    CHECK(!map.retarget.enabled);
}

TEST_CASE("skel2rig --map-for: renamed joints matched by name and hierarchy, other proportions retargeted")
{
    if (!fs::exists(test::cmuClip)) return;
    const auto& cmu = test::cmuSetup();
    const auto dir = test::scratchDir("retarget_tool_renamed");
    const auto clip = test::writeFile(dir / "renamed.bvh", longerLegs({{"Hips", "HIPS"},
                                                                       {"LeftUpLeg", "L_UpLeg"},
                                                                       {"RightUpLeg", "upLeg_r"},
                                                                       {"LeftLeg", "Bone7"},
                                                                       {"LowerBack", "mocap:LowerBack"}}));
    const auto out = dir / "map.yaml";
    const auto r = test::run(
        fmt::format("{} {} --map-for {} -o {}", test::tool("skel2rig"), clip.string(), cmu.rig.string(), out.string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    const std::string text = test::readFile(out);
    CHECK(text.find("  HIPS: Hips  # by name (case, prefix or side convention)\n") != std::string::npos);
    CHECK(text.find("  L_UpLeg: LeftUpLeg  # by name (case, prefix or side convention)\n") != std::string::npos);
    CHECK(text.find("  upLeg_r: RightUpLeg  # by name (case, prefix or side convention)\n") != std::string::npos);
    CHECK(text.find("  Bone7: LeftLeg  # by hierarchy: the only unmatched child of L_UpLeg\n") != std::string::npos);
    CHECK(text.find("  \"mocap:LowerBack\": LowerBack  # by name") != std::string::npos);
    CHECK(text.find("  rootScale: auto") != std::string::npos);
    CHECK(text.find("  leg: [LeftUpLeg, LeftLeg, LeftFoot]\n") != std::string::npos);
    const TargetMap map = readTargetMap(out);
    CHECK(map.scale == doctest::Approx(1.0).epsilon(1e-9));
    CHECK(map.rename.size() == 5);
    // The map as written makes the clip reach its rig.
    const Json report = invert(cmu.approximation, cmu.rig, clip, out.string(), dir);
    CHECK(report["status_frames"]["reached"].get<int>() == 60);
    CHECK(report["max_position_error_cm"].get<double>() < 1e-3);
}

TEST_CASE("skel2rig --map-for mistakes are one line")
{
    if (!fs::exists(test::cmuClip)) return;
    const auto dir = test::scratchDir("retarget_tool_errors");
    const std::string skel2rig = test::tool("skel2rig"), clip = test::cmuClip.string();
    const std::string out = (dir / "m.yaml").string();
    auto r = test::run(fmt::format("{} {} --map-for rigs/nope.yaml -o {}", skel2rig, clip, out));
    CHECK(r.exitCode == 2);
    CHECK(r.err == "error: rigs/nope.yaml: no such rig file\n");
    r = test::run(fmt::format("{} {} --map-for rigs/biped.yaml --with-motion -o {}", skel2rig, clip, out));
    CHECK(r.exitCode == 2);
    CHECK(r.err == "error: --with-motion excludes --map-for; run 'skel2rig --help' for usage\n");
    r = test::run(fmt::format("{} {} --map-for rigs/biped.yaml -o rigs/biped.yaml", skel2rig, clip));
    CHECK(r.exitCode == 2);
    CHECK(r.err ==
          "error: -o rigs/biped.yaml: is --map-for (rigs/biped.yaml); writing it would destroy an input, "
          "choose another output file\n");
    // A rig no name relates to the clip: nothing matched, everything left for a person, said in the map.
    r = test::run(fmt::format("{} {} --map-for rigs/examples/arm.yaml -o {}", skel2rig, clip, out));
    CHECK(r.exitCode == 0);
    CHECK(r.out == fmt::format("wrote {}: 0 joints by the same name, 0 by name, 0 by hierarchy, 31 left for a person; "
                               "scale 1\n",
                               out));
    CHECK(test::readFile(out).find("# rig joints no clip joint matched: shoulder, elbow, wrist\n") !=
          std::string::npos);
}
