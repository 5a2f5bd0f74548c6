// Constraint operators (inversion/model/constraint.h, constraint_fit.h): the planar chain learned on IK rigs, its
// base's velocity against finite differences, and solves through it.
#include <doctest/doctest.h>

#include <unistd.h>

#include <fmt/format.h>
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <random>

#include <Eigen/Eigenvalues>

#include "adapter/inversion_spec.h"
#include "core/rotation_math.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/ik_arm.h"
#include "inversion/learn/learner.h"
#include "inversion/model/approximation.h"
#include "inversion/model/approximation_io.h"
#include "inversion/model/constraint.h"
#include "inversion/solve/block_elimination.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/pole_hold.h"
#include "inversion/solve/residual_term.h"
#include "inversion/solve/solver.h"
#include "inversion/solver_rigs.h"
#include "test_support.h"

namespace rig {
namespace {

// The IK arm with its goal and pole controls as helper frames, read from the graph beside the joints.
class HelperRig final : public RigFunction {
public:
    HelperRig(RigFunction& rig, Graph& graph, std::vector<std::string> helpers)
        : rig_(rig), graph_(graph), names_(rig.outputs())
    {
        for (const auto& h : helpers) {
            plugs_.push_back(graph.plug(h + ".worldMatrix"));
            names_.push_back(h);
        }
        parents_ = rig.outputParents();
        parents_.resize(names_.size(), -1);
        helper_.assign(rig.outputs().size(), 0);
        helper_.resize(names_.size(), 1);
    }
    const std::vector<RigParameter>& parameters() const override { return rig_.parameters(); }
    const std::vector<std::string>& outputs() const override { return names_; }
    std::vector<int> outputParents() const override { return parents_; }
    std::vector<char> helperOutputs() const override { return helper_; }
    void evaluate(std::span<const double> values, std::vector<Eigen::Matrix4d>& worlds) override
    {
        rig_.evaluate(values, worlds);
        for (const Plug& p : plugs_) worlds.push_back(std::get<Eigen::Matrix4d>(graph_.getValue(p)));
    }
    std::uint64_t evaluationCount() const override { return rig_.evaluationCount(); }
    std::string fingerprint() const override { return rig_.fingerprint(); }

private:
    RigFunction& rig_;
    Graph& graph_;
    std::vector<std::string> names_;
    std::vector<Plug> plugs_;
    std::vector<int> parents_;
    std::vector<char> helper_;
};

}  // namespace

// The IK arm with its helpers, learned once per run.
struct LearnedArm {
    // Per process: CTest runs the cases that share it side by side.
    std::filesystem::path file =
        test::writeFile(test::scratchDir(fmt::format("constraint-ik-arm.{}", ::getpid())) / "arm.yaml", test::ikArm);
    GraphRigFunction graphRig{file, test::ikArmOptions()};
    HelperRig rig{graphRig, graphRig.graph(), {"arm_ik_ctrl", "arm_pole_ctrl"}};
    Approximation approximation = learnApproximation(rig, LearnOptions{}, file.string());
};

LearnedArm& learnedArm()
{
    static LearnedArm arm;
    return arm;
}

// Joint targets (not the helpers) from the real rig at these values of the approximation's parameters.
std::vector<JointTarget> realTargets(LearnedArm& arm, std::span<const double> values)
{
    const Approximation& a = arm.approximation;
    std::vector<double> rigValues;
    for (const auto& p : arm.rig.parameters()) rigValues.push_back(p.defaultValue);
    for (const auto& m : a.parameters)
        for (std::size_t i = 0; i < arm.rig.parameters().size(); ++i)
            if (arm.rig.parameters()[i].name == m.parameter.name)
                rigValues[i] = values[static_cast<std::size_t>(&m - a.parameters.data())];
    std::vector<Eigen::Matrix4d> worlds;
    arm.rig.evaluate(rigValues, worlds);
    std::vector<JointTarget> targets(a.outputs.size());
    for (std::size_t k = 0; k < a.outputs.size(); ++k) {
        if (a.outputs[k].helper) continue;
        const auto& names = arm.rig.outputs();
        const auto at = std::find(names.begin(), names.end(), a.outputs[k].name) - names.begin();
        targets[k].active = true;
        targets[k].world = worlds[static_cast<std::size_t>(at)];
    }
    return targets;
}

TEST_CASE("constraints: the IK arm's chain is learned as planar-chain constraints, within epsilon")
{
    const Approximation& a = learnedArm().approximation;
    CHECK(!a.hasUnmodelledOutputs());
    CHECK(a.validation.withinEpsilon);
    CHECK(a.validation.maxRelativeError < 1e-3);
    // The shoulder and the elbow on the goal and the pole; the wrist, whose IK translation is constant, relative to
    // the elbow again once that is modelled.
    std::vector<std::string> constrained;
    for (const auto& o : a.outputs)
        if (o.constraint >= 0) {
            constrained.push_back(o.name);
            const ConstraintBase& c = a.constraints[static_cast<std::size_t>(o.constraint)];
            CHECK(a.outputs[static_cast<std::size_t>(c.anchor)].name == "clavicle");
            CHECK(a.outputs[static_cast<std::size_t>(c.goal)].name == "arm_ik_ctrl");
            CHECK(a.outputs[static_cast<std::size_t>(c.pole)].name == "arm_pole_ctrl");
            CHECK(o.parent == -1);
        }
    CHECK(constrained == std::vector<std::string>{"shoulder", "elbow"});
    const auto wrist =
        std::find_if(a.outputs.begin(), a.outputs.end(), [](const auto& o) { return o.name == "wrist"; });
    REQUIRE(wrist != a.outputs.end());
    CHECK(a.outputs[static_cast<std::size_t>(wrist->parent)].name == "elbow");
    for (const auto& o : a.outputs) CHECK(o.helper == (o.name == "arm_ik_ctrl" || o.name == "arm_pole_ctrl"));
}

TEST_CASE("constraints: the analytic Jacobian through planar chains equals central differences")
{
    LearnedArm& arm = learnedArm();
    const Approximation& a = arm.approximation;
    std::mt19937 rng(3);
    for (int pose = 0; pose < 10; ++pose) {
        CAPTURE(pose);
        const std::vector<double> values = test::randomValues(a, rng, 0.8);
        const std::vector<JointTarget> targets = realTargets(arm, test::randomValues(a, rng, 0.8));
        JacobianEvaluator evaluator(a, targets, 10.0);
        CHECK(evaluator.structure().hasBases());
        CHECK(!evaluator.structure().twistForm());
        Eigen::MatrixXd analytic, numeric;
        Eigen::VectorXd r1, r2;
        evaluator.jacobian(values, JacobianMethod::analytic, 0.0, analytic, r1);
        evaluator.jacobian(values, JacobianMethod::finiteDifference, 1e-5, numeric, r2);
        CHECK((r1 - r2).norm() == doctest::Approx(0.0));
        CHECK((analytic - numeric).cwiseAbs().maxCoeff() < 1e-5 * std::max(1.0, analytic.cwiseAbs().maxCoeff()));
        // The goal's and the pole's columns move the chain: they are not zero.
        CHECK(analytic.norm() > 0.0);
    }
}

TEST_CASE("constraints: poses of the IK arm are solved through its planar chains, reached on the real rig")
{
    LearnedArm& arm = learnedArm();
    const Approximation& a = arm.approximation;
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(5);
    int fromRest = 0;
    const int poses = 20;
    for (int pose = 0; pose < poses; ++pose) {
        CAPTURE(pose);
        const std::vector<double> known = test::randomValues(a, rng, 0.6);
        const std::vector<JointTarget> targets = realTargets(arm, known);
        std::vector<double> values = a.defaults();
        const SolveSummary summary = solver.solve(targets, values);
        // Judged on the real rig: the joints at the values found against the targets.
        const std::vector<JointTarget> reached = realTargets(arm, values);
        double worst = 0.0;
        for (std::size_t k = 0; k < targets.size(); ++k)
            if (targets[k].active)
                worst =
                    std::max(worst, (reached[k].world.block<3, 1>(0, 3) - targets[k].world.block<3, 1>(0, 3)).norm());
        if (summary.converged() && worst < 1e-3) ++fromRest;
    }
    MESSAGE("reached from rest: " << fromRest << " of " << poses);
    CHECK(fromRest >= poses * 9 / 10);
}

TEST_CASE("constraints: a held pole sits at its rest distance in the plane the solve found, the joints unchanged")
{
    const Approximation& a = learnedArm().approximation;
    const std::vector<PoleHold> holds = poleHolds(a);
    REQUIRE(holds.size() == 1);  // the arm's one pole, read by the shoulder's and the elbow's constraints
    const PoleHold& hold = holds.front();
    CHECK(hold.parameters.size() == 3);  // arm_pole_ctrl.translateX, Y and Z
    CHECK(hold.across > 1.0);
    const ConstraintBase& c = a.constraints[static_cast<std::size_t>(hold.constraint)];
    std::mt19937 rng(11);
    for (int pose = 0; pose < 20; ++pose) {
        CAPTURE(pose);
        std::vector<double> values = test::randomValues(a, rng, 1.0);
        for (const int p : hold.parameters)
            values[static_cast<std::size_t>(p)] *= 40.0;  // far out, as a drift leaves it
        std::vector<Eigen::Matrix4d> before, after;
        a.evaluate(values, before);
        holdPoles(a, holds, values);
        a.evaluate(values, after);
        for (std::size_t k = 0; k < a.outputs.size(); ++k)
            if (!a.outputs[k].helper) CHECK((before[k] - after[k]).cwiseAbs().maxCoeff() < 1e-9);
        const Eigen::Vector3d root =
            after[static_cast<std::size_t>(c.anchor)].block<3, 3>(0, 0) *
                a.outputs[static_cast<std::size_t>(c.anchor)].rest.block<3, 3>(0, 0).transpose() *
                (c.root - a.outputs[static_cast<std::size_t>(c.anchor)].rest.block<3, 1>(0, 3)) +
            after[static_cast<std::size_t>(c.anchor)].block<3, 1>(0, 3);
        const Eigen::Vector3d x = (after[static_cast<std::size_t>(c.goal)].block<3, 1>(0, 3) - root).normalized();
        const Eigen::Vector3d offset = after[static_cast<std::size_t>(c.pole)].block<3, 1>(0, 3) - root;
        CHECK(offset.dot(x) == doctest::Approx(hold.along).epsilon(1e-9));
        CHECK((offset - offset.dot(x) * x).norm() == doctest::Approx(hold.across).epsilon(1e-9));
    }
}

// The biped with IK legs learned as rig-learn learns it (helper frames found), once per run.
struct IkBipedChains {
    InversionSpec spec = readInversionSpec(test::sourceDir() / "rigs" / "biped_inversion_ik.yaml");
    GraphRigOptions options()
    {
        GraphRigOptions o{spec.params, spec.outputs, {}, spec.set, spec.ranges};
        o.autoHelpers = true;
        return o;
    }
    GraphRigFunction rig{test::sourceDir() / "rigs" / "biped.yaml", options()};
    Approximation a = learnApproximation(rig, LearnOptions{}, "rigs/biped.yaml");
};

IkBipedChains& ikBiped()
{
    static IkBipedChains biped;
    return biped;
}

TEST_CASE("constraints: random poses of the biped's IK legs are recovered from rest through planar chains")
{
    IkBipedChains& biped = ikBiped();
    const Approximation& a = biped.a;
    REQUIRE(!a.hasUnmodelledOutputs());
    RigBinding binding(a, biped.rig);
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(7);
    int reached = 0;
    double worstOfAll = 0.0;
    const int poses = 300;
    for (int pose = 0; pose < poses; ++pose) {
        // Every control within half its learning range around rest.
        std::vector<double> truth = a.defaults();
        for (std::size_t p = 0; p < a.parameters.size(); ++p) {
            const RigParameter& q = a.parameters[p].parameter;
            truth[p] +=
                0.5 * std::uniform_real_distribution<double>(q.min - q.defaultValue, q.max - q.defaultValue)(rng);
        }
        const std::vector<JointTarget> targets = test::realTargetsAt(a, binding, truth);
        const double worst = test::solvedFromRest(a, solver, binding, targets);
        reached += worst < 1e-3 ? 1 : 0;
        worstOfAll = std::max(worstOfAll, worst);
    }
    MESSAGE("random poses of the IK biped reached from rest on the real rig: " << reached << " of " << poses
                                                                               << ", worst " << worstOfAll << " cm");
    // 300 of 300 measured (worst 2.8e-4 cm), with the chains' shapes refined to an absolute bound (issue #32's goal:
    // 99%). Before, 295: the misses were the approximation's own error, 1.1e-3 to 1.8e-3 cm.
    CHECK(reached >= 297);
    CHECK(worstOfAll < 2e-3);
}

// Poses the rig itself makes in the spec's own state, as a user makes them with graph-eval: the root moved and turned,
// each IK control set anywhere within 20 cm of the world origin, which folds the legs up to their nearest reach. Each
// is reachable, so each is reached from rest. Before the hinge's branch ended where the end is nearest (0.2 degrees
// short of the complete fold of the biped's sliding knee), a goal past the nearest reach put the knee on the far side
// of that point, and 6 of 12 such poses stopped 0.0035825 or 0.0054911 cm off, whatever the pose (issue #45).
TEST_CASE("constraints: the biped's own IK poses, legs folded to their nearest reach, are reached from rest")
{
    IkBipedChains& biped = ikBiped();
    const Approximation& a = biped.a;
    RigBinding binding(a, biped.rig);
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(11);
    const auto draw = [&](double half) { return std::uniform_real_distribution<double>(-half, half)(rng); };
    int reached = 0, folded = 0;
    const int poses = 12;
    for (int pose = 0; pose < poses; ++pose) {
        std::vector<double> truth = a.defaults();
        for (std::size_t p = 0; p < a.parameters.size(); ++p) {
            const std::string& name = a.parameters[p].parameter.name;
            if (name.starts_with("root_ctrl.translate")) truth[p] += draw(20.0);
            else if (name.starts_with("root_ctrl.rotate")) truth[p] += draw(30.0 * std::numbers::pi / 180.0);
            else if (name.find("_leg_ik_ctrl.translate") != std::string::npos) truth[p] = draw(20.0);
        }
        const std::vector<JointTarget> targets = test::realTargetsAt(a, binding, truth);
        // A leg folded to its nearest reach: its goal nearer the hip than its foot (the goal helper's world is among
        // the targets, inactive).
        for (const auto& [hip, foot, goal] : {std::array{"LeftUpLeg", "LeftFoot", "L_leg_ik_ctrl"},
                                              std::array{"RightUpLeg", "RightFoot", "R_leg_ik_ctrl"}}) {
            const auto at = [&](const char* n) {
                return targets[static_cast<std::size_t>(test::outputIndex(a, n))].world.block<3, 1>(0, 3).eval();
            };
            folded += (at(goal) - at(hip)).norm() < (at(foot) - at(hip)).norm() - 1e-3 ? 1 : 0;
        }
        const double worst = test::solvedFromRest(a, solver, binding, targets);
        CAPTURE(pose);
        CHECK(worst < 1e-3);
        reached += worst < 1e-3 ? 1 : 0;
    }
    MESSAGE("the biped's IK poses reached from rest: " << reached << " of " << poses << ", " << folded
                                                       << " legs folded to their nearest reach");
    CHECK(folded >= poses / 2);
}

TEST_CASE("constraints: the normal equations through planar chains' bases, from twists, are J^T J and J^T r")
{
    // The bases' columns (root, IK goal, pole) against each other and the unknowns below each base, without J.
    IkBipedChains& biped = ikBiped();
    const Approximation& a = biped.a;
    RigBinding binding(a, biped.rig);
    std::mt19937 rng(31);
    for (int pose = 0; pose < 10; ++pose) {
        CAPTURE(pose);
        std::vector<JointTarget> targets = test::realTargetsAt(a, binding, test::randomValues(a, rng, 0.5));
        if (pose % 2)  // another term on every other output: B^T B as a full 6x6
            for (std::size_t k = 0; k < targets.size(); k += 2) targets[k].term = &residualTerm("position");
        JacobianEvaluator evaluator(a, targets, SolverOptions{}.rotationScaleCm);
        REQUIRE(evaluator.structure().hasBases());
        CHECK(evaluator.structure().twistNormals());
        CHECK_FALSE(evaluator.structure().twistForm());  // no fold through a base
        const std::vector<double> values = test::randomValues(a, rng, 0.5);
        Eigen::MatrixXd j, h;
        Eigen::VectorXd r, rAgain, g;
        evaluator.jacobian(values, JacobianMethod::analytic, 0.0, j, r);
        evaluator.normalEquations(values, JacobianMethod::analytic, 0.0, g, h, rAgain);
        CHECK(rAgain == r);
        const Eigen::VectorXd gradient = j.transpose() * r;
        const Eigen::MatrixXd product = j.transpose() * j;
        CHECK((g - gradient).norm() <= 1e-10 * gradient.norm());
        const Eigen::MatrixXd lower = product.triangularView<Eigen::Lower>();
        const Eigen::MatrixXd formed = h.triangularView<Eigen::Lower>();
        CHECK((formed - lower).norm() <= 1e-10 * product.norm());
    }
}

TEST_CASE("constraints: the IK biped's singular leg blocks (a pole's free directions) take the minimum-norm step")
{
    // A pole moved within its chain's plane changes nothing: each leg's block of J^T J is singular, and the coupled
    // elimination's step must be the whole system's minimum-norm one (S^+ of each leg on its range).
    IkBipedChains& biped = ikBiped();
    const Approximation& a = biped.a;
    RigBinding binding(a, biped.rig);
    std::mt19937 rng(29);
    const std::vector<JointTarget> targets = test::realTargetsAt(a, binding, test::randomValues(a, rng, 0.5));
    const Partition partition = Solver(a, SolverOptions{}).partition(targets);
    REQUIRE(partition.blocks.size() > 3);
    std::vector<int> columns, outputs;
    for (const PartitionBlock& b : partition.blocks) {
        columns.insert(columns.end(), b.parameters.begin(), b.parameters.end());
        outputs.insert(outputs.end(), b.outputs.begin(), b.outputs.end());
    }
    std::sort(columns.begin(), columns.end());
    std::sort(outputs.begin(), outputs.end());
    const ResidualStructure structure(a, columns, outputs);
    REQUIRE(structure.hasBases());
    const BlockElimination elimination(partition, structure);
    std::vector<PreparedTarget> prepared(targets.size());
    for (std::size_t k = 0; k < targets.size(); ++k)
        if (targets[k].active) REQUIRE(prepareTarget(targets[k], SolverOptions{}.rotationScaleCm, prepared[k]));
    const Eigen::Index n = structure.columnCount();
    for (int pose = 0; pose < 5; ++pose) {
        CAPTURE(pose);
        const std::vector<double> values = test::randomValues(a, rng, 0.5);
        std::vector<double> x;
        for (const int c : columns) x.push_back(values[static_cast<std::size_t>(c)]);
        ResidualWorkspace dense(structure), blocks(structure);
        blocks.useLayout(elimination.layout());
        BlockEliminationWorkspace step(elimination);
        Eigen::VectorXd r(structure.rows()), g(n), gBlocks(n);
        Eigen::MatrixXd h = Eigen::MatrixXd::Zero(n, n), j(structure.rows(), n);
        for (ResidualWorkspace* w : {&dense, &blocks}) {
            w->holdParameters(values);
            w->setTargets(prepared);
        }
        dense.normalEquations(x, JacobianMethod::analytic, 1e-6, false, r, g, std::span<double>(h.data(), h.size()), j);
        blocks.normalEquations(x, JacobianMethod::analytic, 1e-6, false, r, gBlocks, step.entries(), j);
        const Eigen::MatrixXd full = h.selfadjointView<Eigen::Lower>();
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(full);
        const Eigen::VectorXd& lambda = eigen.eigenvalues();
        Eigen::Index nullity = 0;
        Eigen::VectorXd inverse(n);
        for (Eigen::Index i = 0; i < n; ++i) {
            const bool range = lambda[i] > 1e-12 * lambda.cwiseAbs().maxCoeff();
            nullity += range ? 0 : 1;
            inverse[i] = range ? 1.0 / lambda[i] : 0.0;
        }
        CHECK(nullity >= 4);  // two free directions per pole
        const Eigen::VectorXd minimumNorm =
            -(eigen.eigenvectors() * inverse.asDiagonal() * eigen.eigenvectors().transpose() * g);
        Eigen::VectorXd delta(n);
        REQUIRE(step.solve(gBlocks, 0.0, delta));
        CHECK((delta - minimumNorm).norm() <= 1e-7 * minimumNorm.norm());
        CHECK((full * delta + g).norm() <= 1e-7 * g.norm());
    }
}

// A random two-bone IK limb under a translating root, as a rigger would build one nobody here tuned for: bone
// lengths, the limb's direction and its rest bend at random, with or without a pole control, with or without
// stretch, a sliding knee or not. The goal sits at the end joint at rest, so IK at rest is the FK rest pose.
struct RandomLimb {
    std::string yaml;
    GraphRigOptions options;
    bool pole = false;
};

// A two-bone IK limb under a translating root (start, mid and end: the upper joint's offset and the two bones), its
// goal control at the end joint at rest, a pole control at `poleAt` or none, stretch or not, a sliding knee or not.
RandomLimb limbRig(const Eigen::Vector3d& start, const Eigen::Vector3d& mid, const Eigen::Vector3d& end,
                   const std::optional<Eigen::Vector3d>& poleAt, bool stretch, bool slide)
{
    const auto v = [](const Eigen::Vector3d& x) { return fmt::format("[{:.9g}, {:.9g}, {:.9g}]", x[0], x[1], x[2]); };
    const Eigen::Vector3d goal = Eigen::Vector3d(0, 100, 0) + start + mid + end;
    RandomLimb limb;
    limb.pole = poleAt.has_value();
    limb.yaml = fmt::format(
        "nodes:\n"
        "  - {{name: root_ctrl, type: transform, translate: [0, 100, 0]}}\n"
        "  - {{name: base, type: joint, parent: root_ctrl}}\n"
        "  - {{name: upper, type: joint, parent: base, translate: {}}}\n"
        "  - {{name: lower, type: joint, parent: upper}}\n"
        "  - {{name: tip, type: joint, parent: lower}}\n"
        "  - {{name: ik_ctrl, type: transform, translate: {}}}\n"
        "  - {{name: ik, type: ikHandle, startTranslate: {}, midTranslate: {}, endTranslate: {}, stretch: {}{}}}\n"
        "{}"
        "connections:\n"
        "  - base.worldMatrix -> ik.startParentMatrix\n"
        "  - base.scale -> ik.startInverseScale\n"
        "  - ik_ctrl.worldMatrix -> ik.goalMatrix\n"
        "  - ik.startRotate -> upper.rotate\n"
        "  - ik.midRotate -> lower.rotate\n"
        "  - ik.outMidTranslate -> lower.translate\n"
        "  - ik.outEndTranslate -> tip.translate\n"
        "{}",
        v(start), v(goal), v(start), v(mid), v(end), stretch ? "true" : "false", slide ? ", midSlide: 0.5" : "",
        limb.pole ? fmt::format("  - {{name: pole_ctrl, type: transform, translate: {}}}\n"
                                "  - {{name: pv, type: poleVectorConstraint, constraintRotatePivot: {}}}\n",
                                v(*poleAt), v(start))
                  : "",
        limb.pole ? "  - pole_ctrl.worldMatrix -> pv.targetMatrix[0]\n  - base.worldMatrix -> pv.pivotSpace\n"
                    "  - pv.constraintTranslate -> ik.poleVector\n"
                  : "");
    limb.options.parameterGlobs = {"root_ctrl.translate?", "ik_ctrl.translate?"};
    if (limb.pole) limb.options.parameterGlobs.push_back("pole_ctrl.translate?");
    limb.options.outputGlobs = {"base", "upper", "lower", "tip"};
    limb.options.autoHelpers = true;
    return limb;
}

// Bone lengths, the limb's direction and its rest bend at random, with or without a pole control, with or without
// stretch, a sliding knee or not.
RandomLimb randomLimb(std::mt19937& rng)
{
    std::uniform_real_distribution<double> unit(-1.0, 1.0), length(15.0, 40.0), bend(0.05, 0.6);
    Eigen::Vector3d along(unit(rng), unit(rng) - 1.5, unit(rng));
    along.normalize();
    Eigen::Vector3d side = along.unitOrthogonal();
    const double l1 = length(rng), l2 = length(rng), b = bend(rng);
    const Eigen::Vector3d start(unit(rng) * 10.0, unit(rng) * 10.0, unit(rng) * 10.0);
    // The mid joint off the start-end line by the bend, towards `side`: the rest plane.
    const Eigen::Vector3d mid = l1 * (std::cos(b) * along + std::sin(b) * side);
    const Eigen::Vector3d end = l2 * (std::cos(b) * along - std::sin(b) * side);
    const bool pole = std::bernoulli_distribution(0.7)(rng);
    const bool stretch = std::bernoulli_distribution(0.5)(rng);
    const bool slide = std::bernoulli_distribution(0.3)(rng);
    const Eigen::Vector3d poleAt = Eigen::Vector3d(0, 100, 0) + start + mid + 40.0 * side;
    return limbRig(start, mid, end, pole ? std::optional(poleAt) : std::nullopt, stretch, slide);
}

TEST_CASE(
    "constraints: random IK limbs (poles or not, stretch, sliding knees) are learned within epsilon, their "
    "Jacobians are central differences', their poses recovered from rest")
{
    std::mt19937 rng(2026);
    int modelled = 0, reached = 0, poses = 0;
    const int limbs = 12;
    for (int limbIndex = 0; limbIndex < limbs; ++limbIndex) {
        const RandomLimb limb = randomLimb(rng);
        CAPTURE(limbIndex);
        CAPTURE(limb.yaml);
        const auto file = test::writeFile(
            test::scratchDir("constraint-random-limb") / fmt::format("limb{}.yaml", limbIndex), limb.yaml);
        GraphRigFunction rig(file, limb.options);
        std::vector<UnmodelledOutput> unmodelled;
        const Approximation a = learnApproximation(rig, LearnOptions{}, file.string(), &unmodelled);
        CHECK(a.validation.withinEpsilon);
        for (const auto& u : unmodelled) MESSAGE(u.name << ": " << u.reason);
        if (a.hasUnmodelledOutputs()) continue;
        ++modelled;
        // A chain without a pole keeps its rest plane; through a file and back, the same bits.
        const bool restPlane = std::any_of(a.constraints.begin(), a.constraints.end(),
                                           [](const ConstraintBase& c) { return c.restPlane; });
        CHECK(restPlane == !limb.pole);
        const Approximation b = approximationFromYaml(approximationToYaml(a), "limb.approx.yaml");
        std::vector<Eigen::Matrix4d> wa, wb;
        const std::vector<double> some = test::randomValues(a, rng, 0.5);
        a.evaluate(some, wa);
        b.evaluate(some, wb);
        CHECK(wa == wb);
        RigBinding binding(a, rig);
        const Solver solver(a, SolverOptions{});
        for (int pose = 0; pose < 5; ++pose) {
            const std::vector<double> truth = test::randomValues(a, rng, 0.4);
            const std::vector<JointTarget> targets = test::realTargetsAt(a, binding, truth);
            // The analytic Jacobian through the chain against central differences, at the truth.
            JacobianEvaluator evaluator(a, targets, 10.0);
            Eigen::MatrixXd analytic, numeric;
            Eigen::VectorXd r1, r2;
            evaluator.jacobian(truth, JacobianMethod::analytic, 0.0, analytic, r1);
            evaluator.jacobian(truth, JacobianMethod::finiteDifference, 1e-5, numeric, r2);
            CHECK((analytic - numeric).cwiseAbs().maxCoeff() < 1e-4 * std::max(1.0, analytic.cwiseAbs().maxCoeff()));
            const double worst = test::solvedFromRest(a, solver, binding, targets);
            reached += worst < 1e-3 ? 1 : 0;
            ++poses;
        }
    }
    MESSAGE("random IK limbs: " << modelled << " of " << limbs
                                << " fully modelled; poses reached from rest on the real "
                                << "rig: " << reached << " of " << poses);
    // 12 of 12 measured. Before, 10: limbs 5 and 6 had goals nearer the root than the shape's knots, which stopped at a
    // fifth of the rest reach, and were 0.003 to 0.013 cm per unit off there. Poses: 58 of 60; the two misses (limbs 2
    // and 8, with poles) are the solve's, not the approximation's: it is within 4e-6 cm of the rig at their truths,
    // and the solve from rest ends 4.5 and 6.9 cm away.
    CHECK(modelled == limbs);
    CHECK(reached >= poses * 19 / 20);
}

// Random limb 6 of the test above (seed 2026): bones of 21.0 and 18.3 cm, nearly straight at rest (38.4 cm of 39.3),
// a pole; with stretch or not.
RandomLimb limbSix(bool stretch)
{
    return limbRig({0.573714413, -4.55110913, 3.24187096}, {9.43226999, -17.5253882, -6.70504874},
                   {0.55391356, -17.3301889, -5.84145085}, Eigen::Vector3d(48.6321466, 88.3167501, -3.46317778),
                   stretch, false);
}

TEST_CASE("constraints: a chain's shape holds for goals near its root, nearer than any pose it was swept for")
{
    // limbSix with stretch. With the shape's sweep stopped at a fifth of the rest reach, a goal 5 cm from the root was
    // 0.72 cm off.
    const RandomLimb limb = limbSix(true);
    const auto file = test::writeFile(test::scratchDir("constraint-near-goals") / "limb.yaml", limb.yaml);
    GraphRigFunction rig(file, limb.options);
    const Approximation a = learnApproximation(rig, LearnOptions{}, file.string());
    REQUIRE(!a.hasUnmodelledOutputs());
    CHECK(a.constraints.size() == 3);
    RigBinding binding(a, rig);
    // Goals from a fiftieth to a fifth of the rest reach from the chain's root (the upper joint), in random
    // directions: the knee folded, then bending, in planes at every angle from the rest plane.
    const Eigen::Vector3d root(0.573714413, 95.44889087, 3.24187096);
    const double restReach = (Eigen::Vector3d(10.559898, 60.5933138, -9.30462863) - root).norm();
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    double worst = 0.0;
    for (int i = 0; i < 20; ++i) {
        const Eigen::Vector3d direction = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
        const Eigen::Vector3d goal = root + restReach * (0.02 + 0.09 * (1.0 + unit(rng))) * direction;
        std::vector<double> values = a.defaults();
        for (int axis = 0; axis < 3; ++axis)
            values[static_cast<std::size_t>(test::parameterIndex(a, fmt::format("ik_ctrl.translate{}", "XYZ"[axis])))] =
                goal[axis];
        std::vector<Eigen::Matrix4d> model, real;
        a.evaluate(values, model);
        binding.evaluate(values, real);
        for (std::size_t k = 0; k < a.outputs.size(); ++k)
            if (!a.outputs[k].helper)
                worst =
                    std::max(worst, (model[k].block<3, 1>(0, 3) - real[k].block<3, 1>(0, 3)).norm() +
                                        10.0 * orientationAngle(model[k].block<3, 3>(0, 0), real[k].block<3, 3>(0, 0)));
    }
    MESSAGE("a nearly straight limb's joints, goals within a fifth of the rest reach: worst " << worst << " cm");
    CHECK(worst < 1e-3);
}

// A random aimed joint (an eye) under a head that turns and moves, aimed at a target control that translates: a
// random aim axis, a random up axis and up mode (carried by the head, the scene's +Y or a fixed world vector), the
// eye at a random offset. The target's controls are its helper frame, found as rig-learn finds them.
std::string randomAimRig(std::mt19937& rng, std::string& upMode)
{
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const auto unit = [&] {
        Eigen::Vector3d v(u(rng), u(rng), u(rng));
        return Eigen::Vector3d(v.normalized());
    };
    const Eigen::Vector3d aim = unit();
    Eigen::Vector3d up = unit();
    up = (up - up.dot(aim) * aim).normalized();
    const Eigen::Vector3d eye(5 * u(rng), 5 * u(rng), 5 * u(rng));
    const Eigen::Vector3d worldUp = unit();
    const std::array modes{"objectRotation", "scene", "vector"};
    upMode = modes[static_cast<std::size_t>(rng() % modes.size())];
    const auto v3 = [](const Eigen::Vector3d& v) {
        return fmt::format("[{:.9g}, {:.9g}, {:.9g}]", v.x(), v.y(), v.z());
    };
    // The target in front of the eye along its aim at rest, 40 to 80 cm away.
    const Eigen::Vector3d head(0, 150, 0), target = head + eye + (60 + 20 * u(rng)) * aim;
    std::string yaml = "nodes:\n";
    yaml += "  - {name: root_ctrl, type: transform}\n  - {name: head_ctrl, type: transform}\n";
    yaml += fmt::format("  - {{name: target_ctrl, type: transform, translate: {}}}\n", v3(target));
    yaml += "  - {name: root, type: joint}\n";
    yaml += fmt::format("  - {{name: head, type: joint, parent: root, translate: {}}}\n", v3(head));
    yaml += fmt::format("  - {{name: eye, type: joint, parent: head, translate: {}}}\n", v3(eye));
    yaml += fmt::format(
        "  - {{name: eye_aim, type: aimConstraint, aimVector: {}, upVector: {}, worldUpType: {}, "
        "worldUpVector: {}, constraintTranslate: {}}}\n",
        v3(aim), v3(up), upMode, v3(worldUp), v3(eye));
    yaml += "connections:\n";
    yaml += "  - root_ctrl.translate -> root.translate\n  - head_ctrl.rotate -> head.rotate\n";
    yaml += "  - target_ctrl.worldMatrix -> eye_aim.targetMatrix[0]\n";
    yaml += "  - head.worldInverseMatrix -> eye_aim.constraintParentInverseMatrix\n";
    yaml += "  - head.worldMatrix -> eye_aim.worldUpMatrix\n  - eye_aim.constraintRotate -> eye.rotate\n";
    return yaml;
}

TEST_CASE(
    "constraints: a rigid chain's goal past its reach is held back inside it, where a missed solve restarts: at its "
    "end's target where that bends the chain")
{
    // Without stretch the limb straightens at the sum of its bones (21.0 + 18.3 cm from the upper joint): past it the
    // shape is flat, and the goal gets a hold there; a stretchy chain's shape never flattens, so it gets none.
    for (const bool stretch : {false, true}) {
        CAPTURE(stretch);
        const RandomLimb limb = limbSix(stretch);
        const auto file = test::writeFile(
            test::scratchDir("constraint-goal-hold") / fmt::format("limb{}.yaml", stretch ? 1 : 0), limb.yaml);
        GraphRigFunction rig(file, limb.options);
        const Approximation a = learnApproximation(rig, LearnOptions{}, file.string());
        REQUIRE(!a.hasUnmodelledOutputs());
        const std::vector<GoalHold> holds = goalHolds(a);
        if (stretch) {
            CHECK(holds.empty());
            continue;
        }
        REQUIRE(holds.size() == 1);
        const double bones = Eigen::Vector3d(9.43226999, -17.5253882, -6.70504874).norm() +
                             Eigen::Vector3d(0.55391356, -17.3301889, -5.84145085).norm();
        // The flat reach is a knot of the shape at or past the straightening, within the knots' spacing of it.
        CHECK(holds[0].flatReach >= bones - 1e-6);
        CHECK(holds[0].flatReach <= bones + 0.05 * bones);

        // The goal 20 cm past the reach: held back onto the chain's line inside the flat reach, the joints as they were
        // (straight toward the goal on the real rig both times).
        RigBinding binding(a, rig);
        const Eigen::Vector3d root(0.573714413, 95.44889087, 3.24187096);
        const Eigen::Vector3d direction = Eigen::Vector3d(1.0, -2.0, 0.5).normalized();
        std::vector<double> values = a.defaults();
        const auto goalIndex = [&](int axis) {
            return static_cast<std::size_t>(test::parameterIndex(a, fmt::format("ik_ctrl.translate{}", "XYZ"[axis])));
        };
        for (int axis = 0; axis < 3; ++axis) values[goalIndex(axis)] = root[axis] + (bones + 20.0) * direction[axis];
        const std::vector<double> past = values;
        std::vector<Eigen::Matrix4d> before, after;
        binding.evaluate(values, before);
        // Straight targets (the pose itself): the end's target is past the reach too.
        std::vector<JointTarget> targets(a.outputs.size());
        for (std::size_t k = 0; k < targets.size(); ++k)
            if (!a.outputs[k].helper) targets[k] = JointTarget{true, before[k]};
        REQUIRE(holdGoals(a, holds, targets, values));
        Eigen::Vector3d goal;
        for (int axis = 0; axis < 3; ++axis) goal[axis] = values[goalIndex(axis)];
        CHECK((goal - root).norm() < holds[0].flatReach);
        CHECK((goal - root).norm() > holds[0].flatReach - 1e-6);
        CHECK(((goal - root).normalized() - direction).norm() < 1e-9);
        binding.evaluate(values, after);
        for (std::size_t k = 0; k < after.size(); ++k)
            if (!a.outputs[k].helper) CHECK((after[k].block<3, 1>(0, 3) - before[k].block<3, 1>(0, 3)).norm() < 1e-4);
        CHECK_FALSE(holdGoals(a, holds, targets, values));  // inside: left alone

        // Targets that bend the limb (its goal 0.9 of the way to the reach, in another direction): the goal goes where
        // the end's target puts it, which is the answer, instead of just inside the flat reach, where the bend's slope
        // is unbounded.
        std::vector<double> bentValues = a.defaults();
        const Eigen::Vector3d bentGoal = root + 0.9 * bones * Eigen::Vector3d(1.0, -2.5, 0.0).normalized();
        for (int axis = 0; axis < 3; ++axis) bentValues[goalIndex(axis)] = bentGoal[axis];
        std::vector<Eigen::Matrix4d> bent, held;
        binding.evaluate(bentValues, bent);
        for (std::size_t k = 0; k < targets.size(); ++k)
            if (!a.outputs[k].helper) targets[k].world = bent[k];
        values = past;
        REQUIRE(holdGoals(a, holds, targets, values));
        for (int axis = 0; axis < 3; ++axis)
            CHECK(values[goalIndex(axis)] == doctest::Approx(bentGoal[axis]).epsilon(1e-9));
        binding.evaluate(values, held);
        for (std::size_t k = 0; k < held.size(); ++k)
            if (!a.outputs[k].helper) CHECK((held[k].block<3, 1>(0, 3) - bent[k].block<3, 1>(0, 3)).norm() < 1e-9);
        // Without an end target: along the line, as for straight targets.
        for (JointTarget& t : targets) t.active = false;
        values = past;
        REQUIRE(holdGoals(a, holds, targets, values));
        for (int axis = 0; axis < 3; ++axis) goal[axis] = values[goalIndex(axis)];
        CHECK(((goal - root).normalized() - direction).norm() < 1e-9);
    }
}

// A random aim rig's parameters and outputs, its helper frames found as rig-learn finds them.
GraphRigOptions aimRigOptions()
{
    GraphRigOptions options;
    options.parameterGlobs = {"root_ctrl.translate?", "head_ctrl.rotate?", "target_ctrl.translate?"};
    options.outputGlobs = {"root", "head", "eye"};
    options.autoHelpers = true;
    return options;
}

TEST_CASE("constraints: random aims (axes, up modes, offsets) are learned as planar chains and solved from rest")
{
    std::mt19937 rng(31);
    const auto dir = test::scratchDir(fmt::format("constraint-aims.{}", ::getpid()));
    int learned = 0, reached = 0, tried = 0;
    const int rigs = 9;
    for (int r = 0; r < rigs; ++r) {
        std::string upMode;
        const auto file = test::writeFile(dir / fmt::format("aim{}.yaml", r), randomAimRig(rng, upMode));
        CAPTURE(upMode);
        GraphRigFunction rig(file, aimRigOptions());
        const Approximation a = learnApproximation(rig, LearnOptions{}, file.string());
        if (a.hasUnmodelledOutputs() || !a.validation.withinEpsilon) {
            MESSAGE("aim " << r << " (" << upMode << ") not learned within epsilon");
            continue;
        }
        CHECK(a.constraints.size() == 1);
        ++learned;
        RigBinding binding(a, rig);
        const Solver solver(a, SolverOptions{});
        for (int pose = 0; pose < 8; ++pose) {
            const std::vector<JointTarget> targets = test::realTargetsAt(a, binding, test::randomValues(a, rng, 0.5));
            const double worst = test::solvedFromRest(a, solver, binding, targets, 10.0);
            ++tried;
            reached += worst < 1e-3 ? 1 : 0;
        }
    }
    MESSAGE("random aims learned within epsilon: " << learned << " of " << rigs << "; poses reached from rest "
                                                   << reached << " of " << tried);
    CHECK(learned == rigs);
    CHECK(reached >= tried * 9 / 10);
}

TEST_CASE(
    "constraints: an aim target's distance along the line of sight is held at the solve's start, frame after frame")
{
    // One eye on a turning head, aimed at a target control: the joints fix the target's direction from the eye, never
    // its distance. Warm-started frames whose targets turn the eye must leave the distance where it was, and the
    // minimum-norm steps alone would move the target across the line of sight, further out each frame.
    std::mt19937 rng(31);
    std::string upMode;
    const auto file = test::writeFile(test::scratchDir("constraint-aim-hold") / "aim.yaml", randomAimRig(rng, upMode));
    GraphRigFunction rig(file, aimRigOptions());
    const Approximation a = learnApproximation(rig, LearnOptions{}, file.string());
    REQUIRE(!a.hasUnmodelledOutputs());
    const std::vector<AimHold> holds = aimHolds(a);
    REQUIRE(holds.size() == 1);
    const std::vector<PoleHold> poles = poleHolds(a);
    const Solver solver(a, SolverOptions{});
    RigBinding binding(a, rig);
    std::vector<double> values = a.defaults(), truth = a.defaults();
    std::vector<double> start;
    aimReaches(a, holds, values, start);
    const auto target = [&](int axis) {
        return static_cast<std::size_t>(test::parameterIndex(a, fmt::format("target_ctrl.translate{}", "XYZ"[axis])));
    };
    for (int frame = 1; frame <= 40; ++frame) {
        CAPTURE(frame);
        // The target circles the head at its rest distance and the head turns: the eye turns frame after frame.
        const double t = 0.15 * frame;
        for (int axis = 0; axis < 3; ++axis)
            truth[target(axis)] = a.defaults()[target(axis)] + 25.0 * std::sin(t + 2.0 * axis);
        truth[static_cast<std::size_t>(test::parameterIndex(a, "head_ctrl.rotateY"))] = 0.3 * std::sin(0.5 * t);
        std::vector<JointTarget> targets = test::realTargetsAt(a, binding, truth);
        const SolveSummary s = solver.solve(targets, values);
        CHECK(s.converged());
        std::vector<double> now;
        aimReaches(a, holds, values, now);
        CHECK(now[0] == doctest::Approx(start[0]).epsilon(1e-9));
    }
    CHECK(poles.empty());  // the up vector is carried by the head or fixed: no pole control to hold
}

}  // namespace rig
