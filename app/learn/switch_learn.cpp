#include "app/learn/switch_learn.h"

#include <algorithm>
#include <chrono>
#include <random>
#include <set>

#include <fmt/format.h>
#include <Eigen/LU>

#include "core/error.h"
#include "inversion/learn/blend_merge.h"
#include "inversion/learn/constraint_fit.h"

namespace rig::app {
namespace {

// Random poses whose blends are fitted: enough that a wrong rotate order shows (the biped's thigh), and a few
// hundred rig evaluations.
constexpr int blendPoses = 40;
// A blend reproduces the rig's channels exactly: the first rule within rounding is the rig's (cm, matrixError).
constexpr double blendTolerance = 1e-6;

bool isSwitch(const RigSwitches& s, std::size_t p)
{
    return std::binary_search(s.switches.begin(), s.switches.end(), static_cast<int>(p));
}

// The rig learned with every switch held at `value`: the other parameters by name, the switches added to the held
// plugs.
Approximation learnBranch(const LearnJob& job, const GraphRigFunction& rig, const RigSwitches& s, double value,
                          std::vector<UnmodelledOutput>& unmodelled)
{
    GraphRigOptions options = rigOptions(job);
    options.parameterGlobs.clear();
    options.autoParameters = false;  // what auto chose is named below: parameters, and settings among the held
    options.held = rig.held();
    for (std::size_t p = 0; p < rig.parameters().size(); ++p) {
        if (isSwitch(s, p)) options.held.push_back({rig.parameters()[p].name, value});
        else options.parameterGlobs.push_back(rig.parameters()[p].name);
    }
    GraphRigFunction branch(job.rig, options);
    return learnApproximation(branch, job.options, job.rig, &unmodelled);
}

// Per switched output (rig order), its blend's samples: random poses, the output relative to its parent output with
// every switch at 1, at 0 and at the pose's weights.
std::vector<std::vector<BlendSample>> blendSamples(GraphRigFunction& rig, const RigSwitches& s, std::uint32_t seed)
{
    const auto& parameters = rig.parameters();
    const std::vector<int> parents = rig.outputParents();
    std::vector<std::vector<BlendSample>> samples(rig.outputs().size());
    std::mt19937 rng(seed);
    std::vector<double> values(parameters.size());
    std::vector<Eigen::Matrix4d> ik, fk, blended;
    const auto local = [&](const std::vector<Eigen::Matrix4d>& worlds, std::size_t k) {
        const int p = parents[k];
        return p < 0 ? worlds[k] : Eigen::Matrix4d(worlds[static_cast<std::size_t>(p)].inverse() * worlds[k]);
    };
    const auto atSwitches = [&](double value, std::vector<Eigen::Matrix4d>& worlds) {
        std::vector<double> held = values;
        for (const int p : s.switches) held[static_cast<std::size_t>(p)] = value;
        rig.evaluate(held, worlds);
    };
    for (int pose = 0; pose < blendPoses; ++pose) {
        for (std::size_t p = 0; p < parameters.size(); ++p)
            values[p] = std::uniform_real_distribution<double>(parameters[p].min, parameters[p].max)(rng);
        atSwitches(1.0, ik);
        atSwitches(0.0, fk);
        rig.evaluate(values, blended);
        for (std::size_t k = 0; k < samples.size(); ++k)
            if (const int w = s.switchOfOutput[k]; w >= 0)
                samples[k].push_back(
                    {values[static_cast<std::size_t>(w)], local(ik, k), local(fk, k), local(blended, k)});
    }
    return samples;
}

// The branches' switched outputs with their parents, blends and weights.
SwitchBranches branchesOf(GraphRigFunction& rig, const RigSwitches& s, const LearnOptions& options)
{
    SwitchBranches branches;
    for (const int p : s.switches) branches.weights.push_back(rig.parameters()[static_cast<std::size_t>(p)]);
    const std::vector<std::vector<BlendSample>> samples = blendSamples(rig, s, options.seed);
    const std::vector<int> parents = rig.outputParents();
    for (std::size_t k = 0; k < samples.size(); ++k) {
        if (samples[k].empty()) continue;
        // None within rounding: the nearest, which the validation measures (over epsilon, rig-learn exits 3).
        BlendFit closest;
        const std::optional<BlendFit> fit = fitBlendRule(samples[k], blendTolerance, options.frameRadius, &closest);
        const int weight =
            static_cast<int>(std::find(s.switches.begin(), s.switches.end(), s.switchOfOutput[k]) - s.switches.begin());
        const int parent = parents[k];
        branches.switched.push_back({rig.outputs()[k],
                                     parent < 0 ? "" : rig.outputs()[static_cast<std::size_t>(parent)],
                                     fit ? fit->rule : closest.rule, weight});
    }
    return branches;
}

}  // namespace

Approximation learnSwitched(const LearnJob& job, GraphRigFunction& rig, const RigSwitches& switches,
                            std::vector<UnmodelledOutput>& unmodelled)
{
    const auto start = std::chrono::steady_clock::now();
    const std::uint64_t evaluationsBefore = rig.evaluationCount();
    std::vector<UnmodelledOutput> fkUnmodelled;
    const Approximation ik = learnBranch(job, rig, switches, 1.0, unmodelled);
    const Approximation fk = learnBranch(job, rig, switches, 0.0, fkUnmodelled);
    SwitchBranches branches = branchesOf(rig, switches, job.options);
    branches.ik = &ik;
    branches.fk = &fk;
    Approximation merged = mergeSwitchBranches(branches);
    std::set<std::string> switched;
    for (const SwitchBranches::Switched& w : branches.switched) switched.insert(w.output);
    for (UnmodelledOutput& u : fkUnmodelled) {
        if (switched.contains(u.name)) u.name += "@fk";
        else if (std::any_of(ik.outputs.begin(), ik.outputs.end(),
                             [&](const ApproximationOutput& o) { return o.name == u.name; }))
            continue;  // the IK branch's modelling is kept
        unmodelled.push_back(std::move(u));
    }
    // The file is the rig's with the switches as parameters: rig-invert loads it so.
    merged.rigFingerprint = rig.fingerprint();
    merged.held = rig.held();
    validateApproximation(rig, merged, job.options);
    merged.training.evaluations =
        ik.training.evaluations + fk.training.evaluations + (rig.evaluationCount() - evaluationsBefore);
    merged.training.orderEvaluations = ik.training.orderEvaluations + fk.training.orderEvaluations;
    merged.training.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return merged;
}

}  // namespace rig::app
