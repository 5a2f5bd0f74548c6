// Blends of an animated switch (inversion/model/constraint.h, BlendRule): the blended local's rate against central
// differences in both modes and every rotate order, and the rule found from the biped's legs sampled with the IK/FK
// switch animated (L_leg_settings.ikFk a parameter, not held).
#include <doctest/doctest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <random>
#include <string>

#include "adapter/graph_rig_function.h"
#include "adapter/inversion_spec.h"
#include "app/learn/learn_run.h"
#include "core/error.h"
#include "core/rotation_math.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/learn/blend_merge.h"
#include "inversion/learn/constraint_fit.h"
#include "inversion/learn/learner.h"
#include "inversion/model/approximation.h"
#include "inversion/model/approximation_io.h"
#include "inversion/model/constraint.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/partition.h"
#include "inversion/solve/solver.h"
#include "inversion/solve/switch_hold.h"
#include "inversion/solver_rigs.h"
#include "test_support.h"

namespace rig {
namespace {

// A local transform as a joint makes one: a rotation of Euler angles within a radian of rest, a stretch and a
// translation.
Eigen::Matrix4d randomLocal(std::mt19937& rng, bool stretched)
{
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    const Eigen::Vector3d scale =
        stretched ? Eigen::Vector3d(1.0 + 0.4 * u(rng), 1.0 + 0.4 * u(rng), 1.0) : Eigen::Vector3d::Ones();
    m.block<3, 3>(0, 0) = eulerToMatrix(Eigen::Vector3d(u(rng), u(rng), u(rng)), RotateOrder::xyz) * scale.asDiagonal();
    m.block<3, 1>(0, 3) = 10.0 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    return m;
}

Eigen::Matrix4d randomRate(std::mt19937& rng)
{
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 4; ++j) m(i, j) = u(rng);
    return m;
}

// A rotation operator about the `axis`-th unit axis through `pivot`.
Operator rotationAbout(int axis, const Eigen::Vector3d& pivot)
{
    return test::rotationAbout(Eigen::Vector3d::Unit(axis), pivot);
}

// A switched thigh as a blend stores it: a hip, the thigh's IK branch (turned about x) and FK branch (about y then
// z, its rotate order yzx) relative to the hip, and the thigh the blend of their locals by the switch's weight.
Approximation switchedThigh()
{
    Approximation a;
    a.rigFile = "rigs/leg.yaml";
    a.rigFingerprint = "0123456789abcdef";
    a.epsilon = 1e-3;
    a.outputs = {test::restAt("hip", {0, 100, 0}), test::restAt("thigh_ik", {10, 90, 0}),
                 test::restAt("thigh_fk", {10, 90, 0}), test::restAt("thigh", {10, 90, 0}),
                 test::restAt("knee", {10, 50, 0})};
    a.outputs[1].parent = a.outputs[2].parent = 0;
    a.outputs[1].helper = a.outputs[2].helper = true;
    a.outputs[3].constraint = 0;
    a.outputs[4].parent = 3;
    ConstraintBase blend;
    blend.kind = ConstraintKind::blend;
    blend.anchor = blend.ikParent = blend.fkParent = 0;
    blend.ik = 1;
    blend.fk = 2;
    blend.weight = 4;
    blend.blend = {BlendMode::eulerChannels, RotateOrder::yzx};
    a.constraints = {blend};
    const auto add = [&](const std::string& name, int output, const Operator& op, double min, double max) {
        ModelledParameter m;
        m.parameter = RigParameter{name, 0.0, min, max, op.kind == OperatorKind::rotation, true};
        m.outputs = {output};
        m.operators = {op};
        m.operatorOfOutput = {0};
        m.form = std::string(operatorKindName(op.kind));
        a.parameters.push_back(m);
    };
    add("hip_ctrl.rotateX", 0, rotationAbout(0, {0, 100, 0}), -1.0, 1.0);
    add("ik_ctrl.rotateX", 1, rotationAbout(0, {10, 90, 0}), -1.0, 1.0);
    add("fk_ctrl.rotateY", 2, rotationAbout(1, {10, 90, 0}), -1.0, 1.0);
    add("fk_ctrl.rotateZ", 2, rotationAbout(2, {10, 90, 0}), -1.0, 1.0);
    ModelledParameter w;
    w.parameter = RigParameter{"settings.ikFk", 0.0, 0.0, 1.0, false, true};
    w.form = "blend weight";
    a.parameters.push_back(w);
    return a;
}

std::string blendErrorWith(const std::string& from, const std::string& to)
{
    std::string text = approximationToYaml(switchedThigh());
    const auto at = text.find(from);
    REQUIRE(at != std::string::npos);
    text.replace(at, from.size(), to);
    try {
        approximationFromYaml(text, "f.yaml");
    }
    catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

// The biped's left leg: its IK branch's controls (the goal and pole), its FK branch's, and those of both.
const std::vector<std::string> legIkParams{"root_ctrl.rotate?",        "L_hip_ctrl.rotate?",
                                           "L_leg_ik_ctrl.translate?", "L_leg_pole_ctrl.translate?",
                                           "L_foot_fk_ctrl.rotate?",   "L_toe_ctrl.rotate?"};
const std::vector<std::string> legFkParams{"root_ctrl.rotate?",       "L_hip_ctrl.rotate?",
                                           "L_upLeg_fk_ctrl.rotate?", "L_knee_fk_ctrl.rotateX",
                                           "L_foot_fk_ctrl.rotate?",  "L_toe_ctrl.rotate?"};
// Each joint with its parent joint.
const std::vector<std::pair<std::string, std::string>> legJoints{
    {"LeftUpLeg", "LHipJoint"}, {"LeftLeg", "LeftUpLeg"}, {"LeftFoot", "LeftLeg"}, {"LeftToeBase", "LeftFoot"}};

// The leg's rig with these controls and, when `fk` is given, both branches' and the switch last (animated).
GraphRigOptions switchedLegOptions(std::vector<std::string> params, const std::vector<std::string>& fk)
{
    GraphRigOptions options;
    for (const std::string& glob : fk)
        if (std::find(params.begin(), params.end(), glob) == params.end()) params.push_back(glob);
    if (!fk.empty()) params.push_back("L_leg_settings.ikFk");
    options.parameterGlobs = params;
    options.outputGlobs = {"LHipJoint", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase"};
    options.held = {{"L_leg_ik.stretch", 1.0}};
    return options;
}

// Per joint of legJoints, 40 random poses with a random weight: each joint relative to its parent joint with the
// switch at 1 (IK), at 0 (FK) and at the weight.
std::vector<std::vector<BlendSample>> switchedLegSamples(GraphRigFunction& rig)
{
    const auto& names = rig.outputs();
    const auto output = [&](const std::string& name) {
        return static_cast<std::size_t>(std::find(names.begin(), names.end(), name) - names.begin());
    };
    const auto& parameters = rig.parameters();
    const std::size_t switchIndex = parameters.size() - 1;
    REQUIRE(parameters[switchIndex].name == "L_leg_settings.ikFk");
    std::vector<std::vector<BlendSample>> samples(legJoints.size());
    std::mt19937 rng(2026);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<double> values(parameters.size());
    std::vector<Eigen::Matrix4d> ik, fk, blended;
    const auto local = [&](const std::vector<Eigen::Matrix4d>& worlds, const std::pair<std::string, std::string>& j) {
        return Eigen::Matrix4d(worlds[output(j.second)].inverse() * worlds[output(j.first)]);
    };
    for (int pose = 0; pose < 40; ++pose) {
        for (std::size_t p = 0; p < parameters.size(); ++p)
            values[p] = parameters[p].min + unit(rng) * (parameters[p].max - parameters[p].min);
        const double w = values[switchIndex];
        values[switchIndex] = 1.0;
        rig.evaluate(values, ik);
        values[switchIndex] = 0.0;
        rig.evaluate(values, fk);
        values[switchIndex] = w;
        rig.evaluate(values, blended);
        for (std::size_t j = 0; j < legJoints.size(); ++j)
            samples[j].push_back({w, local(ik, legJoints[j]), local(fk, legJoints[j]), local(blended, legJoints[j])});
    }
    return samples;
}

// Every control at random within half its range around rest (a random pose the solve is to recover from rest).
void halfRangePose(const std::vector<RigParameter>& parameters, std::mt19937& rng, std::vector<double>& truth)
{
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (std::size_t p = 0; p < parameters.size(); ++p)
        truth[p] = parameters[p].defaultValue + 0.5 * (parameters[p].min - parameters[p].defaultValue +
                                                       unit(rng) * (parameters[p].max - parameters[p].min));
}

}  // namespace

TEST_CASE("blend: the blended local's rate matches central differences in every mode and rotate order")
{
    std::mt19937 rng(32);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<BlendRule> rules{{BlendMode::slerp, RotateOrder::xyz}};
    for (int order = 0; order < 6; ++order) rules.push_back({BlendMode::eulerChannels, *rotateOrderFromIndex(order)});
    for (const BlendRule& rule : rules)
        for (int trial = 0; trial < 20; ++trial) {
            const bool stretched = trial % 2 == 1;
            const Eigen::Matrix4d ik = randomLocal(rng, stretched), fk = randomLocal(rng, stretched);
            const Eigen::Matrix4d dIk = randomRate(rng), dFk = randomRate(rng);
            const double w = unit(rng), dw = unit(rng) - 0.5;
            const double h = 1e-6;
            const Eigen::Matrix4d numeric = (blendLocal(rule, w + h * dw, ik + h * dIk, fk + h * dFk) -
                                             blendLocal(rule, w - h * dw, ik - h * dIk, fk - h * dFk)) /
                                            (2.0 * h);
            const Eigen::Matrix4d analytic = blendLocalRate(rule, w, ik, fk, dw, dIk, dFk);
            INFO(blendModeName(rule.mode) << " " << rotateOrderName(rule.order) << " trial " << trial);
            CHECK((analytic - numeric).cwiseAbs().maxCoeff() < 1e-6);
        }
}

TEST_CASE("blend: at w 0 and 1 the blend is the FK and the IK branch, and a frame's slerp is not a channel blend")
{
    std::mt19937 rng(7);
    const Eigen::Matrix4d ik = randomLocal(rng, true), fk = randomLocal(rng, true);
    for (const BlendRule rule : {BlendRule{BlendMode::eulerChannels, RotateOrder::yzx}, BlendRule{BlendMode::slerp}}) {
        CHECK((blendLocal(rule, 0.0, ik, fk) - fk).cwiseAbs().maxCoeff() < 1e-12);
        CHECK((blendLocal(rule, 1.0, ik, fk) - ik).cwiseAbs().maxCoeff() < 1e-12);
    }
    const Eigen::Matrix4d euler = blendLocal({BlendMode::eulerChannels, RotateOrder::yzx}, 0.5, ik, fk);
    const Eigen::Matrix4d slerp = blendLocal({BlendMode::slerp}, 0.5, ik, fk);
    CHECK(matrixError(euler, slerp, 10.0) > 0.01);
}

TEST_CASE("blend: the biped's legs with ikFk animated are the rig's channel blends of their IK and FK branches")
{
    GraphRigFunction rig(test::sourceDir() / "rigs" / "biped.yaml", switchedLegOptions(legIkParams, legFkParams));
    const std::vector<std::vector<BlendSample>> samples = switchedLegSamples(rig);
    std::vector<std::string> found;
    for (std::size_t j = 0; j < legJoints.size(); ++j) {
        BlendFit closest;
        const std::optional<BlendFit> fit = fitBlendRule(samples[j], 1e-6, 10.0, &closest);
        INFO(legJoints[j].first << ": nearest " << blendModeName(closest.rule.mode) << " "
                                << rotateOrderName(closest.rule.order) << " at " << closest.error << " cm");
        REQUIRE(fit);
        found.push_back(std::string(blendModeName(fit->rule.mode)) + " " +
                        std::string(rotateOrderName(fit->rule.order)));
    }
    // The thigh's channels are blended in its rotate order (yzx); the knee turns about x alone in both branches and
    // the foot's rotation is the same in both (its translation is blended), so the first order already reproduces
    // them; the toe is not switched at all.
    CHECK(found ==
          std::vector<std::string>{"eulerChannels yzx", "eulerChannels xyz", "eulerChannels xyz", "eulerChannels xyz"});
    // The thigh's frames slerped are not what the rig does.
    double slerpError = 0.0;
    for (const BlendSample& s : samples[0])
        slerpError =
            std::max(slerpError, matrixError(blendLocal({BlendMode::slerp}, s.weight, s.ik, s.fk), s.blended, 10.0));
    CHECK(slerpError > 1e-2);
}

namespace {

// The biped's left leg learned in each branch (the switch held) and merged, with the rig of both branches' controls
// and the switch animated; once per run.
struct MergedLeg {
    static Approximation learnBranch(const std::vector<std::string>& params, double held)
    {
        GraphRigOptions options = switchedLegOptions(params, {});
        options.held.push_back({"L_leg_settings.ikFk", held});
        options.autoHelpers = held == 1.0;
        GraphRigFunction branch(test::sourceDir() / "rigs" / "biped.yaml", options);
        return learnApproximation(branch, LearnOptions{}, "rigs/biped.yaml");
    }
    Approximation ik = learnBranch(legIkParams, 1.0), fk = learnBranch(legFkParams, 0.0);
    GraphRigFunction rig{test::sourceDir() / "rigs" / "biped.yaml", switchedLegOptions(legIkParams, legFkParams)};
    Approximation merged = merge();

    Approximation merge()
    {
        const std::vector<std::vector<BlendSample>> samples = switchedLegSamples(rig);
        SwitchBranches branches{&ik, &fk, {rig.parameters().back()}, {}};
        REQUIRE(branches.weights[0].name == "L_leg_settings.ikFk");
        for (std::size_t j = 0; j < 3; ++j) {
            const std::optional<BlendFit> fit = fitBlendRule(samples[j], 1e-6, 10.0);
            REQUIRE(fit);
            branches.switched.push_back({legJoints[j].first, legJoints[j].second, fit->rule});
        }
        return mergeSwitchBranches(branches);
    }
    // The merged approximation's values from the rig's (by name).
    std::vector<double> mergedValues(const std::vector<double>& rigValues) const
    {
        const auto& parameters = rig.parameters();
        std::vector<double> values(merged.parameters.size());
        for (std::size_t p = 0; p < merged.parameters.size(); ++p) {
            const auto it = std::find_if(parameters.begin(), parameters.end(), [&](const RigParameter& r) {
                return r.name == merged.parameters[p].parameter.name;
            });
            REQUIRE(it != parameters.end());
            values[p] = rigValues[static_cast<std::size_t>(it - parameters.begin())];
        }
        return values;
    }
    // Per rig output, its index among the merged outputs.
    std::vector<std::size_t> mergedOutputs() const
    {
        std::vector<std::size_t> index;
        for (const std::string& name : rig.outputs()) {
            const auto it = std::find_if(merged.outputs.begin(), merged.outputs.end(),
                                         [&](const ApproximationOutput& o) { return o.name == name; });
            REQUIRE(it != merged.outputs.end());
            index.push_back(static_cast<std::size_t>(it - merged.outputs.begin()));
        }
        return index;
    }
};

MergedLeg& mergedLeg()
{
    static MergedLeg leg;
    return leg;
}

// Every output but the helpers a target at its world for these values.
std::vector<JointTarget> jointTargetsAt(const Approximation& a, const std::vector<double>& values)
{
    std::vector<Eigen::Matrix4d> worlds;
    a.evaluate(values, worlds);
    std::vector<JointTarget> targets(a.outputs.size());
    for (std::size_t k = 0; k < targets.size(); ++k) {
        targets[k].active = !a.outputs[k].helper;
        targets[k].world = worlds[k];
    }
    return targets;
}

}  // namespace

TEST_CASE("blend: the biped's left leg learned in both branches and merged is the real rig with ikFk animated")
{
    // Each branch learned with the switch held, every output modelled (the IK one on planar chains).
    MergedLeg& leg = mergedLeg();
    const Approximation &ik = leg.ik, &fk = leg.fk, &merged = leg.merged;
    GraphRigFunction& rig = leg.rig;
    CHECK(!ik.hasUnmodelledOutputs());
    CHECK(!fk.hasUnmodelledOutputs());
    CHECK(ik.validation.withinEpsilon);
    CHECK(fk.validation.withinEpsilon);
    CHECK(!merged.hasUnmodelledOutputs());
    CHECK(merged.parameters.back().parameter.name == "L_leg_settings.ikFk");
    // rig-learn's report names each blend's branches, weight and rotate order.
    const app::Json report =
        app::learnReport(app::LearnOutcome{merged, 0, 0, {}, 0.0, {}}, "rigs/biped.yaml", std::nullopt, false);
    bool thigh = false;
    for (const app::Json& o : report.at("frames"))
        if (o.at("name") == "LeftUpLeg") {
            thigh = true;
            CHECK(o.at("constraint").at("kind") == "blend");
            CHECK(o.at("constraint").at("ik") == "LeftUpLeg@ik");
            CHECK(o.at("constraint").at("fk") == "LeftUpLeg@fk");
            CHECK(o.at("constraint").at("anchor") == "LHipJoint");
            CHECK(o.at("constraint").at("weight") == "L_leg_settings.ikFk");
            CHECK(o.at("constraint").at("order") == "yzx");
        }
    CHECK(thigh);
    // It reads back as it was written, and evaluates to the same bits.
    const Approximation read = approximationFromYaml(approximationToYaml(merged), "merged.yaml");

    // Random poses with a random weight, the real rig against the merged approximation, every joint.
    std::mt19937 rng(99);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const auto& parameters = rig.parameters();
    std::vector<double> values(parameters.size());
    std::vector<Eigen::Matrix4d> real, model, again;
    const std::vector<std::size_t> index = leg.mergedOutputs();
    double worst = 0.0;
    for (int pose = 0; pose < 30; ++pose) {
        for (std::size_t p = 0; p < parameters.size(); ++p)
            values[p] = parameters[p].min + unit(rng) * (parameters[p].max - parameters[p].min);
        const std::vector<double> mergedValues = leg.mergedValues(values);
        rig.evaluate(values, real);
        merged.evaluate(mergedValues, model);
        read.evaluate(mergedValues, again);
        for (std::size_t k = 0; k < rig.outputs().size(); ++k) {
            worst = std::max(worst, matrixError(model[index[k]], real[k], 10.0));
            CHECK(again[index[k]] == model[index[k]]);
        }
    }
    MESSAGE("the merged left leg against the real rig with ikFk animated: worst " << worst << " cm");
    CHECK(worst < 1e-2);
}

TEST_CASE("blend: an approximation with a blend evaluates the parent times the blended locals, reads back bit for bit")
{
    const Approximation a = switchedThigh();
    std::vector<Eigen::Matrix4d> worlds, rest;
    a.evaluate(a.defaults(), rest);
    for (std::size_t k = 0; k < rest.size(); ++k) CHECK(rest[k].isApprox(a.outputs[k].rest, 1e-12));
    std::vector<double> values{0.3, 0.7, -0.4, 0.5, 1.0};
    a.evaluate(values, worlds);
    CHECK(worlds[3].isApprox(worlds[1], 1e-12));  // at weight 1, the IK branch
    values[4] = 0.0;
    a.evaluate(values, worlds);
    CHECK(worlds[3].isApprox(worlds[2], 1e-12));  // at 0, the FK branch
    values[4] = 0.25;
    a.evaluate(values, worlds);
    const Eigen::Matrix4d local =
        blendLocal(a.constraints[0].blend, 0.25, worlds[0].inverse() * worlds[1], worlds[0].inverse() * worlds[2]);
    CHECK(worlds[3].isApprox(worlds[0] * local, 1e-12));
    // The knee hangs from the blended thigh; the weight reaches both, the FK controls the FK branch and below.
    CHECK(worlds[4].isApprox(worlds[3] * a.outputs[3].rest.inverse() * a.outputs[4].rest, 1e-12));
    const std::vector<std::vector<int>> reach = a.reach();
    CHECK(reach[4] == std::vector<int>{3, 4});
    CHECK(reach[2] == std::vector<int>{2, 3, 4});

    const std::string text = approximationToYaml(a);
    CHECK(text.find("  - kind: blend\n    anchor: \"hip\"\n    ik: \"thigh_ik\"\n    fk: \"thigh_fk\"\n"
                    "    ikParent: \"hip\"\n    fkParent: \"hip\"\n    weight: \"settings.ikFk\"\n"
                    "    mode: eulerChannels\n    order: yzx\n") != std::string::npos);
    const Approximation b = approximationFromYaml(text, "blend.yaml");
    CHECK(approximationToYaml(b) == text);
    REQUIRE(b.constraints.size() == 1);
    CHECK(b.constraints[0].kind == ConstraintKind::blend);
    CHECK(b.constraints[0].weight == 4);
    std::vector<Eigen::Matrix4d> again;
    b.evaluate(values, again);
    for (std::size_t k = 0; k < worlds.size(); ++k) CHECK(again[k] == worlds[k]);

    // A slerp has no rotate order.
    Approximation slerp = a;
    slerp.constraints[0].blend = {BlendMode::slerp};
    const std::string slerpText = approximationToYaml(slerp);
    CHECK(slerpText.find("    mode: slerp\n    parameters:") == std::string::npos);
    CHECK(slerpText.find("    mode: slerp\n") != std::string::npos);
    CHECK(slerpText.find("order: yzx") == std::string::npos);
    CHECK(approximationFromYaml(slerpText, "slerp.yaml").constraints[0].blend.mode == BlendMode::slerp);
}

TEST_CASE("blend: the Jacobian through a blend is central differences', the weight's column and both branches'")
{
    const Approximation a = switchedThigh();
    std::mt19937 rng(41);
    for (int trial = 0; trial < 12; ++trial) {
        CAPTURE(trial);
        std::vector<double> values = test::randomValues(a, rng);
        const std::vector<JointTarget> targets = jointTargetsAt(a, test::randomValues(a, rng));
        if (trial < 2) values[4] = trial;  // at a branch: the other branch moves nothing
        JacobianEvaluator evaluator(a, targets, 10.0);
        CHECK(evaluator.structure().hasBases());
        // hip, thigh, knee: the weight moves the thigh and the knee below it.
        CHECK(evaluator.structure().outputsOfColumn(4) == std::vector<int>{1, 2});
        Eigen::MatrixXd analytic, numeric, h;
        Eigen::VectorXd r1, r2, g;
        evaluator.jacobian(values, JacobianMethod::analytic, 0.0, analytic, r1);
        evaluator.jacobian(values, JacobianMethod::finiteDifference, 1e-6, numeric, r2);
        CHECK((r1 - r2).norm() == doctest::Approx(0.0));
        CHECK((analytic - numeric).cwiseAbs().maxCoeff() < 1e-6 * std::max(1.0, analytic.cwiseAbs().maxCoeff()));
        if (trial == 0) CHECK(analytic.col(1).norm() == 0.0);            // w = 0: the IK control moves only its helper
        if (trial == 1) CHECK(analytic.middleCols(2, 2).norm() == 0.0);  // w = 1: the FK controls nothing
        if (trial >= 2) CHECK(analytic.col(4).norm() > 0.0);
        evaluator.normalEquations(values, JacobianMethod::analytic, 0.0, g, h, r1);
        const Eigen::MatrixXd jtj = analytic.transpose() * analytic;
        CHECK((Eigen::MatrixXd(h.triangularView<Eigen::Lower>()) - Eigen::MatrixXd(jtj.triangularView<Eigen::Lower>()))
                  .cwiseAbs()
                  .maxCoeff() < 1e-9 * std::max(1.0, jtj.cwiseAbs().maxCoeff()));
        CHECK((g - analytic.transpose() * r1).cwiseAbs().maxCoeff() < 1e-9 * std::max(1.0, g.cwiseAbs().maxCoeff()));

        // The weight held (not a column): the blend reads it from the held values.
        const ResidualStructure held(a, {0, 1, 2, 3}, {0, 3, 4});
        ResidualWorkspace workspace(held);
        workspace.holdParameters(values);
        std::vector<PreparedTarget> prepared(a.outputs.size());
        for (std::size_t k = 0; k < a.outputs.size(); ++k) REQUIRE(prepareTarget(targets[k], 10.0, prepared[k]));
        workspace.setTargets(prepared);
        Eigen::MatrixXd heldAnalytic(held.rows(), 4), heldNumeric(held.rows(), 4);
        Eigen::VectorXd heldR(held.rows());
        const std::vector<double> x(values.begin(), values.begin() + 4);
        workspace.jacobian(x, JacobianMethod::analytic, 0.0, false, heldR, heldAnalytic);
        CHECK((heldR - r2).norm() == doctest::Approx(0.0));
        workspace.jacobian(x, JacobianMethod::finiteDifference, 1e-6, false, heldR, heldNumeric);
        CHECK((heldAnalytic - analytic.leftCols(4)).cwiseAbs().maxCoeff() < 1e-12 * std::max(1.0, analytic.norm()));
        CHECK((heldAnalytic - heldNumeric).cwiseAbs().maxCoeff() < 1e-6 * std::max(1.0, heldAnalytic.norm()));
    }
}

TEST_CASE("blend: the partition solves a switch's weight with both branches' controls, on the outputs it blends")
{
    const Approximation a = switchedThigh();
    // Targets on the hip, the thigh and the knee: the hip's control may be solved first, on the hip alone; the weight,
    // the IK and the FK controls move the thigh together (through the blend), so one block holds them.
    const std::vector<unsigned char> rows{allRows, 0, 0, allRows, allRows};
    const Partition partition = partitionProblem(a, rows, PartitionSplit::determined);
    CHECK(partition.unreached.empty());
    const auto block = std::find_if(partition.blocks.begin(), partition.blocks.end(), [](const PartitionBlock& b) {
        return std::find(b.parameters.begin(), b.parameters.end(), 4) != b.parameters.end();
    });
    REQUIRE(block != partition.blocks.end());
    for (const int p : {1, 2, 3})
        CHECK(std::find(block->parameters.begin(), block->parameters.end(), p) != block->parameters.end());
    for (const int k : {3, 4})
        CHECK(std::find(block->outputs.begin(), block->outputs.end(), k) != block->outputs.end());
}

TEST_CASE("blend: warm-started solves with the switch at a branch leave the other branch's controls where they were")
{
    // At w = 1 the FK controls move nothing (and the IK control at w = 0): their columns are zero, the minimum-norm
    // steps leave them, and the weight stays at its limit while the active branch reaches the targets.
    const Approximation a = switchedThigh();
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(17);
    for (const double branch : {1.0, 0.0}) {
        CAPTURE(branch);
        std::vector<double> values{0.0, 0.3, -0.2, 0.4, branch};
        const std::vector<double> start = values;
        for (int frame = 0; frame < 5; ++frame) {
            CAPTURE(frame);
            std::vector<double> truth = test::randomValues(a, rng, 0.5);
            truth[4] = branch;
            const SolveSummary summary = solver.solve(jointTargetsAt(a, truth), values);
            CHECK(summary.converged());
            CHECK(values[4] == branch);
            if (branch == 1.0) {
                CHECK(values[2] == start[2]);
                CHECK(values[3] == start[3]);
            } else {
                CHECK(values[1] == start[1]);
            }
        }
    }
}

TEST_CASE("blend: the merged left leg's Jacobian through its chained blends and chains is central differences'")
{
    // The knee's blend hangs from the thigh's, the foot's from the knee's, and the IK copies are planar chains.
    const Approximation& a = mergedLeg().merged;
    std::mt19937 rng(8);
    for (int trial = 0; trial < 10; ++trial) {
        CAPTURE(trial);
        const std::vector<double> values = test::randomValues(a, rng, 0.5);
        JacobianEvaluator evaluator(a, jointTargetsAt(a, test::randomValues(a, rng, 0.5)), 10.0);
        Eigen::MatrixXd analytic, numeric;
        Eigen::VectorXd r1, r2;
        evaluator.jacobian(values, JacobianMethod::analytic, 0.0, analytic, r1);
        evaluator.jacobian(values, JacobianMethod::finiteDifference, 1e-6, numeric, r2);
        CHECK((analytic - numeric).cwiseAbs().maxCoeff() < 1e-5 * std::max(1.0, analytic.cwiseAbs().maxCoeff()));
        CHECK(analytic.col(analytic.cols() - 1).norm() > 0.0);  // the weight, last
    }
}

TEST_CASE("blend: random poses of the left leg with a random ikFk weight are recovered from rest on the real rig")
{
    MergedLeg& leg = mergedLeg();
    const Approximation& a = leg.merged;
    const Solver solver(a, SolverOptions{});
    const auto& parameters = leg.rig.parameters();
    const std::vector<std::size_t> index = leg.mergedOutputs();
    std::mt19937 rng(32);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<double> truth(parameters.size()), solved(parameters.size());
    std::vector<Eigen::Matrix4d> real, reached;
    int recovered = 0;
    double worstOfAll = 0.0;
    const int poses = 30;
    for (int pose = 0; pose < poses; ++pose) {
        halfRangePose(parameters, rng, truth);  // the switch then anywhere in [0, 1]
        truth.back() = unit(rng);
        leg.rig.evaluate(truth, real);
        std::vector<JointTarget> targets(a.outputs.size());
        for (std::size_t k = 0; k < index.size(); ++k) targets[index[k]] = JointTarget{true, real[k]};
        std::vector<double> values = a.defaults();
        solver.initialGuess(targets, values);
        SolveSummary summary;
        solver.solveCold(targets, values, summary);
        // Judged on the real rig at the values found (mapped back by name).
        for (std::size_t p = 0; p < a.parameters.size(); ++p) {
            const auto it = std::find_if(parameters.begin(), parameters.end(), [&](const RigParameter& r) {
                return r.name == a.parameters[p].parameter.name;
            });
            solved[static_cast<std::size_t>(it - parameters.begin())] = values[p];
        }
        leg.rig.evaluate(solved, reached);
        double worst = 0.0;
        for (std::size_t k = 0; k < real.size(); ++k)
            worst = std::max(worst, (reached[k].block<3, 1>(0, 3) - real[k].block<3, 1>(0, 3)).norm());
        recovered += worst < 1e-3 ? 1 : 0;
        worstOfAll = std::max(worstOfAll, worst);
    }
    MESSAGE("random poses of the switched left leg reached from rest on the real rig: "
            << recovered << " of " << poses << ", worst " << worstOfAll << " cm");
    // 25 of 30 measured (22 before a solve that misses the switched leg tries again from the other branch's end,
    // guessed anew there). Four misses end stuck (2.5 to 5.8 cm at the foot) with the weight away from the truth's,
    // near the IK branch: local minima of the blended leg's redundant controls, not the Jacobian (checked above). One
    // (50.9 cm) converges on the approximation with the FK thigh's rotateY at -139 degrees, past its learned range,
    // where the blend reads the FK thigh's Euler angles as the triple nearest rest and the rig blends its raw channels.
    CHECK(recovered >= 25);
}

namespace {

// rig-learn's work on rigs/biped_inversion_ikfk.yaml (both legs' switches animated), with the rig of its parameters;
// once per run.
struct TwoLegs {
    static app::LearnJob job()
    {
        const InversionSpec spec = readInversionSpec(test::sourceDir() / "rigs" / "biped_inversion_ikfk.yaml");
        app::LearnJob job{(test::sourceDir() / "rigs" / "biped.yaml").string(), spec.params, spec.outputs, {}, {}, {}};
        job.held = spec.set;
        return job;
    }
    app::LearnOutcome learned = app::learn(job());
    GraphRigFunction rig{job().rig, app::rigOptions(job())};
};

TwoLegs& twoLegs()
{
    static TwoLegs legs;
    return legs;
}

}  // namespace

TEST_CASE("blend: rig-learn's biped with both switches animated blends each leg by its own switch, within epsilon")
{
    TwoLegs& legs = twoLegs();
    const Approximation& a = legs.learned.approximation;
    CHECK(!a.hasUnmodelledOutputs());
    CHECK(legs.learned.unmodelled.empty());
    CHECK(a.discarded.empty());
    // Measured against the rig with the switches as parameters, drawn in [0, 1] like every control in its range.
    CHECK(a.validation.poses == 60);
    CHECK(a.validation.withinEpsilon);
    CHECK(a.validation.maxPositionErrorCm < 1e-3);
    // The weights last, each blend reading its own leg's.
    const std::size_t n = a.parameters.size();
    CHECK(a.parameters[n - 2].parameter.name == "L_leg_settings.ikFk");
    CHECK(a.parameters[n - 1].parameter.name == "R_leg_settings.ikFk");
    std::vector<std::string> blends;
    for (const ApproximationOutput& o : a.outputs)
        if (o.constraint >= 0 && a.constraints[static_cast<std::size_t>(o.constraint)].kind == ConstraintKind::blend)
            blends.push_back(
                o.name + " by " +
                a.parameters[static_cast<std::size_t>(a.constraints[static_cast<std::size_t>(o.constraint)].weight)]
                    .parameter.name);
    CHECK(blends == std::vector<std::string>{"LeftUpLeg by L_leg_settings.ikFk", "LeftLeg by L_leg_settings.ikFk",
                                             "LeftFoot by L_leg_settings.ikFk", "RightUpLeg by R_leg_settings.ikFk",
                                             "RightLeg by R_leg_settings.ikFk", "RightFoot by R_leg_settings.ikFk"});
    // Each switch's own FK controls held at the IK branch, and its IK controls at the FK branch.
    const std::vector<SwitchHold> holds = switchHolds(a);
    REQUIRE(holds.size() == 2);
    const auto names = [&](const std::vector<int>& ps) {
        std::vector<std::string> out;
        for (const int p : ps) out.push_back(a.parameters[static_cast<std::size_t>(p)].parameter.name);
        std::sort(out.begin(), out.end());
        return out;
    };
    CHECK(names(holds[0].fk) == std::vector<std::string>{"L_knee_fk_ctrl.rotateX", "L_upLeg_fk_ctrl.rotateX",
                                                         "L_upLeg_fk_ctrl.rotateY", "L_upLeg_fk_ctrl.rotateZ"});
    CHECK(names(holds[1].ik) == std::vector<std::string>{"R_leg_ik_ctrl.translateX", "R_leg_ik_ctrl.translateY",
                                                         "R_leg_ik_ctrl.translateZ", "R_leg_pole_ctrl.translateX",
                                                         "R_leg_pole_ctrl.translateY", "R_leg_pole_ctrl.translateZ"});
    // The file loads the rig as rig-invert does (the switches parameters, the branch copies not the rig's joints),
    // with the fingerprint it records.
    const Approximation read = approximationFromYaml(approximationToYaml(a), "ikfk.yaml");
    CHECK(read.held.size() == 2);  // the stretch, not the switches
    GraphRigFunction rig(test::sourceDir() / "rigs" / "biped.yaml", rigOptionsFor(read));
    CHECK(rig.fingerprint() == read.rigFingerprint);
    CHECK(rig.parameters().size() == read.parameters.size());
    RigBinding binding(read, rig);
    std::vector<Eigen::Matrix4d> real, model;
    binding.evaluate(read.defaults(), real);
    read.evaluate(read.defaults(), model);
    // At rest (both switches at 0, FK) every joint as the approximation has it; a branch copy reads its joint, which is
    // the IK copy's frame only at the IK end (the biped's IK thigh rests a quarter turn from its FK thigh).
    for (std::size_t k = 0; k < real.size(); ++k) {
        INFO(read.outputs[k].name);
        const std::string name = read.outputs[k].name;
        CHECK((matrixError(real[k], model[k], 10.0) < 1e-6) == !name.ends_with("@ik"));
    }
}

TEST_CASE(
    "blend: without helper frames the IK legs are not modelled, so not blended: their switches move them on the "
    "real rig only")
{
    app::LearnJob job = TwoLegs::job();
    job.noHelpers = true;
    const app::LearnOutcome learned = app::learn(job);
    const Approximation& a = learned.approximation;
    // The IK branch's thighs, knees, feet and toes, as the IK spec learned without helpers leaves them.
    std::vector<std::string> unmodelled;
    for (const ApproximationOutput& o : a.outputs)
        if (!o.modelled) unmodelled.push_back(o.name);
    CHECK(unmodelled == std::vector<std::string>{"LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "RightUpLeg",
                                                 "RightLeg", "RightFoot", "RightToeBase"});
    CHECK(a.constraints.empty());
    CHECK(a.validation.withinEpsilon);
    const auto parameter = [&](const std::string& name) {
        return *std::find_if(a.parameters.begin(), a.parameters.end(),
                             [&](const ModelledParameter& m) { return m.parameter.name == name; });
    };
    const ModelledParameter weight = parameter("L_leg_settings.ikFk");
    CHECK(weight.outputs.empty());
    CHECK(weight.unmodelledOutputs.size() == 3);
    CHECK(app::storedForm(weight) == "none (real rig only)");
    const ModelledParameter fk = parameter("L_upLeg_fk_ctrl.rotateX");
    CHECK(fk.outputs.empty());
    CHECK(fk.unmodelledOutputs.size() == 1);
    // A file rig-invert loads (a blend reading an unmodelled copy would be refused).
    CHECK(approximationFromYaml(approximationToYaml(a), "hybrid.yaml").parameters.size() == a.parameters.size());
}

TEST_CASE("blend: random poses with random ikFk weights are recovered from rest on the real rig with both legs blended")
{
    TwoLegs& legs = twoLegs();
    const Approximation& a = legs.learned.approximation;
    const Solver solver(a, SolverOptions{});
    GraphRigFunction& rig = legs.rig;
    const auto& parameters = rig.parameters();
    REQUIRE(parameters.size() == a.parameters.size());
    std::vector<std::size_t> index;  // per approximation parameter, the rig's
    for (const ModelledParameter& m : a.parameters)
        index.push_back(
            static_cast<std::size_t>(std::find_if(parameters.begin(), parameters.end(),
                                                  [&](const RigParameter& r) { return r.name == m.parameter.name; }) -
                                     parameters.begin()));
    std::vector<int> target(a.outputs.size(), -1);  // per approximation output, the rig's joint
    for (std::size_t k = 0; k < a.outputs.size(); ++k)
        if (!a.outputs[k].helper)
            target[k] = static_cast<int>(std::find(rig.outputs().begin(), rig.outputs().end(), a.outputs[k].name) -
                                         rig.outputs().begin());
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<double> truth(parameters.size()), solved(parameters.size());
    std::vector<Eigen::Matrix4d> real, reached;
    int recovered = 0, recoveredWarm = 0;
    double worstOfAll = 0.0;
    const int poses = 30;
    for (int pose = 0; pose < poses; ++pose) {
        halfRangePose(parameters, rng, truth);  // the switches then anywhere in [0, 1]
        for (const char* weight : {"L_leg_settings.ikFk", "R_leg_settings.ikFk"})
            truth[static_cast<std::size_t>(std::find_if(parameters.begin(), parameters.end(),
                                                        [&](const RigParameter& r) { return r.name == weight; }) -
                                           parameters.begin())] = unit(rng);
        rig.evaluate(truth, real);
        std::vector<JointTarget> targets(a.outputs.size());
        for (std::size_t k = 0; k < a.outputs.size(); ++k)
            if (target[k] >= 0) targets[k] = JointTarget{true, real[static_cast<std::size_t>(target[k])]};
        std::vector<double> guess = a.defaults();
        solver.initialGuess(targets, guess);
        // From the guess: a cold solve (the other branch tried where a switched joint is missed), and solve() as a
        // warm-started frame runs it, which never flips a switch.
        for (const bool cold : {true, false}) {
            std::vector<double> values = guess;
            SolveSummary summary;
            if (cold) solver.solveCold(targets, values, summary);
            else solver.solve(targets, values, summary);
            for (std::size_t p = 0; p < a.parameters.size(); ++p) solved[index[p]] = values[p];
            rig.evaluate(solved, reached);
            double worst = 0.0;
            for (std::size_t k = 0; k < real.size(); ++k)
                if (!rig.helperOutputs()[k])
                    worst = std::max(worst, (reached[k].block<3, 1>(0, 3) - real[k].block<3, 1>(0, 3)).norm());
            (cold ? recovered : recoveredWarm) += worst < 1e-3 ? 1 : 0;
            if (cold) worstOfAll = std::max(worstOfAll, worst);
        }
    }
    MESSAGE("random poses of the biped with both legs switched reached from rest on the real rig: "
            << recovered << " of " << poses << ", worst " << worstOfAll << " cm; by solve() alone " << recoveredWarm);
    // 18 of 30 measured (96 of 150 with other seeds; 14 of 30 and 78 of 150 before a solve that misses a switched leg
    // tries the other branch's end, 16 and 87 without guessing anew from there): a miss ends stuck at a foot with its
    // weight away from the truth's, as on the left leg alone (above), in either leg.
    CHECK(recovered >= 18);
    CHECK(recoveredWarm == 14);  // solve() never tries the other branch
}

TEST_CASE("blend: a damaged blend is one line naming file:line:col and the field")
{
    CHECK(blendErrorWith("", "") == "(no error)");
    CHECK(blendErrorWith("mode: eulerChannels", "mode: lerp") ==
          "f.yaml:56:11: constraints[0].mode: unknown blend 'lerp'; the blends are eulerChannels and slerp");
    CHECK(blendErrorWith("    order: yzx\n", "") ==
          "f.yaml:49:5: constraints[0]: an eulerChannels blend needs `order`, the rotate order its angles are read in");
    CHECK(blendErrorWith("order: yzx", "order: xyy") ==
          "f.yaml:57:12: constraints[0].order: not a rotate order; it is one of xyz, yzx, zxy, xzy, yxz, zyx");
    CHECK(blendErrorWith("mode: eulerChannels", "mode: slerp") ==
          "f.yaml:57:12: constraints[0].order: a slerp has no rotate order; remove it");
    // The weight is a parameter limited to [0, 1]; another parameter named instead leaves the weight moving nothing.
    CHECK(blendErrorWith("weight: \"settings.ikFk\"", "weight: \"hip_ctrl.rotateX\"") ==
          "f.yaml:137:14: parameters[4].outputs: a parameter affects at least one output");
    CHECK(blendErrorWith("\"settings.ikFk\"\n    default: 0\n    min: 0\n    max: 1\n",
                         "\"settings.ikFk\"\n    default: 0\n    min: 0\n    max: 2\n") ==
          "f.yaml:55:13: constraints[0].weight: 'settings.ikFk' is not limited to [0, 1]; a blend's weight is a "
          "switch's (re-run rig-learn)");
    CHECK(blendErrorWith("fk: \"thigh_fk\"", "fk: \"thigh_ik\"") ==
          "f.yaml:52:9: constraints[0].fk: is the IK branch too; a blend has two branches");
    CHECK(
        blendErrorWith("ik: \"thigh_ik\"", "ik: \"thigh\"") ==
        "f.yaml:41:17: outputs[3].constraint: constraints[0] reads 'thigh' itself; a constraint reads outputs learned "
        "before its output");
    CHECK(
        blendErrorWith("    weight:", "    wait: 1\n    weight:")
            .find("constraints[0]: unknown field 'wait'; the fields are kind, ik, fk, weight, mode, anchor, ikParent, "
                  "fkParent, order") != std::string::npos);
}

}  // namespace rig
