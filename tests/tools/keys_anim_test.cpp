// Keys and Maya .anim end to end: rig-invert --key-tolerance on a CMU clip and the biped, its report and its
// keyed JSON and CSV; then the round trip dense -> keys -> .anim -> graph-eval --anim -> joints within the
// tolerance of the joints the dense curves give (themselves played from a dense .anim); and the errors of
// the new flags.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>
#include <Eigen/Geometry>

#include "learned_fixtures.h"
#include "test_support.h"

namespace fs = std::filesystem;
using namespace rig;

namespace {

constexpr double toleranceCm = 0.1;
constexpr double toleranceDeg = 0.5;

std::string rigInvert(const std::string& extra)
{
    return fmt::format("{} {} --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml --clip {} --frames 1:60 {}",
                       test::tool("rig-invert"), test::bipedApproximation().string(), test::cmuClip.string(), extra);
}

Eigen::Matrix4d matrix(const YAML::Node& rows)
{
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) m(r, c) = rows[r][c].as<double>();
    return m;
}

double angleDeg(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b)
{
    const Eigen::Matrix3d d = a.topLeftCorner<3, 3>().transpose() * b.topLeftCorner<3, 3>();
    return Eigen::AngleAxisd(Eigen::Quaterniond(d).normalized()).angle() * 180.0 / std::numbers::pi;
}

}  // namespace

TEST_CASE(
    "keys: rig-invert --key-tolerance keys a CMU clip within the tolerance, and .anim plays it back in "
    "graph-eval")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto dir = test::scratchDir("keys_anim_round_trip");
    const std::string keysFlags = fmt::format("--key-tolerance {} --key-tolerance-deg {}", toleranceCm, toleranceDeg);
    const auto keyed = test::run(rigInvert(fmt::format("{} -o {} --report-json {}", keysFlags,
                                                       (dir / "keys.anim").string(), (dir / "report.json").string())));
    INFO(keyed.err);
    REQUIRE(keyed.exitCode == 0);
    CHECK(keyed.out.find("\nkeys              ") != std::string::npos);
    CHECK(keyed.out.find("\nkeys per control  root_ctrl.translateX ") != std::string::npos);
    CHECK(keyed.out.find("\nuniform keys      ") != std::string::npos);

    const YAML::Node report = YAML::LoadFile((dir / "report.json").string())["keys"];
    const auto keys = report["keys"].as<std::size_t>();
    CHECK(report["dense_keys"].as<std::size_t>() == 60 * 79);
    CHECK(keys < report["dense_keys"].as<std::size_t>() / 2);
    CHECK(report["reduction"].as<double>() == doctest::Approx(1.0 - keys / (60.0 * 79.0)));
    CHECK(report["max_position_error_cm"].as<double>() <= toleranceCm);
    CHECK(report["max_rotation_error_deg"].as<double>() <= toleranceDeg);
    CHECK(report["per_control"].size() == 79);
    std::size_t perControl = 0;
    for (const auto& entry : report["per_control"]) perControl += entry.second.as<std::size_t>();
    CHECK(perControl == keys);
    CHECK(report["uniform"]["step"].as<int>() >= 1);
    CHECK(report["uniform"]["max_position_error_cm"].as<double>() <= toleranceCm);
    // The uniform keys' count beside the dense one adds up: at a step of 1, one per frame and control but on the
    // constant curves, keyed once.
    const auto uniformKeys = report["uniform"]["keys"].as<std::size_t>();
    const auto constant = report["uniform"]["constant_curves"].as<std::size_t>();
    CHECK(keyed.out.find(fmt::format("\nkeys              {} for 79 controls against 4740 dense keys (one per frame "
                                     "and control): ",
                                     keys)) != std::string::npos);
    if (report["uniform"]["step"].as<int>() == 1) {
        CHECK(uniformKeys == 60 * 79 - 59 * constant);
        CHECK(keyed.out.find(fmt::format("\nuniform keys      no step over 1 frame holds the tolerance: a key on "
                                         "every frame, constant curves keyed once ({} of 79): {} keys\n",
                                         constant, uniformKeys)) != std::string::npos);
    }

    // The same keys as JSON and CSV.
    REQUIRE(test::run(rigInvert(keysFlags + " -q -o " + (dir / "keys.json").string())).exitCode == 0);
    REQUIRE(test::run(rigInvert(keysFlags + " -q -o " + (dir / "keys.csv").string())).exitCode == 0);
    const YAML::Node json = YAML::LoadFile((dir / "keys.json").string());
    CHECK(json["tangent"].as<std::string>() == "auto");
    CHECK(json["frames"][1].as<double>() == 60.0);
    std::size_t jsonKeys = 0;
    for (const auto& curve : json["curves"]) {
        jsonKeys += curve.second.size();
        CHECK(curve.second[0][0].as<double>() == 1.0);
        CHECK(curve.second[0][2].as<std::string>() == "auto");
    }
    CHECK(jsonKeys == keys);
    const std::string csv = test::readFile(dir / "keys.csv");
    CHECK(csv.starts_with("plug,frame,value,in_tangent,out_tangent\nroot_ctrl.translateX,1,"));
    CHECK(static_cast<std::size_t>(std::count(csv.begin(), csv.end(), '\n')) == keys + 1);

    // Dense curves as .anim: a key every frame.
    REQUIRE(test::run(rigInvert("-q -o " + (dir / "dense.anim").string())).exitCode == 0);
    std::string gets;
    for (const auto& joint : YAML::LoadFile((test::sourceDir() / "rigs/biped_inversion.yaml").string())["outputs"])
        gets += fmt::format(" --get {}.worldMatrix", joint.as<std::string>());
    for (const char* name : {"keys", "dense"}) {
        const auto r = test::run(fmt::format("{} rigs/biped.yaml --anim {} --frames 1:60{} -o {}",
                                             test::tool("graph-eval"), (dir / fmt::format("{}.anim", name)).string(),
                                             gets, (dir / fmt::format("{}_joints.json", name)).string()));
        INFO(r.err);
        REQUIRE(r.exitCode == 0);
    }
    const YAML::Node fromKeys = YAML::LoadFile((dir / "keys_joints.json").string());
    const YAML::Node fromDense = YAML::LoadFile((dir / "dense_joints.json").string());
    REQUIRE(fromKeys.size() == 60);
    REQUIRE(fromDense.size() == 60);
    double worstCm = 0.0, worstDeg = 0.0;
    for (std::size_t f = 0; f < 60; ++f)
        for (const auto& entry : fromDense[f]) {
            const std::string plug = entry.first.as<std::string>();
            if (plug == "frame") continue;
            const Eigen::Matrix4d a = matrix(entry.second), b = matrix(fromKeys[f][plug]);
            worstCm = std::max(worstCm, (a.block<3, 1>(0, 3) - b.block<3, 1>(0, 3)).norm());
            worstDeg = std::max(worstDeg, angleDeg(a, b));
        }
    CHECK(worstCm <= toleranceCm + 1e-9);
    CHECK(worstDeg <= toleranceDeg + 1e-6);
    CHECK(worstCm > 0.0);
    // The report measured what graph-eval plays (degrees written and read back move the last bits only).
    CHECK(worstCm == doctest::Approx(report["max_position_error_cm"].as<double>()).epsilon(1e-6));
}

TEST_CASE("keys: the new flags' bad values are one line and exit code 2")
{
    const auto dir = test::scratchDir("keys_flags");
    const auto arm = dir / "arm.approx.yaml";
    REQUIRE(test::run(fmt::format("{} rigs/examples/arm.yaml --params 'shoulder.rotate?' 'elbow.rotate?' -o {}",
                                  test::tool("rig-learn"), arm.string()))
                .exitCode == 0);
    const std::string base = fmt::format("{} {} --rig rigs/examples/arm.yaml --clip tests/corpus/clips/arm.json -o {}",
                                         test::tool("rig-invert"), arm.string(), (dir / "out.anim").string());
    const auto expectError = [&](const std::string& args, const std::string& message) {
        const auto r = test::run(base + " " + args);
        CHECK(r.exitCode == 2);
        CHECK(r.err == "error: " + message + "\n");
        CHECK_FALSE(fs::exists(dir / "out.anim"));
    };
    expectError("--key-tolerance 0", "--key-tolerance 0: give a positive distance in cm (e.g. 0.1)");
    expectError("--key-tolerance-deg -1", "--key-tolerance-deg -1: give a positive angle in degrees (e.g. 0.5)");
    expectError("--key-tangent bouncy",
                "--key-tangent bouncy: not a tangent type; use one of auto, spline, clamped, "
                "plateau, linear, flat, step, stepnext");
    expectError("--html " + dir.string(), fmt::format("{}: is a folder; give a file name, e.g. --html {}", dir.string(),
                                                      (dir / "report.html").string()));
    expectError("--html " + (dir / "out.anim").string(),
                fmt::format("--html {}: is also -o ({}); give each output a file of its own",
                            (dir / "out.anim").string(), (dir / "out.anim").string()));
    // A two-frame clip keyed: every joint within the tolerance, exit code 0, the .anim readable by graph-eval.
    const auto r = test::run(base + " --key-tolerance 0.01 -q");
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    const auto played = test::run(fmt::format("{} rigs/examples/arm.yaml --anim {} --frames 1:2 --get shoulder.rotateZ",
                                              test::tool("graph-eval"), (dir / "out.anim").string()));
    CHECK(played.exitCode == 0);
}
