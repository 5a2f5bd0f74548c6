// rig-invert end to end: a real CMU clip on its bvh2rig rig (exact: the clip's channels come back),
// the same clip on the production-style biped (a residual, finite and steady), chunks that equal one
// run, thread counts that give the same bits, and the command line's errors.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "learned_fixtures.h"
#include "nodes/builtin_nodes.h"
#include "nodes/clips/bvh.h"
#include "nodes/transform_math.h"
#include "test_support.h"

using namespace rig;
namespace fs = std::filesystem;

namespace {

test::CommandResult rigInvert(const std::string& args) { return test::run(test::tool("rig-invert") + " " + args); }

YAML::Node report(const fs::path& file) { return YAML::LoadFile(file.string()); }

}  // namespace

TEST_CASE("rig-invert: a CMU clip on its bvh2rig rig converges on every frame and gives the clip's channels back")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto& s = test::cmuSetup();
    const auto dir = test::scratchDir("rig_invert_cmu_run");
    const auto r = rigInvert(fmt::format("{} --rig {} --clip {} --frames 1:120 -o {} --report-json {}",
                                         s.approximation.string(), s.rig.string(), test::cmuClip.string(),
                                         (dir / "curves.json").string(), (dir / "report.json").string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK(r.err.empty());
    const auto rep = report(dir / "report.json");
    CHECK(rep["frames"].as<int>() == 120);
    CHECK(rep["status_frames"]["reached"].as<int>() == 120);
    CHECK(rep["max_position_error_cm"].as<double>() < 1e-3);
    CHECK(rep["max_rotation_error_deg"].as<double>() < 1e-3);
    CHECK(rep["ms_per_frame"].as<double>() > 0.0);
    CHECK(rep["setup_ms"].as<double>() > 0.0);
    CHECK(rep["per_frame"].size() == 120);

    // The channels, up to equivalent Euler angles: the same local rotation in the joint's rotate order.
    auto rig = loadGraphFile(s.rig, makeBuiltinRegistry());
    const YAML::Node curves = YAML::LoadFile((dir / "curves.json").string());
    REQUIRE(curves.size() == 120);
    double worst = 0.0;
    for (int f = 0; f < 120; ++f) {
        const auto channels = bvhRigChannels(s.clip, s.clip.frame(f));
        for (const auto& j : s.clip.joints) {
            Eigen::Vector3d fromClip = Eigen::Vector3d::Zero(), fromCurves = Eigen::Vector3d::Zero();
            bool rotates = false;
            for (std::size_t c = 0; c < j.channels.size(); ++c) {
                if (!bvhIsRotation(j.channels[c])) continue;
                const int axis = bvhChannelAxis(j.channels[c]);
                const std::string plug = fmt::format("{}.rotate{}", j.name, "XYZ"[axis]);
                fromClip[axis] = channels[j.firstChannel + c] * std::numbers::pi / 180.0;
                fromCurves[axis] = curves[f][plug].as<double>() * std::numbers::pi / 180.0;
                rotates = true;
            }
            if (!rotates) continue;
            const auto order = *rotateOrderFromIndex(std::get<int>(rig->getValue(rig->plug(j.name + ".rotateOrder"))));
            worst = std::max(worst,
                             (eulerToMatrix(fromClip, order) - eulerToMatrix(fromCurves, order)).cwiseAbs().maxCoeff());
        }
    }
    CHECK(worst < 1e-6);
}

TEST_CASE("rig-invert: chunks of a clip give the curves of one run, and threads 1, 2 and 8 the same bits")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto dir = test::scratchDir("rig_invert_chunks");
    const auto approximation = test::bipedApproximation();
    const auto invert = [&](const std::string& frames, const std::string& out, int threads) {
        const auto r = rigInvert(
            fmt::format("{} --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml --clip {} "
                        "--frames {} --restart-every 40 --threads {} -o {} -q",
                        approximation.string(), test::cmuClip.string(), frames, threads, (dir / out).string()));
        INFO(r.err);
        REQUIRE(r.exitCode == 0);
        return YAML::LoadFile((dir / out).string());
    };
    const auto whole = invert("1:100", "whole.json", 1);
    const auto first = invert("1:55", "first.json", 2);
    // The second chunk continues the first (its chain starts at frame 41; --after gives frame 40's values).
    const auto second = invert("56:100 --after " + (dir / "first.json").string(), "second.json", 2);
    REQUIRE(whole.size() == 100);
    REQUIRE(first.size() + second.size() == 100);
    for (std::size_t f = 0; f < 100; ++f) {
        const YAML::Node chunk = f < 55 ? first[f] : second[f - 55];
        CHECK(YAML::Dump(chunk) == YAML::Dump(whole[f]));
    }
    const std::string one = test::readFile(dir / "whole.json");
    invert("1:100", "two.json", 2);
    invert("1:100", "eight.json", 8);
    CHECK(test::readFile(dir / "two.json") == one);
    CHECK(test::readFile(dir / "eight.json") == one);
    // CSV holds the same numbers.
    const auto r =
        rigInvert(fmt::format("{} --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml --clip {} --frames "
                              "1:2 -o {} -q",
                              approximation.string(), test::cmuClip.string(), (dir / "curves.csv").string()));
    REQUIRE(r.exitCode == 0);
    const std::string csv = test::readFile(dir / "curves.csv");
    CHECK(csv.starts_with("frame,root_ctrl.translateX,"));
    CHECK(std::count(csv.begin(), csv.end(), '\n') == 3);
}

TEST_CASE("rig-invert: the CMU clip on the biped leaves a finite residual that is steady from frame to frame")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto dir = test::scratchDir("rig_invert_biped_run");
    const auto r =
        rigInvert(fmt::format("{} --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml --clip {} --frames "
                              "1:240 -o {} --report-json {}",
                              test::bipedApproximation().string(), test::cmuClip.string(),
                              (dir / "curves.json").string(), (dir / "report.json").string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK(r.out.find("frames            240: 1 reached, 239 best fit\n") != std::string::npos);
    // The clip's units as the targets have them: the map's scale is in the factor, and named.
    CHECK(r.out.find("\n  clip: BVH, units x5.64444 to cm (BVH has no unit: taken as is; x5.64444 by the map "
                     "rigs/maps/cmu_to_biped.yaml), up axis Y, take 0 of 1, 120 fps\n") != std::string::npos);
    const auto rep = report(dir / "report.json");
    MESSAGE("biped residual on 01_01 frames 1-240: worst "
            << rep["max_position_error_cm"].as<double>() << " cm, " << rep["max_rotation_error_deg"].as<double>()
            << " deg, mean " << rep["mean_position_error_cm"].as<double>() << " cm");
    // Out of the rig's exact reach after the calibration pose: best fits (the approximation agrees with the real
    // rig at each answer), every frame accounted for, and the joints that carry the residual named.
    CHECK(rep["status_frames"]["reached"].as<int>() == 1);
    CHECK(rep["status_frames"]["best_fit"].as<int>() == 239);
    CHECK(rep["failed_frames"].as<int>() == 0);
    CHECK(rep["first_failure"].IsNull());
    CHECK(rep["residual_joints"].size() > 0);
    CHECK(rep["max_model_gap_cm"].as<double>() < 1e-3);
    // Each residual joint's worst position (cm) and rotation (deg) apart, each its own unit: the worst rotation's
    // joint carries the clip's worst rotation, and no joint's figure passes the clip's worst in its unit. The text
    // line gives the report's first joint in the same figures.
    CHECK(rep["residual_joints"]["LeftHand"]["worst_rotation_error_deg"].as<double>() ==
          rep["max_rotation_error_deg"].as<double>());
    CHECK(rep["residual_joints"]["Neck1"]["worst_position_error_cm"].as<double>() ==
          rep["max_position_error_cm"].as<double>());
    for (const auto& joint : rep["residual_joints"]) {
        CHECK(joint.second["worst_position_error_cm"].as<double>() <= rep["max_position_error_cm"].as<double>());
        CHECK(joint.second["worst_rotation_error_deg"].as<double>() <= rep["max_rotation_error_deg"].as<double>());
    }
    const auto first = rep["residual_joints"].begin();
    CHECK(r.out.find(fmt::format("residual joints   {} ({:.3g} cm, {:.3g} deg, {} frames), ",
                                 first->first.as<std::string>(), first->second["worst_position_error_cm"].as<double>(),
                                 first->second["worst_rotation_error_deg"].as<double>(),
                                 first->second["frames"].as<int>())) != std::string::npos);
    for (std::size_t i = 1; i < rep["per_frame"].size(); ++i) {
        CHECK(rep["per_frame"][i]["status"].as<std::string>() == "best fit");
        CHECK(rep["per_frame"][i]["missed_joints"].size() > 0);
    }
    // The worst rotation is named with its own joint and frame, not the worst position's.
    CHECK(rep["worst_rotation_joint"].as<std::string>() == "LeftHand");
    CHECK(rep["worst_joint"].as<std::string>() == "Neck1");
    CHECK(std::isfinite(rep["max_position_error_cm"].as<double>()));
    // The spine and neck share their rotations and the knee is a hinge: a residual of a few cm, no more.
    CHECK(rep["max_position_error_cm"].as<double>() < 5.0);
    // The clip's first line is a calibration pose (every rotation 0 but three): the motion starts at
    // frame 2, so steadiness is measured from frame 2 to frame 3 on.
    double previous = -1.0, largestJump = 0.0;
    for (std::size_t i = 1; i < rep["per_frame"].size(); ++i) {
        const double e = rep["per_frame"][i]["position_error_cm"].as<double>();
        CHECK(std::isfinite(e));
        if (previous >= 0.0) largestJump = std::max(largestJump, std::abs(e - previous));
        previous = e;
    }
    // Steady: at 120 frames per second the residual moves by a fraction of a centimetre per frame.
    CHECK(largestJump < 0.5);
    // Continuous controls: no angle jumps by whole turns between frames.
    const YAML::Node curves = YAML::LoadFile((dir / "curves.json").string());
    double largestStep = 0.0;
    for (std::size_t f = 2; f < curves.size(); ++f)
        for (const auto& entry : curves[f]) {
            const auto name = entry.first.as<std::string>();
            if (name == "frame" || name.find(".rotate") == std::string::npos) continue;
            largestStep = std::max(largestStep, std::abs(entry.second.as<double>() - curves[f - 1][name].as<double>()));
        }
    CHECK(largestStep < 45.0);
}

TEST_CASE("rig-invert: --term position fits the joints' positions alone, closer than joint targets do")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto dir = test::scratchDir("rig_invert_term_position");
    const auto run = [&](const std::string& name, const std::string& flags) {
        const auto r = rigInvert(
            fmt::format("{} --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml --clip {} --frames 1:60 {} -o {} "
                        "--report-json {} -q",
                        test::bipedApproximation().string(), test::cmuClip.string(), flags,
                        (dir / (name + ".json")).string(), (dir / (name + ".report.json")).string()));
        INFO(r.err);
        REQUIRE(r.exitCode == 0);
        return report(dir / (name + ".report.json"));
    };
    const auto joint = run("joint", "");
    const auto position = run("position", "--term position");
    // Judged on the real rig over what the term counts: positions, every frame reached or a best fit.
    CHECK(position["failed_frames"].as<int>() == 0);
    CHECK(position["max_rotation_error_deg"].as<double>() == 0.0);
    CHECK(position["max_position_error_cm"].as<double>() < 0.5 * joint["max_position_error_cm"].as<double>());
    CHECK(position["mean_position_error_cm"].as<double>() < 0.5 * joint["mean_position_error_cm"].as<double>());
}

TEST_CASE("rig-invert: --contacts holds the feet, a file of the detected ranges gives the same curves, chunks agree")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto dir = test::scratchDir("rig_invert_contacts");
    const auto run = [&](const std::string& name, const std::string& flags) {
        const auto r = rigInvert(
            fmt::format("{} --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml --clip {} --restart-every 40 {} "
                        "-o {} --report-json {}",
                        test::bipedApproximation().string(), test::cmuClip.string(), flags,
                        (dir / (name + ".json")).string(), (dir / (name + ".report.json")).string()));
        INFO(r.err);
        REQUIRE(r.exitCode == 0);
        return r.out;
    };
    const std::string text = run("auto", "--frames 1:300 --contacts auto");
    const YAML::Node contacts = report(dir / "auto.report.json")["contacts"];
    REQUIRE(contacts["count"].as<int>() >= 2);
    CHECK(contacts["per_contact"].size() == contacts["count"].as<std::size_t>());
    CHECK(contacts["max_slide_cm"].as<double>() < 0.01);
    CHECK(text.find(fmt::format("contacts          {}: foot slide on the real rig worst",
                                contacts["count"].as<int>())) != std::string::npos);
    // The detected ranges as a file: the same holds, the same curves.
    std::string file;
    for (const auto& joint : {"LeftFoot", "RightFoot"}) {
        std::vector<std::string> ranges;
        for (const auto& c : contacts["per_contact"])
            if (c["joint"].as<std::string>() == joint)
                ranges.push_back(fmt::format("[{}, {}]", c["first_frame"].as<double>(), c["last_frame"].as<double>()));
        file += fmt::format("{}: [{}]\n", joint, fmt::join(ranges, ", "));
    }
    test::writeFile(dir / "contacts.yaml", file);
    run("file", "--frames 1:300 --contacts " + (dir / "contacts.yaml").string());
    CHECK(test::readFile(dir / "file.json") == test::readFile(dir / "auto.json"));
    // Without contacts the report says none were asked for.
    run("none", "--frames 1:300");
    CHECK(report(dir / "none.report.json")["contacts"].IsNull());
    // Chunks, the second continuing the first: one run's curves, contacts spanning the boundary included.
    run("first", "--frames 1:150 --contacts auto");
    run("second", "--frames 151:300 --contacts auto --after " + (dir / "first.json").string());
    const YAML::Node whole = YAML::LoadFile((dir / "auto.json").string());
    const YAML::Node first = YAML::LoadFile((dir / "first.json").string());
    const YAML::Node second = YAML::LoadFile((dir / "second.json").string());
    REQUIRE(first.size() + second.size() == whole.size());
    for (std::size_t f = 0; f < whole.size(); ++f)
        CHECK(YAML::Dump(f < first.size() ? first[f] : second[f - first.size()]) == YAML::Dump(whole[f]));
}

TEST_CASE("rig-invert: bad input is one line and exit code 2, and leaves outputs alone")
{
    const auto dir = test::scratchDir("rig_invert_errors");
    const auto arm = dir / "arm.approx.yaml";
    REQUIRE(test::run(fmt::format("{} rigs/examples/arm.yaml --params 'shoulder.rotate?' 'elbow.rotate?' -o {}",
                                  test::tool("rig-learn"), arm.string()))
                .exitCode == 0);
    const auto clip = dir / "clip.json";
    REQUIRE(test::run(fmt::format("{} rigs/examples/arm.yaml --frames 1:3 --get '*.worldMatrix' -o {}",
                                  test::tool("graph-eval"), clip.string()))
                .exitCode == 0);
    const std::string out = (dir / "out.json").string();
    test::writeFile(out, "previous\n");
    const std::string base = fmt::format("{} --rig rigs/examples/arm.yaml --clip {}", arm.string(), clip.string());
    const auto expectError = [&](const std::string& args, const std::string& message) {
        const auto r = rigInvert(args);
        CHECK(r.exitCode == 2);
        CHECK(r.out.empty());
        CHECK(r.err == "error: " + message + "\n");
        CHECK(test::readFile(out) == "previous\n");
    };
    expectError(base + " --frames 5:9 -o " + out,
                fmt::format("--frames 5:9: {} has no frame 5 (its frames are 1 to 3)", clip.string()));
    expectError(base + " -o " + (dir / "out.txt").string(),
                fmt::format("-o {}: the curves are written as .json, .csv, .anim or .ma (Maya); give one of those",
                            (dir / "out.txt").string()));
    expectError(fmt::format("{} --rig rigs/examples/arm.yaml --clip {} -o {}", (dir / "none.yaml").string(),
                            clip.string(), out),
                fmt::format("{}: cannot read it (No such file or directory); check the name (rig-learn -o writes one)",
                            (dir / "none.yaml").string()));
    expectError(base + " --map " + (dir / "none.yaml").string() + " -o " + out,
                fmt::format("{}: no such map file; check the path", (dir / "none.yaml").string()));
    expectError(base + " --threads -1 -o " + out,
                "--threads -1: not a thread count; give a whole number from 0 (all cores) to 1024");
    expectError(base + " --restart-every 0 -o " + out,
                "--restart-every 0: give 1 or more frames between warm-start restarts (default 120)");
    expectError(base + " --jacobian exact -o " + out, "--jacobian exact: expected analytic or fd");
    // --after: the curves of the frames before a chunk's chain.
    test::writeFile(dir / "before.json", "[{\"frame\": 1, \"shoulder.rotateX\": 1}]\n");
    expectError(
        base + " --frames 2:3 --restart-every 1 --after " + (dir / "none.json").string() + " -o " + out,
        fmt::format("--after {}: cannot read it; give the curves (.json) rig-invert wrote for the frames before",
                    (dir / "none.json").string()));
    expectError(base + " --frames 1:3 --after " + (dir / "before.json").string() + " -o " + out,
                fmt::format("--after {}: frames 1:3 start at the clip's first chain; there is no frame before them to "
                            "continue from (leave --after out)",
                            (dir / "before.json").string()));
    expectError(base + " --frames 3:3 --restart-every 1 --after " + (dir / "before.json").string() + " -o " + out,
                fmt::format("--after {}: has no frame 2; frames 3:3 start their chain at frame 3, so the curves before "
                            "must reach the frame before it",
                            (dir / "before.json").string()));
    expectError(
        base + " --frames 2:3 --restart-every 1 --after " + (dir / "before.json").string() + " -o " + out,
        fmt::format("--after {}: frame 1 has no finite value of shoulder.rotateZ; give curves written with this "
                    "approximation",
                    (dir / "before.json").string()));
    const auto overwrite = rigInvert(base + " --frames 2:3 --restart-every 1 --after " +
                                     (dir / "before.json").string() + " -o " + (dir / "before.json").string());
    CHECK(overwrite.exitCode == 2);
    CHECK(overwrite.err == fmt::format("error: -o {0}: is --after ({0}); writing it would destroy an input, choose "
                                       "another output file\n",
                                       (dir / "before.json").string()));

    // A clip with no joint of the approximation asks for a map.
    test::writeFile(dir / "other.json",
                    "[{\"frame\": 1, \"x.worldMatrix\": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], "
                    "[0, 0, 0, 1]]}]\n");
    const auto r = rigInvert(fmt::format("{} --rig rigs/examples/arm.yaml --clip {} -o {}", arm.string(),
                                         (dir / "other.json").string(), out));
    CHECK(r.exitCode == 2);
    CHECK(r.err.find("no joint of the clip is an output of the approximation") != std::string::npos);

    // Another rig: a warning, and an error with --strict.
    test::writeFile(dir / "arm_edited.yaml",
                    test::readFile(test::sourceDir() / "rigs/examples/arm.yaml") + "# edited\n");
    const std::string edited = fmt::format("{} --rig {} --clip {} -o {}", arm.string(),
                                           (dir / "arm_edited.yaml").string(), clip.string(), out);
    const auto warned = rigInvert(edited + " -q");
    CHECK(warned.exitCode == 0);
    CHECK(warned.err.starts_with("warning: "));
    const auto strict = rigInvert(edited + " --strict");
    CHECK(strict.exitCode == 2);
    CHECK(strict.err.starts_with("error: "));
}

TEST_CASE("rig-invert: a run of invalid targets measures nothing: its errors are null and 'not measured', never 0")
{
    const auto dir = test::scratchDir("rig_invert_unmeasured");
    const auto arm = dir / "arm.approx.yaml";
    REQUIRE(test::run(fmt::format("{} rigs/examples/arm.yaml --params 'shoulder.rotate?' 'elbow.rotate?' -o {}",
                                  test::tool("rig-learn"), arm.string()))
                .exitCode == 0);
    // Every target 1e308 times out: not finite, so no frame is measured.
    const auto map = test::writeFile(dir / "map.yaml", "scale: 1e308\n");
    const auto r = rigInvert(
        fmt::format("{} --rig rigs/examples/arm.yaml --clip tests/corpus/clips/arm.json --map {} "
                    "-o {} --report-json {}",
                    arm.string(), map.string(), (dir / "curves.json").string(), (dir / "report.json").string()));
    CHECK(r.exitCode == 3);
    CHECK(r.err ==
          "error: 2 of 2 frames are not an answer on the real rig (first: frame 1, invalid targets, shoulder): a "
          "target there is not finite or is singular\n");
    CHECK(r.out.find("real-rig error    not measured (no frame has a target it could be measured against)\n") !=
          std::string::npos);
    CHECK(r.out.find("       1  invalid targets     0             -                            -\n") !=
          std::string::npos);
    CHECK(r.out.find("worst 0 cm") == std::string::npos);
    const auto rep = report(dir / "report.json");
    for (const char* key :
         {"max_position_error_cm", "worst_joint", "worst_frame", "mean_position_error_cm", "max_rotation_error_deg",
          "worst_rotation_joint", "worst_rotation_frame", "mean_rotation_error_deg", "max_model_gap_cm"}) {
        CAPTURE(key);
        CHECK(rep[key].IsNull());
    }
    for (const char* key : {"position_error_cm", "worst_joint", "rotation_error_deg", "model_gap_cm"}) {
        CAPTURE(key);
        CHECK(rep["per_frame"][0][key].IsNull());
    }
}

TEST_CASE("rig-invert: a frame whose targets are not finite is reported and keeps the previous frame's values")
{
    const auto dir = test::scratchDir("rig_invert_nan");
    const auto arm = dir / "arm.approx.yaml";
    REQUIRE(test::run(fmt::format("{} rigs/examples/arm.yaml --params 'shoulder.rotate?' 'elbow.rotate?' -o {}",
                                  test::tool("rig-learn"), arm.string()))
                .exitCode == 0);
    const auto clip = dir / "clip.json";
    REQUIRE(test::run(fmt::format("{} rigs/examples/arm.yaml --set shoulder.rotateZ=20 --frames 1:3 --get "
                                  "'*.worldMatrix' -o {}",
                                  test::tool("graph-eval"), clip.string()))
                .exitCode == 0);
    // Frame 2's elbow target as graph-eval writes a NaN: null.
    std::string text = test::readFile(clip);
    const auto second = text.find("\"frame\": 2");
    const auto elbow = text.find("\"elbow.worldMatrix\": [[", second) + std::string("\"elbow.worldMatrix\": [[").size();
    text.replace(elbow, text.find(',', elbow) - elbow, "null");
    test::writeFile(clip, text);

    const auto r =
        rigInvert(fmt::format("{} --rig rigs/examples/arm.yaml --clip {} -o {} --report-json {}", arm.string(),
                              clip.string(), (dir / "curves.json").string(), (dir / "report.json").string()));
    INFO(r.err);
    // A frame with no answer is never a success: exit code 3, the frame named.
    REQUIRE(r.exitCode == 3);
    CHECK(r.err ==
          "error: 1 of 3 frames are not an answer on the real rig (first: frame 2, invalid targets, "
          "elbow): a target there is not finite or is singular\n");
    const auto rep = YAML::LoadFile((dir / "report.json").string());
    CHECK(rep["frames"].as<int>() == 3);
    // Frame 3's elbow is bent by the arm's animation (arm_ctrl.bend, not a parameter here): out of reach,
    // so stationary with a residual on the arm's joints: a best fit.
    CHECK(rep["status_frames"]["reached"].as<int>() == 1);
    CHECK(rep["status_frames"]["best_fit"].as<int>() == 1);
    CHECK(rep["status_frames"]["invalid_targets"].as<int>() == 1);
    CHECK(rep["per_frame"][2]["termination"].as<std::string>() == "stuck");
    CHECK(rep["per_frame"][2]["status"].as<std::string>() == "best fit");
    CHECK(rep["residual_joints"]["elbow"]["frames"].as<int>() == 1);
    // The elbow's worst position and rotation there, each in its own unit and equal to that frame's own figures.
    CHECK(rep["residual_joints"]["elbow"]["worst_position_error_cm"].as<double>() > 1.0);
    CHECK(rep["residual_joints"]["elbow"]["worst_rotation_error_deg"].as<double>() ==
          rep["per_frame"][2]["rotation_error_deg"].as<double>());
    CHECK(rep["per_frame"][1]["termination"].as<std::string>() == "invalidTargets");
    CHECK(r.out.find("invalid targets") != std::string::npos);
    const std::string curves = test::readFile(dir / "curves.json");
    CHECK(curves.find("null") == std::string::npos);
    const YAML::Node c = YAML::LoadFile((dir / "curves.json").string());
    for (const auto& entry : c[1]) {
        if (entry.first.as<std::string>() == "frame") continue;
        CHECK(entry.second.as<double>() == c[0][entry.first.as<std::string>()].as<double>());
    }
    CHECK(std::abs(c[0]["shoulder.rotateZ"].as<double>() - 20.0) < 1e-6);

    // A contact cannot start at that frame: its hold would be the target there.
    const auto contacts = test::writeFile(dir / "contacts.yaml", "elbow: [[2, 3]]\n");
    const auto held =
        rigInvert(fmt::format("{} --rig rigs/examples/arm.yaml --clip {} --contacts {} -o {}", arm.string(),
                              clip.string(), contacts.string(), (dir / "held.json").string()));
    CHECK(held.exitCode == 2);
    CHECK(held.err == fmt::format("error: --contacts: {}:1:10: 'elbow' has no finite target at frame 2, where its "
                                  "hold would be; start the contact at a frame that has one\n",
                                  contacts.string()));
}
