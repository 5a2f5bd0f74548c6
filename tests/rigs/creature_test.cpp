// rigs/creature.yaml, the hand-written creature (docs/rigs.md): it loads, evaluates at random control values
// in checked mode, its switches, reverse feet and shared spine behave as the file says, its FK spec learns
// within epsilon and random poses invert back onto the real rig; its IK spec learns with the IK limbs
// reported, with its forearm twist joints twist shares of the IK hands, and scripts/random_poses.py makes a clip
// rig-invert inverts.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <random>
#include <set>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "adapter/graph_rig_function.h"
#include "adapter/inversion_spec.h"
#include "graph/plug_glob.h"
#include "graph/yaml_loader.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/learn/learner.h"
#include "inversion/solve/equivalences.h"
#include "inversion/solve/solver.h"
#include "nodes/builtin_nodes.h"
#include "test_support.h"

using namespace rig;

namespace {

const double degree = std::numbers::pi / 180;

std::unique_ptr<Graph> loadCreature()
{
    return loadGraphFile(test::sourceDir() / "rigs/creature.yaml", makeBuiltinRegistry());
}

Eigen::Matrix4d world(Graph& g, const std::string& joint)
{
    return std::get<Eigen::Matrix4d>(g.getValue(g.plug(joint + ".worldMatrix")));
}

Eigen::Vector3d position(Graph& g, const std::string& joint) { return world(g, joint).block<3, 1>(0, 3); }

void set(Graph& g, const std::string& plug, double userValue)
{
    const Plug p = g.plug(plug);
    g.setValue(p, userValue * unitFactor(Unit::None, g.spec(p).unit));
}

double degrees(Graph& g, const std::string& plug) { return std::get<double>(g.getValue(g.plug(plug))) / degree; }

std::vector<std::string> joints(const Graph& g)
{
    std::vector<std::string> names;
    for (NodeId n = 0; n < g.nodeCount(); ++n)
        if (g.nodeType(n).name() == "joint") names.push_back(g.nodeName(n));
    return names;
}

// Every free keyable number input of every control (*_ctrl) at a random value within its limits, or
// +-60 degrees, +-20 cm about its rest value: the ikFk switches too, so both modes and their blends are seen.
void randomPose(Graph& g, std::mt19937& rng)
{
    for (const Plug& p : allPlugs(g)) {
        const AttributeSpec& spec = g.spec(p);
        if (!spec.input || !spec.keyable || !g.nodeName(p.node).ends_with("_ctrl")) continue;
        if (g.incomingConnection(p) != nullptr || g.plugType(p) != ValueType::Double) continue;
        const double rest = std::get<double>(g.getValue(p));
        const double reach = spec.unit == Unit::Angle ? 60 * degree : 20.0;
        const double lo = spec.min ? *spec.min : rest - reach;
        const double hi = spec.max ? *spec.max : rest + reach;
        g.setValue(p, std::uniform_real_distribution<double>(lo, hi)(rng));
    }
}

InversionSpec spec(const char* file) { return readInversionSpec(test::sourceDir() / "rigs" / file); }

GraphRigFunction creatureRig(const InversionSpec& s)
{
    return GraphRigFunction(test::sourceDir() / "rigs/creature.yaml", {s.params, s.outputs, {}, s.set});
}

const ModelledParameter& modelled(const Approximation& a, const std::string& name)
{
    const auto found = std::find_if(a.parameters.begin(), a.parameters.end(),
                                    [&](const ModelledParameter& m) { return m.parameter.name == name; });
    REQUIRE_MESSAGE(found != a.parameters.end(), "not modelled: " << name);
    return *found;
}

int indexOf(const Approximation& a, const std::string& name)
{
    for (std::size_t i = 0; i < a.parameters.size(); ++i)
        if (a.parameters[i].parameter.name == name) return static_cast<int>(i);
    return -1;
}

// The IK spec learned as rig-learn learns it (helpers found in the rig): the arms and legs planar chains on their
// goals and poles. Learned once per process, with the rig it was learned on (for RigBinding).
struct IkCreature {
    std::unique_ptr<GraphRigFunction> rig;
    Approximation approximation;
};

const IkCreature& ikCreature()
{
    static const IkCreature creature = [] {
        const InversionSpec s = spec("creature_inversion_ik.yaml");
        GraphRigOptions options{s.params, s.outputs, {}, s.set};
        options.autoHelpers = true;
        IkCreature c;
        c.rig = std::make_unique<GraphRigFunction>(test::sourceDir() / "rigs/creature.yaml", options);
        c.approximation = learnApproximation(*c.rig, LearnOptions{}, "rigs/creature.yaml");
        return c;
    }();
    return creature;
}

// Every parameter within 60% of its range, as scripts/random_poses.py draws them.
std::vector<double> randomPoseValues(const Approximation& a, std::mt19937& rng)
{
    std::vector<double> values;
    for (const auto& m : a.parameters) {
        const RigParameter& p = m.parameter;
        const double mid = 0.5 * (p.min + p.max), half = 0.3 * (p.max - p.min);
        values.push_back(std::uniform_real_distribution<double>(mid - half, mid + half)(rng));
    }
    return values;
}

// The largest distance between the origins of two sets of worlds over the active targets, cm.
double farthestCm(const std::vector<JointTarget>& targets, const std::vector<Eigen::Matrix4d>& a,
                  const std::vector<Eigen::Matrix4d>& b)
{
    double cm = 0.0;
    for (std::size_t k = 0; k < targets.size(); ++k)
        if (targets[k].active) cm = std::max(cm, (a[k].block<3, 1>(0, 3) - b[k].block<3, 1>(0, 3)).norm());
    return cm;
}

// Targets at `worlds` on every modelled output but the helpers (never targets): the legs and claw tips too.
std::vector<JointTarget> jointTargets(const Approximation& a, const std::vector<Eigen::Matrix4d>& worlds)
{
    std::vector<JointTarget> targets(worlds.size());
    for (std::size_t k = 0; k < worlds.size(); ++k) {
        targets[k].active = a.outputs[k].modelled && !a.outputs[k].helper;
        targets[k].world = worlds[k];
    }
    return targets;
}

// A random pose (randomPoseValues) set on the real rig, every joint a target, solved on the approximation from its
// initial guess (checked converged): the values set, the targets, the real rig's worlds at them, the answer and the
// real rig's worlds at it.
struct RealPose {
    std::vector<double> known;
    std::vector<JointTarget> targets;
    std::vector<Eigen::Matrix4d> worlds;
    std::vector<double> values;
    std::vector<Eigen::Matrix4d> solved;
};

RealPose solveRealPose(const Approximation& a, const Solver& solver, RigBinding& binding, std::mt19937& rng)
{
    RealPose pose;
    pose.known = randomPoseValues(a, rng);
    binding.evaluate(pose.known, pose.worlds);
    pose.targets = jointTargets(a, pose.worlds);
    pose.values = a.defaults();
    REQUIRE(solver.initialGuess(pose.targets, pose.values) == TerminationType::converged);
    const SolveSummary summary = solver.solve(pose.targets, pose.values);
    CAPTURE(summary.briefReport());
    CHECK(summary.converged());
    binding.evaluate(pose.values, pose.solved);
    return pose;
}

}  // namespace

TEST_CASE("creature: 47 joints, every control a free keyable plug on a *_ctrl, checked mode at random values")
{
    auto g = loadCreature();
    CHECK(joints(*g).size() == 47);
    // Both specs' parameters are animator controls: free keyable scalar plugs of *_ctrl transforms.
    for (const char* file : {"creature_inversion.yaml", "creature_inversion_ik.yaml"}) {
        std::set<Plug> plugs;
        for (const auto& glob : spec(file).params)
            for (const Plug& p : matchPlugs(*g, glob)) {
                const std::string name = g->plugName(p);
                CAPTURE(name);
                CHECK(g->nodeName(p.node).ends_with("_ctrl"));
                CHECK(g->nodeType(p.node).name() == "transform");
                CHECK(g->incomingConnection(p) == nullptr);
                CHECK((g->spec(p).keyable || p.child >= 0));
                plugs.insert(p);
            }
        CAPTURE(file);
        CHECK(plugs.size() == 85);
    }
    std::mt19937 rng(5);
    for (int round = 0; round < 4; ++round) {
        randomPose(*g, rng);
        CHECK(g->checkEvaluation().empty());
        for (const std::string& joint : joints(*g)) REQUIRE(world(*g, joint).allFinite());
    }
}

TEST_CASE("creature: IK at rest is the FK rest pose, the goals are reached, the reverse foot rolls on its pivots")
{
    auto g = loadCreature();
    std::vector<Eigen::Matrix4d> rest;
    for (const std::string& joint : joints(*g)) rest.push_back(world(*g, joint));
    for (const char* limb : {"L_arm", "R_arm", "L_leg", "R_leg"})
        set(*g, fmt::format("{}_settings_ctrl.ikFk", limb), 1);
    const std::vector<std::string> names = joints(*g);
    for (std::size_t j = 0; j < names.size(); ++j) {
        CAPTURE(names[j]);
        CHECK((world(*g, names[j]) - rest[j]).norm() < 1e-9);
    }

    g->setValue(g->plug("L_arm_ik_ctrl.translate"), Eigen::Vector3d(38, 120, 25));
    CHECK((position(*g, "L_hand") - Eigen::Vector3d(38, 120, 25)).norm() < 1e-9);

    // roll 0..5 lifts the heel about the ball: the ball and the toes stay planted, the ankle rises.
    const Eigen::Vector3d ankle = position(*g, "L_ankle"), ball = position(*g, "L_ball"),
                          toe = position(*g, "L_toe_end");
    set(*g, "L_foot_ik_ctrl.roll", 5);
    CHECK((position(*g, "L_ball") - ball).norm() < 1e-9);
    CHECK((position(*g, "L_toe_end") - toe).norm() < 1e-9);
    CHECK(position(*g, "L_ankle").y() > ankle.y() + 3);
    // 5..10 rolls onto the toe tip: only the toes stay planted.
    set(*g, "L_foot_ik_ctrl.roll", 10);
    CHECK((position(*g, "L_toe_end") - toe).norm() < 1e-9);
    CHECK(position(*g, "L_ball").y() > ball.y() + 3);
    // Below 0 the foot rocks back on its heel: the toes rise.
    set(*g, "L_foot_ik_ctrl.roll", -10);
    CHECK(position(*g, "L_toe_end").y() > toe.y() + 5);
    // In FK the reverse foot does nothing.
    set(*g, "L_leg_settings_ctrl.ikFk", 0);
    CHECK((position(*g, "L_toe_end") - toe).norm() < 1e-9);
}

TEST_CASE("creature: the spine bend is shared by four joints, spine4 adds the chest control to its share")
{
    auto g = loadCreature();
    set(*g, "spine_ctrl.bendForward", 40);
    CHECK(degrees(*g, "spine1.rotateX") == doctest::Approx(8));
    CHECK(degrees(*g, "spine2.rotateX") == doctest::Approx(10));
    CHECK(degrees(*g, "spine3.rotateX") == doctest::Approx(10));
    CHECK(degrees(*g, "spine4.rotateX") == doctest::Approx(12));
    set(*g, "chest_ctrl.rotateX", 30);
    CHECK(degrees(*g, "spine4.rotateX") == doctest::Approx(42));

    // The chest's rotate order is zxy, R = Ry Rx Rz: (x, y, z) and (180 - x, y + 180, z + 180) are one
    // rotation. Alone on spine4 the two are one pose; with the bend's share added first they are not.
    const auto head = [&](double x, double y, double z) {
        set(*g, "chest_ctrl.rotateX", x);
        set(*g, "chest_ctrl.rotateY", y);
        set(*g, "chest_ctrl.rotateZ", z);
        return world(*g, "head");
    };
    set(*g, "spine_ctrl.bendForward", 0);
    CHECK((head(30, 50, 20) - head(150, 230, 200)).norm() < 1e-9);
    set(*g, "spine_ctrl.bendForward", 40);
    CHECK((head(30, 50, 20) - head(150, 230, 200)).block<3, 1>(0, 3).norm() > 1.0);
}

TEST_CASE(
    "learning the creature's FK spec: all 85 parameters within epsilon, and random poses invert onto the real rig")
{
    GraphRigFunction rig = creatureRig(spec("creature_inversion.yaml"));
    REQUIRE(rig.parameters().size() == 85);
    REQUIRE(rig.outputs().size() == 43);
    const Approximation a = learnApproximation(rig, LearnOptions{}, "rigs/creature.yaml");
    MESSAGE(
        fmt::format("creature: {} modelled, {} rig evaluations ({} for the order); validation {:.3g} cm, {:.3g} deg",
                    a.parameters.size(), a.training.evaluations, a.training.orderEvaluations,
                    a.validation.maxPositionErrorCm, a.validation.maxRotationErrorDeg));
    CHECK(a.discarded.empty());
    REQUIRE(a.parameters.size() == 85);
    CHECK_FALSE(a.hasUnmodelledOutputs());
    CHECK(a.validation.withinEpsilon);
    CHECK(a.validation.maxPositionErrorCm < 1e-6);
    // Shared controls are exact on each joint, relative to its parent; the limited knee keeps its limits.
    for (const char* shared : {"spine_ctrl.bendForward", "spine_ctrl.bendSide", "spine_ctrl.twist"})
        CHECK(modelled(a, shared).form == "per output: 4 rotation");
    for (const char* shared : {"tail_ctrl.curl", "tail_ctrl.swish"})
        CHECK(modelled(a, shared).form == "per output: 6 rotation");
    const ModelledParameter& knee = modelled(a, "L_knee_fk_ctrl.bend");
    CHECK(knee.form == "rotation");
    CHECK(knee.parameter.min == doctest::Approx(-10 * degree));
    CHECK(knee.parameter.max == doctest::Approx(150 * degree));

    // The chest's channels compose between the spine bend's (they share spine4), so they are not an Euler
    // triple whose other solution is the same pose: continuity must never swap it. The head's are one.
    const Equivalences equivalences(a);
    const auto triple = [&](const char* control) {
        std::array<int, 3> t{};
        for (int c = 0; c < 3; ++c)
            t[static_cast<std::size_t>(c)] = indexOf(a, fmt::format("{}.rotate{}", control, "XYZ"[c]));
        std::sort(t.begin(), t.end());
        return std::any_of(equivalences.triples.begin(), equivalences.triples.end(), [&](std::array<int, 3> u) {
            std::sort(u.begin(), u.end());
            return u == t;
        });
    };
    CHECK_FALSE(triple("chest_ctrl"));
    CHECK(triple("head_ctrl"));

    RigBinding binding(a, rig);
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(17);
    for (int pose = 0; pose < 6; ++pose) {
        CAPTURE(pose);
        // Every control within 90% of its range, the chest far from rest.
        std::vector<double> known;
        for (const auto& m : a.parameters) {
            const RigParameter& p = m.parameter;
            known.push_back(std::uniform_real_distribution<double>(
                p.defaultValue + 0.9 * (p.min - p.defaultValue), p.defaultValue + 0.9 * (p.max - p.defaultValue))(rng));
        }
        std::vector<Eigen::Matrix4d> worlds;
        binding.evaluate(known, worlds);
        std::vector<JointTarget> targets(worlds.size());
        for (std::size_t k = 0; k < worlds.size(); ++k) {
            targets[k].active = true;
            targets[k].world = worlds[k];
        }
        // A cold start, as a clip's restart frame: the guess from the approximation's structure, then the solve.
        std::vector<double> values = a.defaults();
        CHECK(solver.initialGuess(targets, values) == TerminationType::converged);
        const SolveSummary s = solver.solve(targets, values);
        CAPTURE(s.briefReport());
        CHECK(s.converged());
        std::vector<Eigen::Matrix4d> solved;
        binding.evaluate(values, solved);
        double positionCm = 0.0, rotationDeg = 0.0;
        for (std::size_t k = 0; k < worlds.size(); ++k) {
            positionCm = std::max(positionCm, (solved[k].block<3, 1>(0, 3) - worlds[k].block<3, 1>(0, 3)).norm());
            const Eigen::AngleAxisd d(
                Eigen::Matrix3d(solved[k].block<3, 3>(0, 0).transpose() * worlds[k].block<3, 3>(0, 0)));
            rotationDeg = std::max(rotationDeg, std::abs(d.angle()) / degree);
        }
        CHECK(positionCm < 1e-3);
        CHECK(rotationDeg < 0.02);  // the claw tips' spline driven key is a fitted curve (docs/rigs.md)
        // The spine's bend and the chest are recovered, not another split of spine4's rotation.
        for (const char* name : {"spine_ctrl.bendForward", "spine_ctrl.twist", "chest_ctrl.rotateX",
                                 "chest_ctrl.rotateY", "chest_ctrl.rotateZ"}) {
            CAPTURE(name);
            const auto i = static_cast<std::size_t>(indexOf(a, name));
            CHECK(std::abs(values[i] - known[i]) < 1e-5);
        }
    }
}

TEST_CASE("learning the creature's IK spec: the IK limbs unmodelled, the leg poles' in-plane channels coupled")
{
    const InversionSpec s = spec("creature_inversion_ik.yaml");
    CHECK(s.set.size() == 8);
    GraphRigFunction rig = creatureRig(s);
    REQUIRE(rig.parameters().size() == 85);
    LearnOptions options;
    options.validationPoses = 10;
    const Approximation a = learnApproximation(rig, options, "rigs/creature.yaml");
    CHECK(a.validation.withinEpsilon);
    CHECK(a.parameters.size() == 81);
    std::vector<std::string> discarded;
    for (const auto& d : a.discarded) {
        CAPTURE(d.reason);
        CHECK(d.reason.starts_with("no effect on its own, but it changes what other parameters do (coupled"));
        discarded.push_back(d.parameter.name);
    }
    std::sort(discarded.begin(), discarded.end());
    CHECK(discarded == std::vector<std::string>{"L_leg_pole_ctrl.translateY", "L_leg_pole_ctrl.translateZ",
                                                "R_leg_pole_ctrl.translateY", "R_leg_pole_ctrl.translateZ"});
    std::vector<std::string> unmodelled;
    for (const auto& o : a.outputs)
        if (!o.modelled) unmodelled.push_back(o.name);
    CHECK(unmodelled.size() == 18);  // the IK arms (7 joints each) and the thighs and knees
    for (const char* joint : {"L_upperArm", "R_claw2_tip", "L_thigh", "R_knee"})
        CHECK(std::find(unmodelled.begin(), unmodelled.end(), joint) != unmodelled.end());
    for (const char* joint : {"spine4", "head", "tail_end", "L_ankle", "R_toe_end"})
        CHECK(std::find(unmodelled.begin(), unmodelled.end(), joint) == unmodelled.end());
}

TEST_CASE(
    "learning the creature's IK spec with helper frames: the claw tips relative to their claws, within epsilon, "
    "and random poses of every joint recovered from the initial guess at the tips on the real rig")
{
    const Approximation& a = ikCreature().approximation;
    CHECK(a.validation.withinEpsilon);
    const auto output = [&](const std::string& name) {
        const auto found = std::find_if(a.outputs.begin(), a.outputs.end(),
                                        [&](const ApproximationOutput& o) { return o.name == name; });
        REQUIRE_MESSAGE(found != a.outputs.end(), "no output " << name);
        return *found;
    };
    CHECK(output("L_hand").constraint >= 0);
    // Below the IK hand, the claws and their tips stay parent-relative, the tips' curl learned as in FK mode.
    for (const char* side : {"L", "R"})
        for (const char* claw : {"claw1", "claw2"}) {
            const std::string name = fmt::format("{}_{}", side, claw), tip = name + "_tip";
            CAPTURE(tip);
            const ApproximationOutput& t = output(tip);
            CHECK(t.modelled);
            CHECK(t.constraint < 0);
            REQUIRE(t.parent >= 0);
            CHECK(a.outputs[static_cast<std::size_t>(t.parent)].name == name);
            CHECK(t.validationError <= a.epsilon);
            const ApproximationOutput& c = output(name);
            REQUIRE(c.parent >= 0);
            CHECK(a.outputs[static_cast<std::size_t>(c.parent)].name == fmt::format("{}_hand", side));
        }
    for (const char* grip : {"L_wrist_ctrl.grip", "R_wrist_ctrl.grip"}) {
        CHECK(modelled(a, grip).form == "per output: 2 rotation 2 rotation (curve)");
        CHECK(modelled(a, grip).unmodelledOutputs.empty());
    }
    // Every output, the left knee too (its chain is within epsilon since the shapes reach goals near the hip).
    for (const auto& o : a.outputs) {
        CAPTURE(o.name);
        CHECK(o.modelled);
    }
    CHECK(output("L_knee").constraint >= 0);

    // Random poses on the real rig, every joint a target (the legs' reverse feet too), solved from the initial
    // guess on the approximation: the real rig there puts the claw tips on their targets, the grips recovered.
    RigBinding binding(a, *ikCreature().rig);
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(23);
    for (int pose = 0; pose < 6; ++pose) {
        CAPTURE(pose);
        const RealPose real = solveRealPose(a, solver, binding, rng);
        const auto& [known, targets, worlds, values, solved] = real;
        double tipCm = 0.0, footCm = 0.0;
        int feet = 0;
        for (std::size_t k = 0; k < worlds.size(); ++k) {
            const std::string& name = a.outputs[k].name;
            const double cm = (solved[k].block<3, 1>(0, 3) - worlds[k].block<3, 1>(0, 3)).norm();
            if (name.ends_with("_tip")) tipCm = std::max(tipCm, cm);
            if (targets[k].active &&
                (name.ends_with("_ankle") || name.ends_with("_ball") || name.ends_with("_toe_end")))
                footCm = std::max(footCm, cm), ++feet;
        }
        // The approximation at the pose is itself off the real rig by its learning error (up to 0.004 cm on these
        // poses): the feet are held to that, as the issue's "where the targets are reachable" asks.
        std::vector<Eigen::Matrix4d> approximated;
        a.evaluate(known, approximated);
        const double learnedCm = farthestCm(targets, approximated, worlds);
        MESSAGE(
            fmt::format("pose {}: the claw tips {:.3g} cm, the feet {:.3g} cm from their targets on the real rig "
                        "(the approximation at the pose {:.3g} cm)",
                        pose, tipCm, footCm, learnedCm));
        CHECK(feet == 6);
        CHECK(tipCm < 1e-3);
        CHECK(footCm < 1e-3 + learnedCm);
        for (const char* grip : {"L_wrist_ctrl.grip", "R_wrist_ctrl.grip"}) {
            CAPTURE(grip);
            const auto i = static_cast<std::size_t>(indexOf(a, grip));
            CHECK(std::abs(values[i] - known[i]) < 1e-4);
        }
    }
}

TEST_CASE("creature: scripts/random_poses.py makes a JSON clip that rig-invert inverts onto the real rig")
{
    const auto dir = test::scratchDir("creature-random-poses");
    const auto approx = dir / "creature.approx.yaml", clip = dir / "clip.json", curves = dir / "curves.json";
    const auto learned = test::run(fmt::format("{} rigs/creature.yaml --spec rigs/creature_inversion.yaml -o '{}'",
                                               test::tool("rig-learn"), approx.string()));
    INFO(learned.err);
    REQUIRE(learned.exitCode == 0);
    const auto made =
        test::run(fmt::format("python3 scripts/random_poses.py '{}' --rig rigs/creature.yaml --poses 4 "
                              "--graph-eval {} -o '{}'",
                              approx.string(), test::tool("graph-eval"), clip.string()));
    INFO(made.err);
    REQUIRE(made.exitCode == 0);
    // Independent poses: each frame a restart; the polish takes the claw tips' fitted curve onto the real rig.
    const auto inverted =
        test::run(fmt::format("{} '{}' --rig rigs/creature.yaml --clip '{}' --restart-every 1 "
                              "--polish 2 -o '{}'",
                              test::tool("rig-invert"), approx.string(), clip.string(), curves.string()));
    INFO(inverted.out << inverted.err);
    CHECK(inverted.exitCode == 0);
    CHECK(inverted.out.find("frames            4: 4 reached\n") != std::string::npos);
}

TEST_CASE(
    "learning the creature's IK spec with helper frames: random poses of every joint, the reverse feet and claws "
    "too, recovered from the initial guess")
{
    // Targets on the approximation's own worlds (reachable exactly) at random poses, on every modelled joint (the
    // left knee while its chain is over epsilon is not one). From rest, a reverse foot's roll stops where its heel,
    // ball or toe piece is flat (a few degrees off at the ankle and ball); the guess solves each foot's ankle, ball
    // and toe together from three rolls (docs/solver.md, Cold starts).
    const Approximation& a = ikCreature().approximation;
    const Solver solver(a, SolverOptions{});
    const double scaleCm = solver.options().rotationScaleCm;
    const double recoveredCm = solver.options().targetTolerance;  // 1e-3 cm: issue #32's bar
    constexpr int poses = 200;
    std::mt19937 rng(29);
    int fromGuess = 0, fromRest = 0;
    for (int pose = 0; pose < poses; ++pose) {
        CAPTURE(pose);
        std::vector<Eigen::Matrix4d> worlds;
        a.evaluate(randomPoseValues(a, rng), worlds);
        const std::vector<JointTarget> targets = jointTargets(a, worlds);
        for (const bool guess : {true, false}) {
            CAPTURE(guess);
            std::vector<double> values = a.defaults();
            if (guess) REQUIRE(solver.initialGuess(targets, values) == TerminationType::converged);
            const SolveSummary summary = solver.solve(targets, values);
            CAPTURE(summary.briefReport());
            const bool recovered = summary.maxPositionErrorCm <= recoveredCm &&
                                   scaleCm * summary.maxRotationErrorDeg * degree <= recoveredCm;
            (guess ? fromGuess : fromRest) += recovered;
            // What is not recovered is never called converged.
            if (!recovered) CHECK(!summary.converged());
        }
    }
    MESSAGE(fmt::format("IK creature: {} of {} poses recovered from the initial guess, {} from rest", fromGuess, poses,
                        fromRest));
    CHECK(fromGuess * 100 >= 99 * poses);
}

TEST_CASE(
    "learning the creature's IK spec with the forearm twist joints: twist shares of half the hand's twist, within "
    "epsilon, and random poses solved from rest with the twist joints on their targets on the real rig")
{
    // The roll joints under the IK forearms: each turns with its forearm by a share of the hand's twist relative to
    // the forearm, both planar chain outputs (the hand fitted after the roll joint, which a chain first took).
    InversionSpec s = spec("creature_inversion_ik.yaml");
    s.outputs.push_back("[LR]_forearm_twist");
    GraphRigOptions options{s.params, s.outputs, {}, s.set};
    options.autoHelpers = true;
    GraphRigFunction rig(test::sourceDir() / "rigs/creature.yaml", options);
    const Approximation a = learnApproximation(rig, LearnOptions{}, "rigs/creature.yaml");
    CHECK(a.validation.withinEpsilon);
    CHECK(a.validation.maxRelativeError <= a.epsilon);
    const auto index = [&](const std::string& name) {
        const auto found = std::find_if(a.outputs.begin(), a.outputs.end(),
                                        [&](const ApproximationOutput& o) { return o.name == name; });
        REQUIRE_MESSAGE(found != a.outputs.end(), "no output " << name);
        return static_cast<int>(found - a.outputs.begin());
    };
    for (const char* side : {"L", "R"}) {
        CAPTURE(side);
        const ApproximationOutput& twist =
            a.outputs[static_cast<std::size_t>(index(fmt::format("{}_forearm_twist", side)))];
        CHECK(twist.modelled);
        CHECK(twist.validationError <= a.epsilon);
        REQUIRE(twist.constraint >= 0);
        const ConstraintBase& base = a.constraints[static_cast<std::size_t>(twist.constraint)];
        CHECK(base.kind == ConstraintKind::twistShare);
        CHECK(base.anchor == index(fmt::format("{}_forearm", side)));
        CHECK(base.driver == index(fmt::format("{}_hand", side)));
        CHECK(base.driverParent == index(fmt::format("{}_forearm", side)));
        // The rig's weight, 0.5, of the wrist's twist about the hand's x axis (the sign is the fitted axis's).
        CHECK(base.twistAxis == 0);
        CHECK(std::abs(base.share) == doctest::Approx(0.5).epsilon(1e-9));
        // The plain swing-twist, as twistDistribute reads the wrist's rotate in the hand's own order (the reorderings
        // that agree with it to rounding are not taken).
        CHECK(base.readOrder == base.twistOrder);
        // The forearm and the hand are planar chains on the arm's goal and pole.
        for (const int input : {base.anchor, base.driver})
            CHECK(a.constraints[static_cast<std::size_t>(a.outputs[static_cast<std::size_t>(input)].constraint)].kind ==
                  ConstraintKind::planarChain);
    }

    RigBinding binding(a, rig);
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(31);
    for (int pose = 0; pose < 6; ++pose) {
        CAPTURE(pose);
        // A cold start from rest: the guess places the chains and the reverse feet (without it a foot's roll can stop
        // flat, 0.5 cm off; the twist joints are on their targets either way), then the solve.
        const RealPose real = solveRealPose(a, solver, binding, rng);
        const auto& [known, targets, worlds, values, solved] = real;
        for (const char* name : {"L_forearm_twist", "R_forearm_twist"}) {
            CAPTURE(name);
            const auto k = static_cast<std::size_t>(index(name));
            const Eigen::Matrix4d offset = solved[k].inverse() * worlds[k];
            // Its roll as the distance it moves a frame point a rotation scale away: the origin alone barely sees it.
            const double cm = (solved[k].block<3, 1>(0, 3) - worlds[k].block<3, 1>(0, 3)).norm();
            const double turnCm =
                solver.options().rotationScaleCm * Eigen::AngleAxisd(Eigen::Matrix3d(offset.block<3, 3>(0, 0))).angle();
            CHECK(cm < 1e-3);
            CHECK(turnCm < 1e-3);
        }
    }
}

TEST_CASE("rig-learn: the creature's IK spec with the forearm twist joints writes them as twist shares of the hands")
{
    // The command line of the issue (it exited 3, the roll joints planar chains 0.0453 cm per unit over epsilon).
    const auto dir = test::scratchDir("creature-ik-twist");
    std::string text = test::readFile(test::sourceDir() / "rigs/creature_inversion_ik.yaml");
    const std::string hands = "'[LR]_hand', ";
    const auto at = text.find(hands);
    REQUIRE(at != std::string::npos);
    text.insert(at + hands.size(), "'[LR]_forearm_twist', ");
    const auto specFile = test::writeFile(dir / "creature_inversion_ik_with_twist.yaml", text);
    const auto approx = dir / "creature.approx.yaml";
    const auto learned = test::run(fmt::format("{} rigs/creature.yaml --spec '{}' -o '{}'", test::tool("rig-learn"),
                                               specFile.string(), approx.string()));
    INFO(learned.out << learned.err);
    CHECK(learned.exitCode == 0);
    for (const char* side : {"L", "R"})
        CHECK(
            learned.out.find(fmt::format("  {0}_forearm_twist: twistShare, turns with {0}_forearm, -0.5 of {0}_hand's "
                                         "twist about x relative to {0}_forearm (swing-twist)\n",
                                         side)) != std::string::npos);
    CHECK(learned.out.find("epsilon 0.001 cm: within") != std::string::npos);
    CHECK(std::filesystem::exists(approx));
}
