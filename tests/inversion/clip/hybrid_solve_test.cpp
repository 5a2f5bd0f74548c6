// Per-output modelling and the hybrid solve (docs/solver.md) on IK rigs: an IK arm with a pole control, and the
// biped's legs in IK mode (rigs/biped_inversion_ik.yaml). The learner leaves the IK joints unmodelled and keeps
// the root modelled where it composes; the hybrid solve recovers random reachable poses of the IK goal and pole
// from rest on the real rig; a goal out of reach is a miss, not converged.

#include <doctest/doctest.h>

#include <algorithm>
#include <filesystem>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "adapter/graph_rig_function.h"
#include "adapter/inversion_spec.h"
#include "core/rotation_math.h"
#include "inversion/clip/clip_inversion.h"
#include "inversion/clip/continuity.h"
#include "inversion/clip/hybrid_solve.h"
#include "inversion/ik_arm.h"
#include "inversion/learn/learner.h"
#include "inversion/model/approximation_io.h"
#include "nodes/clips/target_clip.h"
#include "test_support.h"

namespace rig {
namespace {

const ModelledParameter& parameter(const Approximation& a, const std::string& name)
{
    const auto it = std::find_if(a.parameters.begin(), a.parameters.end(),
                                 [&](const ModelledParameter& m) { return m.parameter.name == name; });
    REQUIRE_MESSAGE(it != a.parameters.end(), name << " is not modelled");
    return *it;
}

int output(const Approximation& a, const std::string& name)
{
    for (std::size_t k = 0; k < a.outputs.size(); ++k)
        if (a.outputs[k].name == name) return static_cast<int>(k);
    FAIL("no output " << name);
    return -1;
}

bool has(const std::vector<int>& list, int k) { return std::find(list.begin(), list.end(), k) != list.end(); }

std::vector<JointTarget> targetsFrom(const std::vector<Eigen::Matrix4d>& worlds)
{
    std::vector<JointTarget> targets(worlds.size());
    for (std::size_t k = 0; k < worlds.size(); ++k) {
        targets[k].active = true;
        targets[k].world = worlds[k];
    }
    return targets;
}

// Random poses of `moved` (offsets up to `range` cm from rest) solved from rest by the hybrid solve: every joint
// back on its target.
void recoverPoses(const Approximation& a, RigFunction& rig, const std::vector<std::string>& moved, double range)
{
    RigBinding binding(a, rig);
    const Solver solver(a, SolverOptions{});
    HybridSolver hybrid(solver, binding, 2);
    REQUIRE(hybrid.blocks().size() >= 1);
    std::mt19937 rng(5);
    std::vector<Eigen::Matrix4d> worlds;
    for (int pose = 0; pose < 6; ++pose) {
        CAPTURE(pose);
        std::vector<double> truth = a.defaults();
        for (std::size_t p = 0; p < a.parameters.size(); ++p)
            for (const std::string& prefix : moved)
                if (a.parameters[p].parameter.name.starts_with(prefix))
                    truth[p] += std::uniform_real_distribution<double>(-range, range)(rng);
        binding.evaluate(truth, worlds);
        const std::vector<JointTarget> targets = targetsFrom(worlds);
        std::vector<double> values = a.defaults();
        ChainScratch scratch;
        ChainFrame frame;
        hybrid.solveFrame(targets, values, retryNever, scratch, frame);
        CHECK(frame.realRigEvaluations > 0);
        CHECK(frame.summary.termination == TerminationType::converged);
        binding.evaluate(values, worlds);
        for (std::size_t k = 0; k < worlds.size(); ++k) {
            CAPTURE(a.outputs[k].name);
            CHECK((worlds[k].block<3, 1>(0, 3) - targets[k].world.block<3, 1>(0, 3)).norm() < 1e-4);
            CHECK(orientationAngle(worlds[k].topLeftCorner<3, 3>(), targets[k].world.topLeftCorner<3, 3>()) * 180.0 /
                      std::numbers::pi <
                  1e-3);
        }
    }
}

// The biped with IK legs, learned as rigs/biped_inversion_ik.yaml says (5 validation poses: quick).
struct IkBiped {
    static LearnOptions quick()
    {
        LearnOptions learn;
        learn.validationPoses = 5;
        return learn;
    }
    InversionSpec spec = readInversionSpec(test::sourceDir() / "rigs" / "biped_inversion_ik.yaml");
    GraphRigFunction rig{test::sourceDir() / "rigs" / "biped.yaml",
                         GraphRigOptions{spec.params, spec.outputs, {}, spec.set}};
    Approximation a = learnApproximation(rig, quick(), "rigs/biped.yaml");
};

}  // namespace

TEST_CASE("per-output modelling: an IK arm's joints are left unmodelled, the root stays modelled where it composes")
{
    const auto file = test::writeFile(test::scratchDir("hybrid-ik-arm") / "arm.yaml", test::ikArm);
    GraphRigFunction rig(file, test::ikArmOptions());
    const Approximation a = learnApproximation(rig, LearnOptions{}, "arm.yaml");
    CHECK(a.validation.withinEpsilon);
    CHECK(a.discarded.empty());
    CHECK(a.outputs[static_cast<std::size_t>(output(a, "clavicle"))].modelled);
    for (const char* joint : {"shoulder", "elbow", "wrist"}) {
        CAPTURE(joint);
        CHECK_FALSE(a.outputs[static_cast<std::size_t>(output(a, joint))].modelled);
    }
    const ModelledParameter& root = parameter(a, "root_ctrl.translateX");
    CHECK(root.outputs == std::vector<int>{output(a, "clavicle")});
    CHECK(has(root.unmodelledOutputs, output(a, "elbow")));
    const ModelledParameter& goal = parameter(a, "arm_ik_ctrl.translateY");
    CHECK(goal.outputs.empty());
    CHECK(goal.operators.empty());
    CHECK(has(goal.unmodelledOutputs, output(a, "wrist")));
    // Through a file and back.
    const Approximation b = approximationFromYaml(approximationToYaml(a), "arm.approx.yaml");
    CHECK(b.outputs[static_cast<std::size_t>(output(b, "wrist"))].modelled == false);
    CHECK(parameter(b, "root_ctrl.translateX").unmodelledOutputs == root.unmodelledOutputs);

    // The talk's behaviour on request: parameters discarded, every output modelled.
    LearnOptions talk;
    talk.perOutput = false;
    const Approximation c = learnApproximation(rig, talk, "arm.yaml");
    CHECK_FALSE(c.discarded.empty());
    CHECK_FALSE(c.hasUnmodelledOutputs());
}

TEST_CASE("hybrid solve: an IK arm recovers random reachable poses of its root, goal and pole from rest")
{
    const auto file = test::writeFile(test::scratchDir("hybrid-ik-arm-poses") / "arm.yaml", test::ikArm);
    GraphRigFunction rig(file, test::ikArmOptions());
    const Approximation a = learnApproximation(rig, LearnOptions{}, "arm.yaml");
    recoverPoses(a, rig, {"root_ctrl", "arm_ik_ctrl", "arm_pole_ctrl"}, 5.0);
}

TEST_CASE("hybrid solve: a goal out of the IK arm's reach is a miss, not converged")
{
    const auto file = test::writeFile(test::scratchDir("hybrid-ik-arm-reach") / "arm.yaml", test::ikArm);
    GraphRigFunction rig(file, test::ikArmOptions());
    const Approximation a = learnApproximation(rig, LearnOptions{}, "arm.yaml");
    RigBinding binding(a, rig);
    const Solver solver(a, SolverOptions{});
    HybridSolver hybrid(solver, binding, 1);
    std::vector<Eigen::Matrix4d> worlds;
    binding.evaluate(a.defaults(), worlds);
    std::vector<JointTarget> targets = targetsFrom(worlds);
    // The wrist 40 cm past the arm's 58 cm reach, along it.
    const int wrist = output(a, "wrist");
    targets[static_cast<std::size_t>(wrist)].world(0, 3) += 40.0;
    std::vector<double> values = a.defaults();
    ChainScratch scratch;
    ChainFrame frame;
    hybrid.solveFrame(targets, values, retryNever, scratch, frame);
    CHECK(frame.summary.termination == TerminationType::stuck);
    CHECK(has(frame.summary.missedOutputs, wrist));
    CHECK(frame.summary.maxPositionErrorCm > 1.0);
}

TEST_CASE("hybrid solve: the biped's IK legs (rigs/biped_inversion_ik.yaml) recover random poses from rest")
{
    IkBiped biped;
    const Approximation& a = biped.a;
    GraphRigFunction& rig = biped.rig;
    CHECK(a.validation.withinEpsilon);
    CHECK(a.discarded.empty());
    // The root composes on the hips and the spine, not on the IK legs.
    const ModelledParameter& root = parameter(a, "root_ctrl.translateY");
    CHECK(has(root.outputs, output(a, "Hips")));
    CHECK(has(a.reach()[static_cast<std::size_t>(&root - a.parameters.data())], output(a, "Spine")));
    for (const char* joint : {"LeftUpLeg", "LeftLeg", "RightFoot"}) {
        CAPTURE(joint);
        CHECK(has(root.unmodelledOutputs, output(a, joint)));
    }
    CHECK(parameter(a, "L_leg_pole_ctrl.translateX").outputs.empty());
    recoverPoses(a, rig, {"root_ctrl.translate", "L_leg_ik_ctrl", "R_leg_ik_ctrl", "L_leg_pole", "R_leg_pole"}, 4.0);
}

TEST_CASE("hybrid solve: the biped's straight IK legs, from rest and along a warm-started walk")
{
    IkBiped biped;
    const Approximation& a = biped.a;
    GraphRigFunction& rig = biped.rig;
    RigBinding binding(a, rig);
    const Solver solver(a, SolverOptions{});
    HybridSolver hybrid(solver, binding, 2);
    const auto index = [&](const std::string& name) {
        return static_cast<std::size_t>(&parameter(a, name) - a.parameters.data());
    };
    // The rest pose carried by the root (the IK goals with it): straight legs, each knee at full extension, where
    // it bends as the square root of the goal's approach (a T-pose frame of a clip).
    const auto carried = [&](double x, double y, double z) {
        std::vector<double> values = a.defaults();
        for (const auto& [axis, offset] : {std::pair{"X", x}, std::pair{"Y", y}, std::pair{"Z", z}}) {
            values[index(std::string("root_ctrl.translate") + axis)] += offset;
            values[index(std::string("L_leg_ik_ctrl.translate") + axis)] += offset;
            values[index(std::string("R_leg_ik_ctrl.translate") + axis)] += offset;
        }
        return values;
    };
    std::vector<Eigen::Matrix4d> worlds;
    const auto check = [&](const std::vector<double>& truth, const std::vector<double>& values) {
        binding.evaluate(truth, worlds);
        const std::vector<Eigen::Matrix4d> expected = worlds;
        binding.evaluate(values, worlds);
        for (std::size_t k = 0; k < worlds.size(); ++k) {
            CAPTURE(a.outputs[k].name);
            CHECK((worlds[k].block<3, 1>(0, 3) - expected[k].block<3, 1>(0, 3)).norm() < 1e-3);  // targetTolerance
        }
    };
    ChainScratch scratch;
    ChainFrame frame;
    const std::vector<double> tPose = carried(40.0, 3.0, -70.0);
    binding.evaluate(tPose, worlds);
    std::vector<double> values = a.defaults();
    hybrid.solveFrame(targetsFrom(worlds), values, retryNever, scratch, frame);
    CHECK(frame.summary.termination == TerminationType::converged);
    check(tPose, values);

    // A walk: the root moves forward 1 cm a frame and sinks 1 cm while the left foot stays planted (its knee bends)
    // and the right foot steps forward and up; each frame warm-started from the previous one.
    double previousCost = frame.summary.finalCost;
    for (int f = 1; f <= 10; ++f) {
        CAPTURE(f);
        std::vector<double> truth = carried(40.0, 3.0 - 1.0 * f, -70.0 + 1.0 * f);
        truth[index("L_leg_ik_ctrl.translateZ")] -= 1.0 * f;
        truth[index("L_leg_ik_ctrl.translateY")] += 1.0 * f;
        truth[index("R_leg_ik_ctrl.translateZ")] += 1.5 * f;
        truth[index("R_leg_ik_ctrl.translateY")] += 1.0 * f;
        binding.evaluate(truth, worlds);
        hybrid.solveFrame(targetsFrom(worlds), values, previousCost, scratch, frame);
        CHECK(frame.summary.termination == TerminationType::converged);
        check(truth, values);
        previousCost = frame.summary.finalCost;
    }
}

TEST_CASE("hybrid solve: the biped's IK legs follow CMU 01_01 where its FK legs do, within 0.1 cm")
{
    // The T-pose frame (straight legs: each IK knee at full extension) and frames 1775 to 1782, where the
    // approximation's answer moves the root far from where the legs want it: the leg joints of the IK solve within
    // 0.1 cm of the FK solve's (the IK knee is the FK knee, rigs/biped.yaml), in invertClip's warm-start chains.
    const std::filesystem::path clipFile = "/usr/share/assimp/models/BVH/01_01.bvh";
    if (!std::filesystem::exists(clipFile)) {
        MESSAGE("[skipped] " << clipFile.string() << " is absent (Debian package assimp-testmodels)");
        return;
    }
    const auto rigFile = test::sourceDir() / "rigs" / "biped.yaml";
    const TargetClip clip =
        readTargetClip(clipFile, readTargetMap(test::sourceDir() / "rigs" / "maps" / "cmu_to_biped.yaml"));
    const auto solveLegs = [&](const char* specName, bool hybridSolve, int first, int last) {
        const InversionSpec spec = readInversionSpec(test::sourceDir() / "rigs" / specName);
        GraphRigFunction rig(rigFile, GraphRigOptions{spec.params, spec.outputs, {}, spec.set});
        LearnOptions learn;
        learn.validationPoses = 5;
        const Approximation a = learnApproximation(rig, learn, "rigs/biped.yaml");
        const ClipTargets targets = matchTargets(a, clip.joints, clip.worlds);
        RigBinding binding(a, rig);
        const Solver solver(a, SolverOptions{});
        HybridSolver hybrid(solver, binding, 2);
        ChainScratch scratch;
        ClipInversionOptions options;
        if (hybridSolve)
            options.frameSolve = [&](std::span<const JointTarget> t, std::vector<double>& values, double previousCost,
                                     ChainFrame& frame) { hybrid.solveFrame(t, values, previousCost, scratch, frame); };
        std::vector<std::vector<double>> values;
        invertClip(solver, binding, targets, first, last, options, values);
        std::vector<std::vector<Eigen::Vector3d>> legs;  // per frame, the leg joints' positions
        std::vector<Eigen::Matrix4d> worlds;
        for (const auto& frameValues : values) {
            binding.evaluate(frameValues, worlds);
            legs.emplace_back();
            for (const char* joint : {"LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "RightUpLeg", "RightLeg",
                                      "RightFoot", "RightToeBase"})
                legs.back().push_back(worlds[static_cast<std::size_t>(output(a, joint))].block<3, 1>(0, 3));
        }
        return legs;
    };
    for (const auto& [first, last] : {std::pair{0, 1}, std::pair{1774, 1781}}) {
        const auto fk = solveLegs("biped_inversion.yaml", false, first, last);
        const auto ik = solveLegs("biped_inversion_ik.yaml", true, first, last);
        REQUIRE(fk.size() == ik.size());
        for (std::size_t f = 0; f < fk.size(); ++f)
            for (std::size_t j = 0; j < fk[f].size(); ++j) {
                CAPTURE(first + static_cast<int>(f));
                CAPTURE(j);
                CHECK((fk[f][j] - ik[f][j]).norm() < 0.1);
            }
    }
}

TEST_CASE("hybrid solve: whole turns of a periodic control come back within half a turn where the pose is the same")
{
    // What the hybrid solve does after its real-rig stage (HybridSolver::keepNearReference): the values carried
    // toward the frame before (or the guess) by checkedContinuityShift, checked on the real rig.
    const auto file = test::writeFile(test::scratchDir("hybrid-ik-arm-turns") / "arm.yaml", test::ikArm);
    GraphRigOptions options = test::ikArmOptions();
    options.parameterGlobs.push_back("root_ctrl.rotateY");
    GraphRigFunction rig(file, options);
    const Approximation a = learnApproximation(rig, LearnOptions{}, "arm.yaml");
    RigBinding binding(a, rig);
    const Solver solver(a, SolverOptions{});
    const auto turn = static_cast<std::size_t>(&parameter(a, "root_ctrl.rotateY") - a.parameters.data());
    const auto goal = static_cast<std::size_t>(&parameter(a, "arm_ik_ctrl.translateX") - a.parameters.data());
    const Equivalences& e = solver.equivalences();
    REQUIRE(e.period[turn] == doctest::Approx(2.0 * std::numbers::pi));
    const auto blocks = hybridBlocks(a);
    REQUIRE(std::any_of(blocks.begin(), blocks.end(), [&](const HybridBlock& b) {
        return has(b.parameters, static_cast<int>(turn));  // the root's turn moves the IK arm, not modelled
    }));

    std::vector<double> reference = a.defaults();
    reference[turn] += 0.4;
    reference[goal] += 3.0;
    std::vector<double> values = reference;
    values[turn] += 3.0 * e.period[turn];  // wound three turns onto the same pose
    values[goal] += 0.5;                   // and a translation, which has no period
    std::vector<Eigen::Matrix4d> before, after;
    binding.evaluate(values, before);
    PoseCheck samePose(a, &binding);
    applyShift(e, checkedContinuityShift(e, reference, values, &samePose), values, values);
    CHECK(samePose.realRigEvaluations() == 2);
    CHECK(values[turn] == doctest::Approx(reference[turn]).epsilon(1e-12));
    CHECK(values[goal] == reference[goal] + 0.5);
    binding.evaluate(values, after);
    for (std::size_t k = 0; k < after.size(); ++k) CHECK((after[k] - before[k]).cwiseAbs().maxCoeff() < 1e-9);
    // Within half a turn already: nothing to take back, nothing evaluated.
    values[turn] += 0.45 * e.period[turn];
    const std::vector<double> within = values;
    applyShift(e, checkedContinuityShift(e, reference, values, &samePose), values, values);
    CHECK(values == within);
    CHECK(samePose.realRigEvaluations() == 2);
}

}  // namespace rig
