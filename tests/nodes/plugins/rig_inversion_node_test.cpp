// The rigInversion plugin node end to end through graph-eval: a graph that wires itself from a clip to a
// rig reproduces the clip's joints, its values equal rig-invert's curves, and a missing file, another
// rig's approximation, a bad map and a cycle are one-line errors.
#include <doctest/doctest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "learned_fixtures.h"
#include "nodes/clips/bvh.h"
#include "test_support.h"

using namespace rig;
namespace fs = std::filesystem;

namespace {

std::string valueGets(int count)
{
    std::string gets;
    for (int i = 0; i < count; ++i) gets += fmt::format(" --get 'inverter.value[{}]'", i);
    return gets;
}

int parameterCount(const fs::path& approximation)
{
    return static_cast<int>(YAML::LoadFile(approximation.string())["parameters"].size());
}

std::string graphFile(const fs::path& rig, const fs::path& approximation, const std::string& map,
                      const std::string& connect = "{targets: clip, parameters: true}")
{
    return fmt::format(
        "plugins: [rigInversion]\ninclude:\n  - {{file: {}}}\nnodes:\n"
        "  - {{name: clip, type: bvhClip, file: {}}}\n"
        "  - name: inverter\n    type: rigInversion\n    file: {}\n{}    connect: {}\n",
        fs::absolute(rig).string(), test::cmuClip.string(), approximation.string(),
        map.empty() ? "" : "    map: " + map + "\n", connect);
}

// The node's values (graph-eval's JSON, `inverter.value[i]`) against rig-invert's curves, frame for frame: the
// same text, since both print the shortest form of the same double.
void checkSameCurves(const fs::path& node, const fs::path& curves, std::size_t frames, int count)
{
    const YAML::Node a = YAML::LoadFile(node.string());
    const YAML::Node b = YAML::LoadFile(curves.string());
    REQUIRE(a.size() == frames);
    REQUIRE(b.size() == frames);
    int compared = 0, equal = 0;
    for (std::size_t f = 0; f < frames; ++f) {
        int i = 0;
        for (const auto& entry : b[f]) {
            if (entry.first.as<std::string>() == "frame") continue;
            equal += a[f][fmt::format("inverter.value[{}]", i)].Scalar() == entry.second.Scalar();
            ++compared;
            ++i;
        }
        CHECK(i == count);
    }
    CHECK(equal == compared);
}

// The largest distance, over `frames` (graph-eval's JSON with each clip joint's worldMatrix), between a joint's
// position and the clip's.
double worstJointPositionCm(const YAML::Node& frames, const BvhClip& clip)
{
    double worst = 0.0;
    for (std::size_t f = 0; f < frames.size(); ++f) {
        const auto expected = bvhWorldMatrices(clip, static_cast<int>(f));
        for (std::size_t j = 0; j < clip.joints.size(); ++j) {
            const YAML::Node m = frames[f][clip.joints[j].name + ".worldMatrix"];
            for (int row = 0; row < 3; ++row)
                worst = std::max(worst, std::abs(m[row][3].as<double>() - expected[j](row, 3)));
        }
    }
    return worst;
}

}  // namespace

TEST_CASE("rigInversion: a bvhClip -> rigInversion -> rig graph reproduces the CMU clip's joints")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto& s = test::cmuSetup();
    const auto dir = test::scratchDir("rig_inversion_node_cmu");
    // The rig's joints carry the clip's names: a namespace keeps them apart from nothing here, so the
    // rig is included as it is and the node's targets come from the clip node.
    const auto graph = test::writeFile(dir / "mocap.yaml", graphFile(s.rig, s.approximation, ""));
    std::string gets;
    for (const auto& j : s.clip.joints) gets += fmt::format(" --get '{}.worldMatrix'", j.name);
    const auto r = test::run(fmt::format("{} {} --frames 1:60{} --get inverter.status -o {}", test::tool("graph-eval"),
                                         graph.string(), gets, (dir / "out.json").string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    const YAML::Node frames = YAML::LoadFile((dir / "out.json").string());
    REQUIRE(frames.size() == 60);
    for (int f = 0; f < 60; ++f) CHECK(frames[f]["inverter.status"].as<std::string>() == "reached");
    CHECK(worstJointPositionCm(frames, s.clip) < 1e-3);
}

TEST_CASE("rigInversion: with term position, the biped reaches the CMU clip's joint positions")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto& s = test::cmuSetup();
    const auto dir = test::scratchDir("rig_inversion_node_position_term");
    const auto graph =
        test::writeFile(dir / "mocap.yaml",
                        graphFile(s.rig, s.approximation, "", "{targets: clip, parameters: true}\n    term: position"));
    std::string gets;
    for (const auto& j : s.clip.joints) gets += fmt::format(" --get '{}.worldMatrix'", j.name);
    const auto r =
        test::run(fmt::format("{} {} --frames 1:30{} --get inverter.status --get inverter.worstErrorCm -o {}",
                              test::tool("graph-eval"), graph.string(), gets, (dir / "out.json").string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    const YAML::Node frames = YAML::LoadFile((dir / "out.json").string());
    REQUIRE(frames.size() == 30);
    for (int f = 0; f < 30; ++f) {
        CHECK(frames[f]["inverter.status"].as<std::string>() == "reached");
        CHECK(frames[f]["inverter.worstErrorCm"].as<double>() < 1e-3);
    }
    CHECK(worstJointPositionCm(frames, s.clip) < 1e-3);
}

TEST_CASE("rigInversion: the node's values equal rig-invert's curves on the biped, frame for frame")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto approximation = test::bipedApproximation();
    const auto dir = test::scratchDir("rig_inversion_node_biped");
    const auto graph = test::writeFile(dir / "biped_mocap.yaml",
                                       graphFile(test::sourceDir() / "rigs/biped.yaml", approximation,
                                                 (test::sourceDir() / "rigs/maps/cmu_to_biped.yaml").string()));
    const int count = parameterCount(approximation);
    const auto node = test::run(fmt::format("{} {} --frames 1:80{} -o {}", test::tool("graph-eval"), graph.string(),
                                            valueGets(count), (dir / "node.json").string()));
    INFO(node.err);
    REQUIRE(node.exitCode == 0);
    const auto invert = test::run(fmt::format(
        "{} {} --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml --clip {} "
        "--frames 1:80 -o {} -q",
        test::tool("rig-invert"), approximation.string(), test::cmuClip.string(), (dir / "curves.json").string()));
    REQUIRE(invert.exitCode == 0);
    checkSameCurves(dir / "node.json", dir / "curves.json", 80, count);
}

TEST_CASE("rigInversion: with contacts, the node's values equal rig-invert --contacts' curves, frame for frame")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto approximation = test::bipedApproximation();
    const auto dir = test::scratchDir("rig_inversion_node_contacts");
    // A contact across the restart at frame 41 (restartInterval 40), one from the first frame.
    const auto contacts = test::writeFile(dir / "contacts.yaml", "LeftFoot: [[1, 30]]\nRightFoot: [[20, 70]]\n");
    const auto graph = test::writeFile(
        dir / "biped_mocap.yaml",
        graphFile(test::sourceDir() / "rigs/biped.yaml", approximation,
                  (test::sourceDir() / "rigs/maps/cmu_to_biped.yaml").string(),
                  "{targets: clip, parameters: true}\n    restartInterval: 40\n    contacts: " + contacts.string()));
    const int count = parameterCount(approximation);
    const auto node = test::run(fmt::format("{} {} --frames 1:80{} -o {}", test::tool("graph-eval"), graph.string(),
                                            valueGets(count), (dir / "node.json").string()));
    INFO(node.err);
    REQUIRE(node.exitCode == 0);
    const auto invert = test::run(fmt::format(
        "{} {} --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml --clip {} --frames 1:80 --restart-every 40 "
        "--contacts {} -o {} --report-json {} -q",
        test::tool("rig-invert"), approximation.string(), test::cmuClip.string(), contacts.string(),
        (dir / "curves.json").string(), (dir / "report.json").string()));
    INFO(invert.err);
    REQUIRE(invert.exitCode == 0);
    CHECK(YAML::LoadFile((dir / "report.json").string())["contacts"]["max_slide_cm"].as<double>() < 0.01);
    checkSameCurves(dir / "node.json", dir / "curves.json", 80, count);
    // A joint the approximation does not have is the node's one line.
    test::writeFile(contacts, "Tail: [[1, 2]]\n");
    const auto bad = test::run(
        fmt::format("{} {} --frames 1:2 --get 'inverter.value[0]'", test::tool("graph-eval"), graph.string()));
    CHECK(bad.exitCode == 2);
    CHECK(bad.err.find(fmt::format("inverter.contacts: {}:1:1: 'Tail' is not an output of the approximation",
                                   contacts.string())) != std::string::npos);
}

TEST_CASE("rigInversion: with a restart every frame, the node's values are rig-invert's, each frame its own clip's")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto approximation = test::bipedApproximation();
    const auto dir = test::scratchDir("rig_inversion_node_restarts");
    const auto graph = test::writeFile(dir / "biped_mocap.yaml",
                                       graphFile(test::sourceDir() / "rigs/biped.yaml", approximation,
                                                 (test::sourceDir() / "rigs/maps/cmu_to_biped.yaml").string(),
                                                 "{targets: clip, parameters: true}\n    restartInterval: 1"));
    const int count = parameterCount(approximation);
    const auto node = test::run(fmt::format("{} {} --frames 1:12{} -o {}", test::tool("graph-eval"), graph.string(),
                                            valueGets(count), (dir / "node.json").string()));
    INFO(node.err);
    REQUIRE(node.exitCode == 0);
    const auto invert = [&](const std::string& frames, const fs::path& out) {
        return test::run(fmt::format("{} {} --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml --clip {} "
                                     "--frames {} --restart-every 1 -o {} -q",
                                     test::tool("rig-invert"), approximation.string(), test::cmuClip.string(), frames,
                                     out.string()))
            .exitCode;
    };
    REQUIRE(invert("1:12", dir / "curves.json") == 0);
    checkSameCurves(dir / "node.json", dir / "curves.json", 12, count);
    // Each frame as a clip of its own: the same curves.
    const YAML::Node whole = YAML::LoadFile((dir / "curves.json").string());
    for (const int frame : {2, 7, 12}) {
        CAPTURE(frame);
        const fs::path alone = dir / fmt::format("frame{}.json", frame);
        REQUIRE(invert(fmt::format("{}:{}", frame, frame), alone) == 0);
        const YAML::Node one = YAML::LoadFile(alone.string());
        REQUIRE(one.size() == 1);
        const YAML::Node same = whole[static_cast<std::size_t>(frame - 1)];
        int equal = 0, compared = 0;
        for (const auto& entry : one[0]) {
            equal += same[entry.first.as<std::string>()].Scalar() == entry.second.Scalar();
            ++compared;
        }
        CHECK(equal == compared);
    }
}

TEST_CASE("rigInversion: a missing file, another rig, a bad map and a cycle are one-line errors")
{
    const auto dir = test::scratchDir("rig_inversion_node_errors");
    const auto arm = dir / "arm.approx.yaml";
    REQUIRE(test::run(fmt::format("{} rigs/examples/arm.yaml --params 'shoulder.rotate?' 'elbow.rotate?' -o {}",
                                  test::tool("rig-learn"), arm.string()))
                .exitCode == 0);
    const auto evaluate = [&](const std::string& name, const std::string& text) {
        const auto file = test::writeFile(dir / name, text);
        const auto r =
            test::run(fmt::format("{} {} --get 'shoulder.worldMatrix'", test::tool("graph-eval"), file.string()));
        CHECK(r.exitCode == 2);
        CHECK(r.out.empty());
        return r.err;
    };
    const std::string rigPath = (test::sourceDir() / "rigs/examples/arm.yaml").string();
    const std::string header = fmt::format("plugins: [rigInversion]\ninclude:\n  - {{file: {}}}\nnodes:\n", rigPath);

    const std::string missing = (dir / "none.yaml").string();
    const std::string line = "  - {name: inverter, type: rigInversion, file: " + missing +
                             ", connect: {targets: 'shoulder', parameters: true}}";
    CHECK(evaluate("missing.yaml", header + line + "\n") ==
          fmt::format("error: {}:5:{}: node 'inverter' (rigInversion): inverter.file: {}: cannot read it (No such file "
                      "or directory); check the name (rig-learn -o writes one)\n",
                      (dir / "missing.yaml").string(), line.find("{targets") + 1, missing));

    // The arm's approximation in a graph without the arm.
    const std::string biped = (test::sourceDir() / "rigs/biped.yaml").string();
    const std::string other =
        evaluate("other.yaml",
                 fmt::format("plugins: [rigInversion]\ninclude:\n  - {{file: {}}}\nnodes:\n"
                             "  - {{name: inverter, type: rigInversion, file: {}, connect: {{parameters: true}}}}\n",
                             biped, arm.string()));
    CHECK(other.find("the approximation drives 'shoulder.rotateZ', which this graph does not have: it was learned from "
                     "another rig (rigs/examples/arm.yaml); include that rig or learn this one\n") !=
          std::string::npos);

    const auto map = test::writeFile(dir / "map.yaml", "scale: -1\n");
    const std::string badMap =
        evaluate("badmap.yaml",
                 header + fmt::format("  - {{name: clip, type: bvhClip}}\n  - {{name: inverter, type: rigInversion, "
                                      "file: {}, map: {}, connect: {{targets: 'shoulder', parameters: true}}}}\n",
                                      arm.string(), map.string()));
    CHECK(badMap.starts_with("error: " + (dir / "badmap.yaml").string() + ":6:"));
    CHECK(badMap.ends_with(map.string() + ":1:8: scale must be positive (target units to cm), got -1\n"));
    // Retargeting needs the clip's rest pose, which the node's targets do not carry: refused, not half applied.
    test::writeFile(map, "retarget:\n  rootScale: 1\n");
    const std::string retarget = evaluate("badmap.yaml", test::readFile(dir / "badmap.yaml"));
    CHECK(
        retarget.ends_with(map.string() +
                           ":2:3: the rigInversion node applies a map's 'scale:', 'joints:', 'ignore:' and 'weights:' "
                           "only; 'retarget:' is for rig-invert and rig-batch (docs/retargeting.md)\n"));
    test::writeFile(map, "weights:\n  pinky: {position: 2}\n");
    const std::string weights = evaluate("badmap.yaml", test::readFile(dir / "badmap.yaml"));
    INFO(weights);
    CHECK(weights.ends_with(map.string() + ":2:3: weights for 'pinky', which is not an output of the approximation; "
                                           "check the name (the rig's)\n"));

    // Targets from the very rig the node drives: the engine's cycle message, with the path.
    const std::string cycle = evaluate(
        "cycle.yaml",
        header + fmt::format("  - {{name: inverter, type: rigInversion, file: {}, connect: {{targets: 'wrist', "
                             "parameters: true}}}}\n",
                             arm.string()));
    CHECK(cycle.find("it would close a cycle (") != std::string::npos);
    CHECK(cycle.find("wrist.worldMatrix -> inverter.target[") != std::string::npos);
    CHECK(std::count(cycle.begin(), cycle.end(), '\n') == 1);

    // A residual term the registry does not know, named with the node's attribute.
    const std::string term = evaluate(
        "term.yaml", header + fmt::format("  - {{name: inverter, type: rigInversion, file: {}, term: aim, connect: "
                                          "{{parameters: true}}}}\n",
                                          arm.string()));
    CHECK(term == "error: " + (dir / "term.yaml").string() +
                      ": evaluating frame 0: inverter.term: unknown residual term 'aim': use one of jointTarget, "
                      "position\n");
}

TEST_CASE("rigInversion: an approximation learned with held plugs holds them on the rig it drives")
{
    // The biped's legs learned in IK mode (rig-learn --set), driven from a second biped in IK mode.
    const auto dir = test::scratchDir("rig_inversion_node_held");
    const auto ik = dir / "ik.yaml";
    const std::vector<std::string> joints{"Hips",     "LHipJoint",   "LeftUpLeg",   "LeftLeg",
                                          "LeftFoot", "LeftToeBase", "RHipJoint",   "RightUpLeg",
                                          "RightLeg", "RightFoot",   "RightToeBase"};
    std::string outputs, renames;
    for (const auto& j : joints) {
        outputs += " " + j;
        renames += fmt::format("  'mocap:{0}': {0}\n", j);
    }
    const auto learned = test::run(fmt::format(
        "{} rigs/biped.yaml --params 'root_ctrl.translate?' 'root_ctrl.rotate?' '[LR]_leg_ik_ctrl.translate?' "
        "'[LR]_leg_pole_ctrl.translate?' '[LR]_foot_fk_ctrl.rotate?' '[LR]_toe_ctrl.rotate?' --outputs{} --set "
        "L_leg_settings.ikFk=1 --set R_leg_settings.ikFk=1 -o {}",
        test::tool("rig-learn"), outputs, ik.string()));
    INFO(learned.err);
    REQUIRE(learned.exitCode == 0);
    const auto map = test::writeFile(dir / "map.yaml", "joints:\n" + renames);
    const std::string biped = (test::sourceDir() / "rigs/biped.yaml").string();
    const std::string graph = fmt::format(
        "plugins: [rigInversion]\ninclude:\n  - {{file: {0}}}\n  - {{file: {0}, namespace: mocap}}\nnodes:\n"
        "  - {{name: inverter, type: rigInversion, file: {1}, map: {2}, connect: {{targets: 'mocap:*', "
        "parameters: true}}}}\n",
        biped, ik.string(), map.string());
    const auto file = test::writeFile(dir / "held.yaml", graph);
    const auto r = test::run(fmt::format(
        "{} {} --set mocap:L_leg_settings.ikFk=1 --set mocap:R_leg_settings.ikFk=1 --set mocap:root_ctrl.translateY=-8 "
        "--get L_leg_settings.ikFk --get R_leg_settings.ikFk --get inverter.heldNames --get 'inverter.heldValue[0]' "
        "--get 'inverter.heldValue[1]' "
        "--get LeftLeg.worldMatrix --get mocap:LeftLeg.worldMatrix -o {}",
        test::tool("graph-eval"), file.string(), (dir / "out.json").string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    const YAML::Node frame = YAML::LoadFile((dir / "out.json").string())[0];
    CHECK(frame["L_leg_settings.ikFk"].as<double>() == 1.0);
    CHECK(frame["R_leg_settings.ikFk"].as<double>() == 1.0);
    CHECK(frame["inverter.heldNames"].as<std::string>() == "L_leg_settings.ikFk\nR_leg_settings.ikFk");
    CHECK(frame["inverter.heldValue[0]"].as<double>() == 1.0);
    CHECK(frame["inverter.heldValue[1]"].as<double>() == 1.0);
    // The knee bent by the IK as in the target rig: the driven rig is in the learned state.
    for (int row = 0; row < 3; ++row)
        CHECK(frame["LeftLeg.worldMatrix"][row][3].as<double>() ==
              doctest::Approx(frame["mocap:LeftLeg.worldMatrix"][row][3].as<double>()).epsilon(1e-6));

    // A held plug that something else drives in the graph cannot be held by the node.
    const auto driven = test::writeFile(dir / "driven.yaml",
                                        graph +
                                            "  - {name: switch, type: transform, addAttr: [{name: v}]}\nconnections:\n"
                                            "  - switch.v -> L_leg_settings.ikFk\n");
    const auto bad =
        test::run(fmt::format("{} {} --get L_leg_settings.ikFk", test::tool("graph-eval"), driven.string()));
    CHECK(bad.exitCode == 2);
    const auto column = graph.find("true}}") - graph.find("  - {name: inverter") + 1;  // of `parameters: true`
    CHECK(bad.err == fmt::format("error: {}:6:{}: node 'inverter' (rigInversion): the approximation was learned with "
                                 "L_leg_settings.ikFk held at 1, but switch.v drives it here; the node holds it at "
                                 "that value: disconnect it, or learn the rig in another state (rig-learn --set)\n",
                                 driven.string(), column));
}

TEST_CASE(
    "rigInversion: without hybrid, the biped's IK legs learned as planar chains give rig-invert's curves, "
    "frame for frame")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto dir = test::scratchDir("rig_inversion_node_chains");
    const auto approximation = dir / "ik.approx.yaml";
    // With helper frames (the default) the legs are constraint operators: every joint modelled.
    const auto learn = test::run(fmt::format("{} rigs/biped.yaml --spec rigs/biped_inversion_ik.yaml -o {}",
                                             test::tool("rig-learn"), approximation.string()));
    REQUIRE(learn.exitCode == 0);
    const std::string map = (test::sourceDir() / "rigs/maps/cmu_to_biped.yaml").string();
    const std::string rigPath = (test::sourceDir() / "rigs/biped.yaml").string();
    const auto graph = test::writeFile(dir / "biped_ik_mocap.yaml", graphFile(rigPath, approximation, map));
    const int count = parameterCount(approximation);
    const auto node =
        test::run(fmt::format("{} {} --frames 1:24{} --get inverter.realRigEvaluations -o {}", test::tool("graph-eval"),
                              graph.string(), valueGets(count), (dir / "node.json").string()));
    INFO(node.err);
    REQUIRE(node.exitCode == 0);
    // Every frame is an answer on the real rig (frame 1, the straight leg, too, since the chains' shapes are refined
    // to an absolute bound).
    const auto invert = test::run(fmt::format("{} {} --rig rigs/biped.yaml --map {} --clip {} --frames 1:24 -o {} -q",
                                              test::tool("rig-invert"), approximation.string(), map,
                                              test::cmuClip.string(), (dir / "curves.json").string()));
    INFO(invert.err);
    CHECK(invert.exitCode == 0);
    checkSameCurves(dir / "node.json", dir / "curves.json", 24, count);
    const YAML::Node a = YAML::LoadFile((dir / "node.json").string());
    for (std::size_t f = 0; f < 24; ++f) CHECK(a[f]["inverter.realRigEvaluations"].as<int>() == 0);
}

TEST_CASE("rigInversion: with hybrid on, the biped's IK legs give rig-invert --hybrid's curves, frame for frame")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto dir = test::scratchDir("rig_inversion_node_hybrid");
    const auto approximation = dir / "ik.approx.yaml";
    // Without helper frames the legs stay unmodelled: the hybrid solve fits them on the real rig.
    const auto learn =
        test::run(fmt::format("{} rigs/biped.yaml --spec rigs/biped_inversion_ik.yaml --no-helpers -o {}",
                              test::tool("rig-learn"), approximation.string()));
    REQUIRE(learn.exitCode == 0);
    const std::string map = (test::sourceDir() / "rigs/maps/cmu_to_biped.yaml").string();
    const std::string rigPath = (test::sourceDir() / "rigs/biped.yaml").string();
    const auto graph =
        test::writeFile(dir / "biped_ik_mocap.yaml", graphFile(rigPath, approximation, map) +
                                                         fmt::format("    hybrid: true\n    rig: {}\n", rigPath));
    const int count = parameterCount(approximation);
    const auto node =
        test::run(fmt::format("{} {} --frames 1:12{} --get inverter.realRigEvaluations -o {}", test::tool("graph-eval"),
                              graph.string(), valueGets(count), (dir / "node.json").string()));
    INFO(node.err);
    REQUIRE(node.exitCode == 0);
    const auto invert = test::run(fmt::format(
        "{} {} --rig rigs/biped.yaml --map {} --clip {} --hybrid --frames 1:12 "
        "-o {} -q",
        test::tool("rig-invert"), approximation.string(), map, test::cmuClip.string(), (dir / "curves.json").string()));
    REQUIRE(invert.exitCode == 0);
    checkSameCurves(dir / "node.json", dir / "curves.json", 12, count);
    const YAML::Node a = YAML::LoadFile((dir / "node.json").string());
    for (std::size_t f = 0; f < 12; ++f) CHECK(a[f]["inverter.realRigEvaluations"].as<int>() > 0);

    // Without a rig file, one line naming the attribute.
    const auto noRig =
        test::writeFile(dir / "no_rig.yaml", graphFile(rigPath, approximation, map) + "    hybrid: true\n");
    const auto r =
        test::run(fmt::format("{} {} --frames 1:1{}", test::tool("graph-eval"), noRig.string(), valueGets(1)));
    CHECK(r.exitCode == 2);
    CHECK(r.err.find("inverter.rig is empty; the hybrid solve evaluates the rig the approximation was learned from "
                     "(rigs/biped.yaml): give its file") != std::string::npos);
}

TEST_CASE(
    "rigInversion: with `rig` its status is rig-invert's, model mismatches included, and without it the "
    "approximation's")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const auto dir = test::scratchDir("rig_inversion_node_real_rig_status");
    // The knees learned over the default +-90 degrees: CMU 01_01 bends them past it from frame 192 on, where the
    // approximation extrapolates and disagrees with the rig.
    std::string spec = test::readFile("rigs/biped_inversion.yaml");
    spec.erase(spec.find("\nranges:"));
    const auto specFile = test::writeFile(dir / "spec.yaml", spec + "\n");
    const auto approximation = dir / "narrow.approx.yaml";
    REQUIRE(test::run(fmt::format("{} rigs/biped.yaml --spec {} -o {}", test::tool("rig-learn"), specFile.string(),
                                  approximation.string()))
                .exitCode == 0);
    const std::string map = (test::sourceDir() / "rigs/maps/cmu_to_biped.yaml").string();
    const std::string rigPath = (test::sourceDir() / "rigs/biped.yaml").string();
    const auto withRig = test::writeFile(
        dir / "with_rig.yaml", graphFile(rigPath, approximation, map) + fmt::format("    rig: {}\n", rigPath));
    const auto without = test::writeFile(dir / "without.yaml", graphFile(rigPath, approximation, map));
    const int count = parameterCount(approximation);
    const auto play = [&](const fs::path& graph, const std::string& name) {
        const auto r =
            test::run(fmt::format("{} {} --frames 1:240 --get inverter.status --get inverter.statusOnRealRig"
                                  "{} -o {}",
                                  test::tool("graph-eval"), graph.string(), valueGets(count), (dir / name).string()));
        INFO(r.err);
        REQUIRE(r.exitCode == 0);
        return YAML::LoadFile((dir / name).string());
    };
    const YAML::Node real = play(withRig, "with_rig.json"), approximated = play(without, "without.json");
    const auto invert =
        test::run(fmt::format("{} {} --rig rigs/biped.yaml --map {} --clip {} --frames 1:240 -o {} "
                              "--report-json {} -q",
                              test::tool("rig-invert"), approximation.string(), map, test::cmuClip.string(),
                              (dir / "curves.json").string(), (dir / "report.json").string()));
    REQUIRE(invert.exitCode == 3);
    checkSameCurves(dir / "with_rig.json", dir / "curves.json", 240, count);
    const YAML::Node report = YAML::LoadFile((dir / "report.json").string());
    const std::map<std::string, std::string> enumName{
        {"reached", "reached"}, {"best fit", "bestFit"}, {"model mismatch", "modelMismatch"}};
    int mismatches = 0;
    for (std::size_t f = 0; f < 240; ++f) {
        CAPTURE(f);
        const std::string status = report["per_frame"][f]["status"].as<std::string>();
        CHECK(real[f]["inverter.status"].as<std::string>() == enumName.at(status));
        CHECK(real[f]["inverter.statusOnRealRig"].as<bool>());
        CHECK(!approximated[f]["inverter.statusOnRealRig"].as<bool>());
        mismatches += status == "model mismatch";
    }
    CHECK(mismatches == 11);
    // The approximation cannot see its own gap to the rig: the same frame reads as a best fit.
    CHECK(real[191]["inverter.status"].as<std::string>() == "modelMismatch");
    CHECK(approximated[191]["inverter.status"].as<std::string>() == "bestFit");
}
