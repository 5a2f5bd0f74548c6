// The bundled rigs: they load, evaluate and pass checked mode at random control values; the biped
// has what docs/rigs.md says; the nasty rig's constructions behave as its table claims.
#include <doctest/doctest.h>

#include <numbers>
#include <random>
#include <set>
#include <tuple>

#include <fmt/format.h>
#include <Eigen/LU>

#include "graph/plug_glob.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "nodes/clips/bvh.h"
#include "test_support.h"

using namespace rig;

namespace {

std::unique_ptr<Graph> loadRig(const std::string& relative)
{
    return loadGraphFile(test::sourceDir() / relative, makeBuiltinRegistry());
}

Eigen::Matrix4d world(Graph& g, const std::string& joint)
{
    return std::get<Eigen::Matrix4d>(g.getValue(g.plug(joint + ".worldMatrix")));
}

void set(Graph& g, const std::string& plug, double userValue)
{
    const Plug p = g.plug(plug);
    g.setValue(p, userValue * unitFactor(Unit::None, g.spec(p).unit));
}

// Every unconnected keyable input of every control (*_ctrl) set to a random value within its
// limits (or a documented range: +-60 degrees, +-20 cm, scale 0.5..2).
void randomPose(Graph& g, std::mt19937& rng)
{
    for (const Plug& p : allPlugs(g)) {
        const AttributeSpec& spec = g.spec(p);
        const std::string& node = g.nodeName(p.node);
        if (!spec.input || !spec.keyable || !node.ends_with("_ctrl") || g.incomingConnection(p) != nullptr) continue;
        if (g.plugType(p) != ValueType::Double) continue;
        double lo = spec.unit == Unit::Angle ? -60.0 * std::numbers::pi / 180 : -20.0;
        double hi = -lo;
        if (spec.name == "scale") {
            lo = 0.5;
            hi = 2.0;
        }
        if (spec.min) lo = *spec.min;
        if (spec.max) hi = *spec.max;
        g.setValue(p, std::uniform_real_distribution<double>(lo, hi)(rng));
    }
}

}  // namespace

TEST_CASE("bundled rigs load, evaluate at random control values, and pass checked mode")
{
    for (const char* file : {"rigs/examples/arm.yaml", "rigs/biped.yaml", "rigs/nasty.yaml"}) {
        CAPTURE(file);
        auto g = loadRig(file);
        std::mt19937 rng(3);
        for (int round = 0; round < 3; ++round) {
            randomPose(*g, rng);
            g->setTime(1 + round);
            CHECK(g->checkEvaluation().empty());
            for (const Plug& p : allPlugs(*g))
                if (!g->spec(p).input && p.child < 0) REQUIRE(isFinite(g->getValue(p)));
        }
    }
}

TEST_CASE("biped: 60+ joints, the 150 animator parameters of docs/rigs.md, 79 of them for inversion")
{
    auto g = loadRig("rigs/biped.yaml");
    int joints = 0;
    for (NodeId n = 0; n < g->nodeCount(); ++n) joints += g->nodeType(n).name() == "joint";
    CHECK(joints == 86);

    const std::vector<std::string> inversion{
        "root_ctrl.translate?",       "root_ctrl.rotate?",          "[LR]_hip_ctrl.rotate?",
        "[LR]_upLeg_fk_ctrl.rotate?", "[LR]_knee_fk_ctrl.rotateX",  "[LR]_foot_fk_ctrl.rotate?",
        "[LR]_toe_ctrl.rotate?",      "spine_ctrl.bend*",           "spine_ctrl.twist",
        "lowerBack_ctrl.rotate?",     "chest_ctrl.rotate?",         "neck_ctrl.rotate?",
        "head_ctrl.rotate?",          "[LR]_clavicle_ctrl.rotate?", "[LR]_arm_fk_ctrl.rotate?",
        "[LR]_elbow_ctrl.rotate?",    "[LR]_wrist_ctrl.rotate?",    "[LR]_hand_ctrl.fist",
        "[LR]_thumb_ctrl.rotate?"};
    const std::vector<std::string> others{"world_ctrl.translate?",
                                          "world_ctrl.rotate?",
                                          "world_ctrl.scale?",
                                          "[LR]_leg_ik_ctrl.translate?",
                                          "[LR]_leg_pole_ctrl.translate?",
                                          "[LR]_leg_settings.ikFk",
                                          "*_ctrl.stretch",
                                          "*_ctrl.squash",
                                          "[LR]_hand_ctrl.spread",
                                          "[LR]_hand_ctrl.*Curl",
                                          "[LR]_index_ctrl.rotate?",
                                          "[LR]_middle_ctrl.rotate?",
                                          "[LR]_ring_ctrl.rotate?",
                                          "[LR]_pinky_ctrl.rotate?",
                                          "jaw_ctrl.open",
                                          "eyes_ctrl.translate?"};
    auto count = [&](const std::vector<std::string>& globs) {
        std::set<Plug> plugs;
        for (const auto& glob : globs)
            for (const Plug& p : matchPlugs(*g, glob)) {
                const std::string name = g->plugName(p);
                CAPTURE(name);
                CHECK(g->incomingConnection(p) == nullptr);  // a parameter is a free channel
                CHECK((g->spec(p).keyable || p.child >= 0));
                plugs.insert(p);
            }
        return plugs.size();
    };
    CHECK(count(inversion) == 79);
    CHECK(count(others) == 71);

    // Every inversion parameter moves a CMU joint (the leaves see every joint above them).
    auto leaves = [&] {
        Eigen::Matrix4d sum = Eigen::Matrix4d::Zero();
        for (const char* j : {"LeftHand", "RightHand", "LeftToeBase", "RightToeBase", "Head", "LFingers", "RFingers",
                              "LThumb", "RThumb"})
            sum += world(*g, j);
        return sum;
    };
    for (const auto& glob : inversion)
        for (const Plug& p : matchPlugs(*g, glob)) {
            const std::string name = g->plugName(p);
            CAPTURE(name);
            const Eigen::Matrix4d before = leaves();
            const Value old = g->getValue(p);
            g->setValue(p, toDouble(old) + 0.3);
            CHECK((leaves() - before).norm() > 1e-6);
            g->setValue(p, old);
        }
}

TEST_CASE("biped: the rest pose is the CMU skeleton in centimetres")
{
    const auto clipFile = std::filesystem::path("/usr/share/assimp/models/BVH/01_01.bvh");
    if (!std::filesystem::exists(clipFile)) {
        MESSAGE("[skipped] " << clipFile << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    const BvhClip clip = readBvhFile(clipFile);
    std::vector<double> rest(static_cast<std::size_t>(clip.channelCount), 0.0);
    const auto cmu = bvhWorldMatrices(clip, rest);
    auto g = loadRig("rigs/biped.yaml");
    const double cm = 2.54 / 0.45;
    for (std::size_t j = 0; j < clip.joints.size(); ++j) {
        CAPTURE(clip.joints[j].name);
        const Eigen::Matrix4d m = world(*g, clip.joints[j].name);
        CHECK((m.block<3, 1>(0, 3) - cm * cmu[j].block<3, 1>(0, 3)).norm() < 1e-6);
        CHECK((m.block<3, 3>(0, 0) - Eigen::Matrix3d::Identity()).norm() < 1e-12);
    }
}

TEST_CASE("biped: the leg IK reaches its goal in IK mode, FK is the default")
{
    auto g = loadRig("rigs/biped.yaml");
    const Eigen::Vector3d restFoot = world(*g, "LeftFoot").block<3, 1>(0, 3);
    g->setValue(g->plug("L_leg_ik_ctrl.translate"), Eigen::Vector3d(15, -60, 20));
    CHECK((world(*g, "LeftFoot").block<3, 1>(0, 3) - restFoot).norm() < 1e-9);  // FK: the IK goal does nothing
    set(*g, "L_leg_settings.ikFk", 1);
    CHECK((world(*g, "LeftFoot").block<3, 1>(0, 3) - Eigen::Vector3d(15, -60, 20)).norm() < 1e-9);
}

TEST_CASE("nasty rig: each construction behaves as docs/rigs.md says")
{
    auto g = loadRig("rigs/nasty.yaml");
    const Eigen::Matrix4d restTip = world(*g, "coupled_tip");

    SUBCASE("coupledTurn alone does nothing, yet changes what coupledBend does")
    {
        set(*g, "nasty_ctrl.coupledTurn", 40);
        CHECK((world(*g, "coupled_tip") - restTip).norm() < 1e-12);
        set(*g, "nasty_ctrl.coupledBend", 30);
        const Eigen::Matrix4d turned = world(*g, "coupled_tip");
        set(*g, "nasty_ctrl.coupledTurn", 0);
        CHECK((world(*g, "coupled_tip") - turned).norm() > 1.0);
    }
    SUBCASE("saturated does nothing past 30 degrees")
    {
        set(*g, "nasty_ctrl.saturated", 45);
        const Eigen::Matrix4d at45 = world(*g, "saturated_tip");
        set(*g, "nasty_ctrl.saturated", 80);
        CHECK((world(*g, "saturated_tip") - at45).norm() == 0.0);
        set(*g, "nasty_ctrl.saturated", 20);
        CHECK((world(*g, "saturated_tip") - at45).norm() > 1.0);
    }
    SUBCASE("redundantA and redundantB have the same effect")
    {
        set(*g, "nasty_ctrl.redundantA", 25);
        const Eigen::Matrix4d a = world(*g, "redundant_tip");
        set(*g, "nasty_ctrl.redundantA", 0);
        set(*g, "nasty_ctrl.redundantB", 25);
        CHECK((world(*g, "redundant_tip") - a).norm() < 1e-12);
    }
    SUBCASE("springy is history-dependent: the same value evaluates differently")
    {
        world(*g, "springy_tip");
        set(*g, "nasty_ctrl.springy", 5);
        const Eigen::Matrix4d first = world(*g, "springy_tip");
        g->dirtyAll();
        CHECK((world(*g, "springy_tip") - first).norm() > 1e-6);
    }
    SUBCASE("wristTwist rotates the roll joints by 33 and 66 percent of the wrist")
    {
        set(*g, "nasty_ctrl.wristTwist", 60);
        const auto angleOf = [&](const char* joint) {
            const Eigen::Matrix3d r = world(*g, joint).block<3, 3>(0, 0);
            return std::atan2(r(2, 1), r(1, 1)) * 180 / std::numbers::pi;
        };
        CHECK(angleOf("wrist") == doctest::Approx(60));
        CHECK(angleOf("forearm_roll1") == doctest::Approx(0.33 * 60));
        CHECK(angleOf("forearm_roll2") == doctest::Approx(0.66 * 60));
    }
    SUBCASE("kneeBend is not a rotation about a fixed pivot")
    {
        // The fixed point of the ankle's world delta moves with the angle.
        const Eigen::Matrix4d rest = world(*g, "ankle");
        auto pivotZ = [&](double degrees) {
            set(*g, "nasty_ctrl.kneeBend", degrees);
            const Eigen::Matrix4d d = world(*g, "ankle") * rest.inverse();
            // Rotation about X: solve (I - R) p = t in the y-z plane.
            const Eigen::Matrix2d a = Eigen::Matrix2d::Identity() - d.block<2, 2>(1, 1);
            return Eigen::Vector2d(a.inverse() * d.block<2, 1>(1, 3));
        };
        CHECK((pivotZ(30) - pivotZ(90)).norm() > 0.5);
    }
}

TEST_CASE("generated rigs: a crowd includes the biped once per member, a chain has N joints")
{
    const auto dir = test::scratchDir("generated-rigs");
    const auto script = test::sourceDir() / "scripts" / "make_rigs.py";
    const auto result =
        test::run(fmt::format("python3 '{}' crowd 3 --rig '{}' -o '{}' && python3 '{}' chain 50 -o '{}'",
                              script.string(), (test::sourceDir() / "rigs" / "biped.yaml").string(),
                              (dir / "crowd.yaml").string(), script.string(), (dir / "chain.yaml").string()));
    REQUIRE(result.exitCode == 0);
    const auto biped = loadRig("rigs/biped.yaml");
    const auto crowd = loadGraphFile(dir / "crowd.yaml", makeBuiltinRegistry());
    CHECK(crowd->nodeCount() == 3 * biped->nodeCount());
    CHECK(crowd->findNode("biped0003:LeftHand") >= 0);
    const auto chain = loadGraphFile(dir / "chain.yaml", makeBuiltinRegistry());
    CHECK(chain->nodeCount() == 50);
    CHECK(world(*chain, "chain00050")(0, 3) == doctest::Approx(490));
}

TEST_CASE("rigs/biped.yaml is what scripts/make_rigs.py generates")
{
    const auto dir = test::scratchDir("biped-generated");
    const auto result =
        test::run(fmt::format("python3 scripts/make_rigs.py biped -o '{}' && cmp -s '{}' rigs/biped.yaml",
                              (dir / "biped.yaml").string(), (dir / "biped.yaml").string()));
    CHECK(result.exitCode == 0);
}

TEST_CASE("rigs/biped_long_legs.yaml is make_rigs.py's biped with thighs, shins and feet 15% longer, IK and FK alike")
{
    const auto dir = test::scratchDir("biped-long-legs-generated");
    const auto result = test::run(fmt::format(
        "python3 scripts/make_rigs.py biped --leg-scale 1.15 -o '{}' && cmp -s '{}' rigs/biped_long_legs.yaml",
        (dir / "long.yaml").string(), (dir / "long.yaml").string()));
    CHECK(result.exitCode == 0);
    auto biped = loadRig("rigs/biped.yaml");
    auto longLegs = loadRig("rigs/biped_long_legs.yaml");
    const auto length = [](Graph& g, const char* from, const char* to) {
        return (world(g, to).block<3, 1>(0, 3) - world(g, from).block<3, 1>(0, 3)).norm();
    };
    for (const auto& [from, to, factor] : {std::tuple{"LeftUpLeg", "LeftLeg", 1.15},
                                           {"LeftLeg", "LeftFoot", 1.15},
                                           {"LeftFoot", "LeftToeBase", 1.15},
                                           {"RightUpLeg", "RightLeg", 1.15},
                                           {"RightLeg", "RightFoot", 1.15},
                                           {"RightFoot", "RightToeBase", 1.15},
                                           {"LHipJoint", "LeftUpLeg", 1.0},
                                           {"LeftArm", "LeftForeArm", 1.0},
                                           {"Spine", "Spine1", 1.0}}) {
        CAPTURE(to);
        CHECK(length(*longLegs, from, to) == doctest::Approx(factor * length(*biped, from, to)).epsilon(1e-9));
    }
    // The IK legs at rest are the FK legs, as on the biped: the goals, poles and IK handles are scaled with them.
    const Eigen::Vector3d fk = world(*longLegs, "LeftFoot").block<3, 1>(0, 3);
    set(*longLegs, "L_leg_settings.ikFk", 1.0);
    CHECK((world(*longLegs, "LeftFoot").block<3, 1>(0, 3) - fk).norm() < 1e-9);
}
