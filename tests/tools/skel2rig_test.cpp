// skel2rig (and its former name bvh2rig) end to end on skeletons read through assimp: every animated skeleton
// of Debian's assimp-testmodels that assimp reads, and the hand-written Z-up legs of tests/corpus/clips, made a
// rig, learned, and their own animation inverted by rig-invert within 1e-6 cm; the rig's skeletonClip playing
// the file; rig-batch and Python's take (docs/clips.md). Models that are absent are skipped.
#include <doctest/doctest.h>

#include <filesystem>
#include <regex>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "learned_fixtures.h"
#include "test_support.h"

using namespace rig;
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

const fs::path models = "/usr/share/assimp/models";

struct Model {
    fs::path file;
    std::string take;  // "" for the first
};

// The rig's parameters (every channel's plug, from its header comment) and its joints.
void rigPlugs(const fs::path& rig, std::vector<std::string>& params, std::vector<std::string>& joints)
{
    const std::string text = test::readFile(rig);
    const std::regex channel(R"(#   \[\d+\] \S+ -> (\S+))"), joint(R"re(- \{name: "([^"]+)", type: joint)re");
    for (auto it = std::sregex_iterator(text.begin(), text.end(), channel); it != std::sregex_iterator(); ++it)
        params.push_back((*it)[1]);
    for (auto it = std::sregex_iterator(text.begin(), text.end(), joint); it != std::sregex_iterator(); ++it)
        joints.push_back((*it)[1]);
}

// skel2rig, rig-learn over every channel, then rig-invert of the file's own take: the report.
Json roundTrip(const Model& model, const fs::path& dir)
{
    const std::string take = model.take.empty() ? "" : fmt::format(" --take '{}'", model.take);
    const fs::path rig = dir / "rig.yaml", approximation = dir / "approx.yaml", report = dir / "report.json";
    auto r = test::run(fmt::format("{} '{}' -o {}{}", test::tool("skel2rig"), model.file.string(), rig.string(), take));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    std::vector<std::string> params, joints;
    rigPlugs(rig, params, joints);
    r = test::run(fmt::format("{} {} --params{} --outputs{} -o {}", test::tool("rig-learn"), rig.string(),
                              test::shellWords(params), test::shellWords(joints), approximation.string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    r = test::run(fmt::format("{} {} --rig {} --clip '{}'{} -o {} --report-json {}", test::tool("rig-invert"),
                              approximation.string(), rig.string(), model.file.string(), take,
                              (dir / "curves.json").string(), report.string()));
    INFO(r.err);
    CHECK(r.exitCode == 0);
    CHECK(r.out.find("  clip: ") != std::string::npos);
    return Json::parse(test::readFile(report));
}

// The round trip of one model into its own folder, its figures as a message.
void checkRoundTrip(const Model& model, const fs::path& folder)
{
    CAPTURE(model.file.string());
    fs::create_directories(folder);
    const Json report = roundTrip(model, folder);
    CHECK(report["failed_frames"] == 0);
    CHECK(report["max_position_error_cm"].get<double>() < 1e-6);
    CHECK(report["max_rotation_error_deg"].get<double>() < 1e-6);
    MESSAGE(fmt::format("{}: {} frames, {} joints, {} parameters: worst {:.3g} cm, {:.3g} deg; {}",
                        model.file.filename().string(), report["frames"].get<int>(), report["target_joints"].get<int>(),
                        report["parameters"].get<int>(), report["max_position_error_cm"].get<double>(),
                        report["max_rotation_error_deg"].get<double>(), report["clip_source"].get<std::string>()));
}

}  // namespace

TEST_CASE("skel2rig: every animated skeleton of assimp-testmodels, its own animation inverted within 1e-6 cm")
{
    const std::vector<Model> all{{models / "FBX/animation_with_skeleton.fbx", ""},
                                 {models / "FBX/huesitos.fbx", ""},
                                 {models / "X/BCN_Epileptic.X", ""},
                                 {models / "X/Testwuson.X", "Wuson_Walk"},
                                 {models / "X/anim_test.x", ""},
                                 {models / "Collada/box_nested_animation.dae", ""},
                                 {models / "glTF2/simple_skin/simple_skin.gltf", ""},
                                 {models / "MDL/MDL (HL1)/man.mdl", "walk"}};
    const auto dir = test::scratchDir("skel2rig_models");
    for (std::size_t i = 0; i < all.size(); ++i) {
        if (!fs::exists(all[i].file)) {
            MESSAGE("[skipped] " << all[i].file.string() << " is absent (Debian package assimp-testmodels)");
            continue;
        }
        checkRoundTrip(all[i], dir / std::to_string(i));
    }
    // spider.fbx is a mesh without a skeleton or an animation: refused in one line.
    const fs::path spider = models / "FBX/spider.fbx";
    if (fs::exists(spider)) {
        const auto r = test::run(
            fmt::format("{} {} -o {}", test::tool("skel2rig"), spider.string(), (dir / "spider.yaml").string()));
        CHECK(r.exitCode == 2);
        CHECK(r.err == "error: " + spider.string() + ": has no animation; a clip needs a skeleton and its motion\n");
    }
}

TEST_CASE(
    "skel2rig: the hand-written Z-up legs (FBX in inches, Collada in cm), their animation inverted within 1e-6 cm")
{
    const auto dir = test::scratchDir("skel2rig_legs");
    checkRoundTrip({test::sourceDir() / "tests/corpus/clips/leg_z_up_inches.fbx", ""}, dir / "fbx");
    checkRoundTrip({test::sourceDir() / "tests/corpus/clips/leg_z_up_cm.dae", ""}, dir / "dae");
}

TEST_CASE("skel2rig and bvh2rig are one program: the same rig from either name, and the source in its header")
{
    const auto dir = test::scratchDir("skel2rig_names");
    for (const char* clip : {"tests/corpus/bvh/good.bvh", "tests/corpus/clips/leg_z_up_inches.fbx"}) {
        CAPTURE(clip);
        const auto a = test::run(fmt::format("{} {} -o {}", test::tool("skel2rig"), clip, (dir / "a.yaml").string()));
        const auto b = test::run(fmt::format("{} {} -o {}", test::tool("bvh2rig"), clip, (dir / "b.yaml").string()));
        REQUIRE(a.exitCode == 0);
        REQUIRE(b.exitCode == 0);
        CHECK(test::readFile(dir / "a.yaml") == test::readFile(dir / "b.yaml"));
        CHECK(test::readFile(dir / "a.yaml").starts_with("# Generated by skel2rig from "));
    }
    CHECK(test::readFile(dir / "a.yaml")
              .find("# Source: FBX, units x2.54 to cm (FBX UnitScaleFactor 2.54), up axis "
                    "Z, take 0 'bend' of 1, 2 fps.\n") != std::string::npos);
    const auto help = test::run(test::tool("bvh2rig") + " --help");
    CHECK(help.out.starts_with("bvh2rig: write a forward-kinematics rig"));
    CHECK(test::run(test::tool("skel2rig") + " --help").out.starts_with("skel2rig: write a forward-kinematics rig"));
}

TEST_CASE("skel2rig --with-motion: the rig's skeletonClip drives it through the file's own frames")
{
    const auto dir = test::scratchDir("skel2rig_motion");
    const fs::path leg = test::sourceDir() / "tests/corpus/clips/leg_z_up_inches.fbx";
    const auto made = test::run(fmt::format("{} {} --with-motion --take bend -o {}", test::tool("skel2rig"),
                                            leg.string(), (dir / "leg.yaml").string()));
    INFO(made.err);
    REQUIRE(made.exitCode == 0);
    CHECK(made.out.find("driven by skeletonClip 'clip'") != std::string::npos);
    CHECK(test::readFile(dir / "leg.yaml").find("type: skeletonClip, file: '" + leg.string() + "', take: 'bend'") !=
          std::string::npos);
    // The ankle at frame 3: the knee bent 90 degrees (float keys), 16 inches towards -X from the knee.
    const auto r = test::run(fmt::format("{} {} --frames 3:3 --get ankle.worldMatrix -o {}", test::tool("graph-eval"),
                                         (dir / "leg.yaml").string(), (dir / "eval.json").string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    const Json eval = Json::parse(test::readFile(dir / "eval.json"));
    const Json& m = eval[0]["ankle.worldMatrix"];
    CHECK(m[0][3].get<double>() == doctest::Approx(-40.64).epsilon(1e-6));
    CHECK(m[1][3].get<double>() == doctest::Approx(50.8).epsilon(1e-6));
    CHECK(std::abs(m[2][3].get<double>()) < 1e-6);
}

TEST_CASE("rig-batch --clips takes a folder's animation files by their extensions, --take for each")
{
    const auto dir = test::scratchDir("skel2rig_batch");
    const fs::path leg = test::sourceDir() / "tests/corpus/clips/leg_z_up_inches.fbx";
    fs::create_directories(dir / "clips");
    fs::copy_file(leg, dir / "clips/leg.fbx");
    fs::copy_file(leg, dir / "clips/leg_again.FBX");
    test::writeFile(dir / "clips/notes.txt", "not a clip\n");
    const Json report = roundTrip({leg, "bend"}, dir);
    CHECK(report["clip_source"] ==
          "FBX, units x2.54 to cm (FBX UnitScaleFactor 2.54), up axis Z, take 0 'bend' of 1, 2 fps");
    // Both files (an extension in capitals too) and not the notes.
    const auto r = test::run(fmt::format(
        "{} {} --rig {} --clips {} --take 0 --out {} --jobs 1 -q", test::tool("rig-batch"),
        (dir / "approx.yaml").string(), (dir / "rig.yaml").string(), (dir / "clips").string(), (dir / "out").string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    const Json batch = Json::parse(test::readFile(dir / "out/report.json"));
    CHECK(batch["totals"]["clips"] == 2);
    CHECK(fs::exists(dir / "out/leg.json"));
    CHECK(fs::exists(dir / "out/leg_again.json"));
}
