#include "inversion/learn/learner.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <thread>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "core/error.h"
#include "core/rotation_math.h"
#include "inversion/learn/classifier.h"
#include "inversion/learn/constraint_fit.h"
#include "inversion/learn/ordering.h"
#include "inversion/learn/rig_pool.h"

namespace rig {

std::vector<std::pair<int, int>> redundantParameters(const Approximation& approximation, double tolerance,
                                                     double frameRadius)
{
    std::vector<std::pair<int, int>> pairs;
    const auto& ps = approximation.parameters;
    for (std::size_t i = 0; i < ps.size(); ++i)
        for (std::size_t j = i + 1; j < ps.size(); ++j) {
            if (ps[i].outputs.empty() || ps[i].outputs != ps[j].outputs) continue;
            const double lo = std::max(ps[i].parameter.min - ps[i].parameter.defaultValue,
                                       ps[j].parameter.min - ps[j].parameter.defaultValue);
            const double hi = std::min(ps[i].parameter.max - ps[i].parameter.defaultValue,
                                       ps[j].parameter.max - ps[j].parameter.defaultValue);
            if (!(hi > lo)) continue;
            bool same = true;
            for (int s = 0; s <= 4 && same; ++s) {
                const double a = lo + (hi - lo) * s / 4.0;
                for (std::size_t e = 0; e < ps[i].outputs.size() && same; ++e) {
                    const Eigen::Matrix4d& rest =
                        approximation.outputs[static_cast<std::size_t>(ps[i].outputs[e])].rest;
                    const Operator& u = ps[i].operators[static_cast<std::size_t>(ps[i].operatorOfOutput[e])];
                    const Operator& v = ps[j].operators[static_cast<std::size_t>(ps[j].operatorOfOutput[e])];
                    same = matrixError(u.matrix(a) * rest, v.matrix(a) * rest, frameRadius) <= tolerance;
                }
            }
            if (same) pairs.emplace_back(static_cast<int>(i), static_cast<int>(j));
        }
    return pairs;
}

namespace {

// Validation poses, drawn once (a value for every parameter in rig order, whether modelled or not, so
// that the poses do not depend on the composition order or on the frames), and the rig's worlds
// there, evaluated once however many frame choices are validated on them.
struct ValidationPoses {
    std::vector<std::vector<double>> drawn;
    std::vector<int> movedSet;                         // the parameters `worlds` moved (the modelled ones)
    std::vector<std::vector<Eigen::Matrix4d>> worlds;  // raw, per pose
};

ValidationPoses drawPoses(const std::vector<RigParameter>& parameters, const LearnOptions& options)
{
    ValidationPoses poses;
    std::mt19937 rng(options.seed);
    for (int pose = 0; pose < options.validationPoses + options.limitPoses; ++pose) {
        std::vector<double> values;
        const bool limits = pose >= options.validationPoses;
        for (const RigParameter& p : parameters)
            values.push_back(limits ? (std::bernoulli_distribution(0.5)(rng) ? p.max : p.min)
                                    : std::uniform_real_distribution<double>(p.min, p.max)(rng));
        poses.drawn.push_back(std::move(values));
    }
    return poses;
}

// A validation pose's values: every rig parameter (the others at their defaults), the modelled ones in composition
// order, and per modelled parameter its offset from its default and the share of its range that is.
struct PoseValues {
    std::vector<double> rig, modelled, offsets, shares;
};

PoseValues poseValues(std::vector<double> defaults, const std::vector<double>& drawn,
                      const Approximation& approximation, const std::vector<int>& indices)
{
    PoseValues v{std::move(defaults), {}, {}, {}};
    for (std::size_t p = 0; p < approximation.parameters.size(); ++p) {
        const auto i = static_cast<std::size_t>(indices[p]);
        const RigParameter& param = approximation.parameters[p].parameter;
        v.rig[i] = drawn[i];
        v.modelled.push_back(drawn[i]);
        v.offsets.push_back(std::abs(drawn[i] - param.defaultValue));
        v.shares.push_back(v.offsets.back() / std::max(param.max - param.min, 1e-300));
    }
    return v;
}

// An output's error relative to what moved it (the modelled parameters `reachedBy` it): epsilon bounds the error
// per unit of the parameters moved. With the parameter moved furthest through its range, or -1.
std::pair<double, int> relativeError(const Eigen::Matrix4d& truth, const Eigen::Matrix4d& approximated,
                                     const std::vector<int>& reachedBy, const PoseValues& v, double frameRadius)
{
    double moved = 0.0;
    int furthest = -1;
    for (const int p : reachedBy) {
        moved += v.offsets[static_cast<std::size_t>(p)];
        if (furthest < 0 || v.shares[static_cast<std::size_t>(p)] > v.shares[static_cast<std::size_t>(furthest)])
            furthest = p;
    }
    const double error = matrixError(truth, approximated, frameRadius);
    const double relative = error <= 1e-12 ? 0.0 : moved > 0.0 ? error / moved : std::numeric_limits<double>::max();
    return {relative, furthest};
}

// Whether output k is a twist share whose twist is undefined at the approximation's worlds or the rig's
// (twistSingular): the rig's twist jumps there by rounding, so no model can agree with it. The rig's too: a driver
// learned with a constraint (an IK hand) is off the rig's by its shape's error, which decides the approximation's
// twist where the rig's is undefined (47 degrees off at a limit pose of a random IK arm).
bool undefinedTwist(const Approximation& a, const std::vector<Eigen::Matrix4d>& approximated,
                    const std::vector<Eigen::Matrix4d>& truth, const std::vector<int>& rigOutput, std::size_t k)
{
    const int c = a.outputs[k].constraint;
    if (c < 0 || a.constraints[static_cast<std::size_t>(c)].kind != ConstraintKind::twistShare) return false;
    const ConstraintBase& base = a.constraints[static_cast<std::size_t>(c)];
    const auto singular = [&](const auto& world) {
        const auto rotation = [&](int i) -> Eigen::Matrix3d {
            return i < 0 ? Eigen::Matrix3d::Identity() : polarRotation(world(i).template block<3, 3>(0, 0));
        };
        return twistSingular(base, rotation(base.driverParent).transpose() * rotation(base.driver));
    };
    return singular([&](int i) { return approximated[static_cast<std::size_t>(i)]; }) ||
           singular([&](int i) { return truth[static_cast<std::size_t>(rigOutput[static_cast<std::size_t>(i)])]; });
}

// The approximation against the real rig on the poses, with only the modelled parameters moved.
// `positionErrors` (may be null): per output, its worst position error, cm.
ValidationSummary validate(RigProbe& probe, Approximation& approximation, const std::vector<int>& indices,
                           const std::vector<int>& rigOutput, ValidationPoses& poses, const LearnOptions& options,
                           std::vector<double>* positionErrors = nullptr)
{
    ValidationSummary summary;
    summary.poses = static_cast<int>(poses.drawn.size());
    const std::vector<std::vector<int>> reach = approximation.reach();
    std::vector<std::vector<int>> reachedBy(approximation.outputs.size());
    for (std::size_t p = 0; p < reach.size(); ++p)
        for (const int k : reach[p]) reachedBy[static_cast<std::size_t>(k)].push_back(static_cast<int>(p));
    for (auto& o : approximation.outputs) o.validationError = 0.0;
    for (auto& m : approximation.parameters) m.validationError = 0.0;
    if (positionErrors) positionErrors->assign(approximation.outputs.size(), 0.0);
    std::vector<Eigen::Matrix4d> approximated;
    double positionSum = 0.0, rotationSum = 0.0;
    std::size_t count = 0;
    // The poses move the modelled parameters only: the rig is evaluated again when that set changed.
    std::vector<int> movedSet = indices;
    std::sort(movedSet.begin(), movedSet.end());
    const bool evaluate = poses.worlds.size() != poses.drawn.size() || poses.movedSet != movedSet;
    poses.worlds.resize(poses.drawn.size());
    poses.movedSet = movedSet;
    for (std::size_t pose = 0; pose < poses.drawn.size(); ++pose) {
        const PoseValues drawn = poseValues(probe.defaults(), poses.drawn[pose], approximation, indices);
        auto& truthWorlds = poses.worlds[pose];
        if (evaluate) truthWorlds = probe.atValues(drawn.rig);
        approximation.evaluate(drawn.modelled, approximated);
        bool finite = true;
        for (const int k : rigOutput)
            finite = finite && (k < 0 || truthWorlds[static_cast<std::size_t>(k)].allFinite());
        if (!finite) {
            ++summary.nonFinitePoses;
            continue;
        }
        for (std::size_t k = 0; k < approximated.size(); ++k) {
            // Not predicted, or not a rig output (a blend's branch copy, measured through its blend): not measured.
            if (!approximation.outputs[k].modelled || rigOutput[k] < 0) continue;
            if (undefinedTwist(approximation, approximated, truthWorlds, rigOutput, k)) {
                if (summary.singularPoses++ == 0) summary.singularOutput = approximation.outputs[k].name;
                continue;
            }
            const Eigen::Matrix4d& truth = truthWorlds[static_cast<std::size_t>(rigOutput[k])];
            const double position = (truth.block<3, 1>(0, 3) - approximated[k].block<3, 1>(0, 3)).norm();
            const double rotation =
                orientationAngle(truth.topLeftCorner<3, 3>(), approximated[k].topLeftCorner<3, 3>()) * 180.0 /
                std::numbers::pi;
            if (positionErrors) (*positionErrors)[k] = std::max((*positionErrors)[k], position);
            positionSum += position;
            rotationSum += rotation;
            ++count;
            if (position > summary.maxPositionErrorCm || summary.worstPose < 0) {
                summary.maxPositionErrorCm = std::max(summary.maxPositionErrorCm, position);
                if (position >= summary.maxPositionErrorCm) {
                    summary.worstOutput = approximation.outputs[k].name;
                    summary.worstPose = static_cast<int>(pose);
                }
            }
            summary.maxRotationErrorDeg = std::max(summary.maxRotationErrorDeg, rotation);
            const auto [relative, furthest] =
                relativeError(truth, approximated[k], reachedBy[k], drawn, options.frameRadius);
            approximation.outputs[k].validationError = std::max(approximation.outputs[k].validationError, relative);
            for (const int p : reachedBy[k]) {
                auto& v = approximation.parameters[static_cast<std::size_t>(p)].validationError;
                v = std::max(v, relative);
            }
            if (relative > summary.maxRelativeError) {
                summary.maxRelativeError = relative;
                summary.worstRelativeOutput = approximation.outputs[k].name;
                summary.worstParameter =
                    furthest < 0 ? std::string()
                                 : approximation.parameters[static_cast<std::size_t>(furthest)].parameter.name;
            }
        }
        if (options.progress)
            options.progress("validating", static_cast<double>(pose + 1) / static_cast<double>(poses.drawn.size()));
    }
    if (count > 0) {
        summary.meanPositionErrorCm = positionSum / static_cast<double>(count);
        summary.meanRotationErrorDeg = rotationSum / static_cast<double>(count);
    }
    summary.withinEpsilon = summary.maxRelativeError <= options.epsilon && summary.nonFinitePoses == 0;
    return summary;
}

// A parameter with no effect on its own may still change what others do (the axis of a bend that
// turns with it): move it at a few random poses of the modelled parameters and look.
std::string couplingReason(RigProbe& probe, const RigParameter& parameter, int index,
                           const Approximation& approximation, const std::vector<int>& indices,
                           const std::vector<int>& rigOutput, const LearnOptions& options)
{
    std::mt19937 rng(options.seed + 7919u * static_cast<std::uint32_t>(index));
    for (int pose = 0; pose < 3; ++pose) {
        std::vector<double> values = probe.defaults();
        for (std::size_t p = 0; p < approximation.parameters.size(); ++p) {
            const RigParameter& param = approximation.parameters[p].parameter;
            values[static_cast<std::size_t>(indices[p])] =
                std::uniform_real_distribution<double>(param.min, param.max)(rng);
        }
        const std::vector<Eigen::Matrix4d> held = probe.atValues(values);
        values[static_cast<std::size_t>(index)] =
            parameter.max != parameter.defaultValue ? parameter.max : parameter.min;
        const std::vector<Eigen::Matrix4d>& moved = probe.atValues(values);
        for (std::size_t o = 0; o < rigOutput.size(); ++o) {
            const auto k = static_cast<std::size_t>(rigOutput[o]);
            const double change = matrixError(held[k], moved[k], options.frameRadius);
            if (change > options.effectTolerance)
                return fmt::format(
                    "no effect on its own, but it changes what other parameters do (coupled: {} moved by "
                    "{:.3g} cm at a random pose); it is held at its rest value",
                    approximation.outputs[o].name, change);
        }
    }
    return {};
}

// Removes the outputs flagged in `remove` from a classification (with their operators when no output is left
// using them), and returns them.
std::vector<int> removeOutputs(Classification& c, const std::vector<char>& remove)
{
    ModelledParameter& m = c.model;
    std::vector<int> outputs, operatorOfOutput, removed;
    std::vector<Eigen::Matrix4d> orderWorlds;
    for (std::size_t e = 0; e < m.outputs.size(); ++e) {
        if (remove[static_cast<std::size_t>(m.outputs[e])]) {
            removed.push_back(m.outputs[e]);
            continue;
        }
        outputs.push_back(m.outputs[e]);
        operatorOfOutput.push_back(m.operatorOfOutput[e]);
        orderWorlds.push_back(c.orderWorlds[e]);
    }
    if (removed.empty()) return removed;
    // Keep only the operators still used, renumbered.
    std::vector<int> renumber(m.operators.size(), -1);
    std::vector<Operator> operators;
    for (int& o : operatorOfOutput) {
        auto& r = renumber[static_cast<std::size_t>(o)];
        if (r < 0) {
            r = static_cast<int>(operators.size());
            operators.push_back(m.operators[static_cast<std::size_t>(o)]);
        }
        o = r;
    }
    m.outputs = std::move(outputs);
    m.operatorOfOutput = std::move(operatorOfOutput);
    m.operators = std::move(operators);
    c.orderWorlds = std::move(orderWorlds);
    return removed;
}

// Drops the unreliable outputs from a classification; a parameter left with no output is no longer modelled.
// Its non-compositional outputs move to model.unmodelledOutputs (rig indices here): a parameter left with
// those only stays, without operators.
void classifyOutputs(Classification& c, const RigState& state)
{
    if (!removeOutputs(c, state.unreliable).empty() && c.model.outputs.empty()) {
        c.modelled = false;
        c.reason = "its only effect is on outputs found history-dependent (they do not come back to their rest pose)";
        return;
    }
    c.model.unmodelledOutputs = removeOutputs(c, state.nonCompositional);
    if (c.model.outputs.empty() && !c.model.unmodelledOutputs.empty())
        c.model.form = "non-compositional (real rig only)";
}

// An output whose rest world has no inverse (a zero scale) or is not finite: no delta can be taken on it.
std::string singularRest(const Eigen::Matrix4d& rest)
{
    if (!rest.allFinite()) return "its rest world matrix is not finite";
    const Eigen::Matrix3d linear = rest.block<3, 3>(0, 0);
    const Eigen::Vector3d sigma = Eigen::JacobiSVD<Eigen::Matrix3d>(linear).singularValues();
    if (nearlySingular(sigma))
        return fmt::format("its rest world matrix is singular (singular values {:.3g}, {:.3g}, {:.3g}: a zero scale?)",
                           sigma[0], sigma[1], sigma[2]);
    return {};
}

// Whether a parameter's fit interpolates samples (a curve magnitude or a sampled operator): more samples
// can make it better between them.
bool interpolated(const ModelledParameter& m)
{
    return std::any_of(m.operators.begin(), m.operators.end(),
                       [](const Operator& op) { return !op.linear() || op.traits().sampled; });
}

// The probe's constraint operators into the approximation, their inputs as its output indices. An output whose
// constraint reads an output left out (found history-dependent since) is not modelled.
void addConstraints(const RigProbe& probe, const std::vector<int>& outputIndex, const std::vector<int>& rigOutput,
                    Approximation& result)
{
    for (std::size_t o = 0; o < result.outputs.size(); ++o) {
        const auto c = probe.constraints.find(rigOutput[o]);
        if (c == probe.constraints.end() || !result.outputs[o].modelled) continue;
        ConstraintBase base = c->second;
        const auto map = [&](int& k) {
            if (k < 0) return true;
            k = outputIndex[static_cast<std::size_t>(k)];
            return k >= 0;
        };
        const auto fields = base.outputFields();
        if (!std::all_of(fields.begin(), fields.end(), [&](int* k) { return map(*k); })) {
            result.outputs[o].modelled = false;
            continue;
        }
        result.outputs[o].parent = -1;
        result.outputs[o].constraint = static_cast<int>(result.constraints.size());
        result.constraints.push_back(std::move(base));
    }
}

// One learning pass in the probe's frames: classify (from stored samples where possible), order,
// assemble and validate.
struct Pass {
    Approximation approximation;
    std::vector<Classification> classes;
    OrderResult order;
    std::vector<int> indices;            // per modelled parameter, its rig index
    std::vector<int> rigOutput;          // per approximation output, its rig index
    std::vector<double> positionErrors;  // per approximation output, its worst position error at validation, cm
};

// `budgets`: per rig parameter, the most samples it may use (LearnOptions::maxSamples, raised by repairs).
// `distrusted`: rig outputs where every pair is tested on the rig (ordering.h).
// `held`: parameters held at rest, each with why (ConstraintFitter::held): classified as not modelled.
Pass learnPass(RigProbe& probe, RigState& state, std::vector<ParameterSamples>& samples, ValidationPoses& poses,
               const LearnOptions& options, const std::vector<int>& budgets, const std::set<int>& distrusted,
               const std::map<int, std::string>& held, PairSamples& pairs, const std::string& rigFile)
{
    RigFunction& rig = probe.rig();
    const auto& parameters = rig.parameters();
    const auto& rest = probe.rest();
    Pass pass;
    LearnOptions raised = options;
    for (std::size_t i = 0; i < parameters.size(); ++i) {
        raised.maxSamples = budgets[i];
        const LearnOptions& own = budgets[i] == options.maxSamples ? options : raised;
        pass.classes.push_back(classifyParameter(probe, static_cast<int>(i), state, samples[i], own));
        if (const auto hold = held.find(static_cast<int>(i)); hold != held.end()) {
            pass.classes.back().modelled = false;
            pass.classes.back().reason = hold->second;
        }
        if (options.progress)
            options.progress("classifying", static_cast<double>(i + 1) / static_cast<double>(parameters.size()));
    }
    // Outputs found history-dependent are dropped from what was learned before they were found; those found
    // non-compositional are set apart. Parameters modelled on no output are not ordered: they come last.
    std::vector<int> modelled, realRigOnly;
    for (Classification& c : pass.classes) {
        if (c.modelled) classifyOutputs(c, state);
        if (c.modelled) (c.model.outputs.empty() ? realRigOnly : modelled).push_back(c.index);
    }
    pass.order = orderParameters(probe, pass.classes, modelled, options, pairs, distrusted);
    pass.order.order.insert(pass.order.order.end(), realRigOnly.begin(), realRigOnly.end());

    // The approximation's outputs are the reliable ones; `rigOutput` maps them back to the rig's.
    Approximation& result = pass.approximation;
    result.rigFile = rigFile;
    result.rigFingerprint = rig.fingerprint();
    result.epsilon = options.epsilon;
    std::vector<int> outputIndex(rest.size(), -1);
    const std::vector<char> helper = rig.helperOutputs();
    for (std::size_t k = 0; k < rest.size(); ++k)
        if (!state.unreliable[k] && !state.idle[k]) {
            outputIndex[k] = static_cast<int>(pass.rigOutput.size());
            pass.rigOutput.push_back(static_cast<int>(k));
            result.outputs.push_back({rig.outputs()[k], rest[k]});
            result.outputs.back().modelled = !state.nonCompositional[k];
            result.outputs.back().helper = helper[k] != 0;
        }
    for (std::size_t o = 0; o < result.outputs.size(); ++o) {
        const int p = probe.parentOf(pass.rigOutput[o]);
        result.outputs[o].parent = p < 0 ? -1 : outputIndex[static_cast<std::size_t>(p)];
    }
    addConstraints(probe, outputIndex, pass.rigOutput, result);
    for (int p : pass.order.order) {
        ModelledParameter m = pass.classes[static_cast<std::size_t>(p)].model;
        for (int& k : m.outputs) k = outputIndex[static_cast<std::size_t>(k)];
        for (int& k : m.unmodelledOutputs) k = outputIndex[static_cast<std::size_t>(k)];
        result.parameters.push_back(std::move(m));
        pass.indices.push_back(p);
    }
    result.validation = validate(probe, result, pass.indices, pass.rigOutput, poses, options, &pass.positionErrors);
    return pass;
}

// Why outputs left their parent output's frame, and why those were then set apart as non-compositional, for
// the report (UnmodelledOutput). The first reason of each output is kept: an output never goes back.
struct FrameHistory {
    std::map<int, std::string> relative;    // rig output -> what failed relative to its parent output
    std::map<int, std::string> world;       // rig output -> what failed in world space: the pair with neither order
    std::map<int, std::string> constraint;  // rig output -> why no constraint operator fits it

    // The non-compositional outputs of `a` (rig indices `rigOutput`), in its order, with their reasons.
    std::vector<UnmodelledOutput> unmodelled(const Approximation& a, const std::vector<int>& rigOutput) const
    {
        std::vector<UnmodelledOutput> out;
        for (std::size_t o = 0; o < a.outputs.size(); ++o) {
            if (a.outputs[o].modelled) continue;
            const auto before = relative.find(rigOutput[o]), after = world.find(rigOutput[o]);
            std::string reason = before == relative.end() ? "" : before->second + "; ";
            if (after != world.end()) reason += "in world space, " + after->second;
            if (const auto fit = constraint.find(rigOutput[o]); fit != constraint.end() && !fit->second.empty())
                reason += "; " + fit->second;
            out.push_back({a.outputs[o].name, std::move(reason)});
        }
        return out;
    }
};

// The outputs learned relative to a parent output where this pass failed (a parameter fits no operator there, a
// pair has neither order there, or the validation exceeds epsilon), each with why in `history`.
std::set<int> failingRelativeOutputs(const Pass& pass, RigProbe& probe, const LearnOptions& options,
                                     FrameHistory& history)
{
    std::set<int> failing;
    auto implicate = [&](int k, const std::string& why) {
        if (k < 0 || probe.parentOf(k) < 0) return;
        failing.insert(k);
        const std::string& parent = probe.rig().outputs()[static_cast<std::size_t>(probe.parentOf(k))];
        history.relative.try_emplace(k, fmt::format("relative to its parent output {}, {}", parent, why));
    };
    for (const Classification& c : pass.classes)
        if (c.failedOutput >= 0) implicate(c.failedOutput, fmt::format("for {}, {}", c.model.parameter.name, c.reason));
    for (const auto& [k, why] : pass.order.conflictOutputs) implicate(k, why);
    for (std::size_t o = 0; o < pass.approximation.outputs.size(); ++o) {
        const double error = pass.approximation.outputs[o].validationError;
        if (!(error <= options.epsilon))
            implicate(pass.rigOutput[o], fmt::format("its validation error {:.3g} cm per unit exceeds epsilon {:g}",
                                                     error, options.epsilon));
    }
    return failing;
}

// Outputs whose rest world matrix is singular, with why: the approximation leaves them out from the start.
std::map<int, std::string> singularOutputs(const std::vector<Eigen::Matrix4d>& rest, RigState& state)
{
    std::map<int, std::string> dropped;
    for (std::size_t k = 0; k < rest.size(); ++k) {
        std::string why = singularRest(rest[k]);
        if (why.empty()) continue;
        state.unreliable[k] = 1;
        dropped[static_cast<int>(k)] = std::move(why);
    }
    return dropped;
}

// An output relative to one that is out of range, unreliable (found history-dependent while sampling) or
// non-compositional is learned in world space. True when a frame changed.
bool worldWhereParentUnusable(RigProbe& probe, const RigState& state, FrameHistory& history)
{
    const std::size_t outputs = probe.rest().size();
    bool changed = false;
    for (std::size_t k = 0; k < probe.parents.size(); ++k) {
        int& p = probe.parents[k];
        if (p < 0) continue;
        const auto parent = static_cast<std::size_t>(p);
        if (parent < outputs && !state.unreliable[parent] && !state.nonCompositional[parent]) continue;
        if (parent < outputs)
            history.relative.try_emplace(
                static_cast<int>(k),
                fmt::format("its parent output {} is {}", probe.rig().outputs()[parent],
                            state.unreliable[parent] ? "left out (a dropped output)" : "not modelled"));
        p = -1;
        changed = true;
    }
    return changed;
}

// Every parameter's first samples, each on a fresh instance of the rig: the bulk of the evaluations, and
// independent of each other.
std::vector<ParameterSamples> firstSamples(RigPool& pool, std::size_t count, const std::vector<Eigen::Matrix4d>& rest,
                                           const LearnOptions& options)
{
    const std::thread::id caller = std::this_thread::get_id();
    std::vector<ParameterSamples> samples(count);
    std::atomic<int> sampled{0};
    pool.forEach(static_cast<int>(count), [&](RigFunction& instance, int i) {
        takeFirstSamples(instance, i, rest, options, samples[static_cast<std::size_t>(i)]);
        // Progress from the caller's thread only: callbacks need not be thread-safe.
        if (options.progress && std::this_thread::get_id() == caller)
            options.progress("sampling", static_cast<double>(sampled + 1) / static_cast<double>(count));
        ++sampled;
    });
    return samples;
}

// Whether a frame reading `inputs` would read output k: one of them framed by k, through parent outputs and
// constraints (a control chain's helper whose closest chain reads a bound joint learned relative to that helper).
// Such a frame would make the outputs' frames a cycle.
template <typename Inputs>
bool readsOutput(const RigProbe& probe, const Inputs& inputs, int k)
{
    std::vector<int> stack;
    std::set<int> seen;
    const auto push = [&](int o) {
        if (o >= 0 && seen.insert(o).second) stack.push_back(o);
    };
    for (const int input : inputs) push(input);
    while (!stack.empty()) {
        const int o = stack.back();
        stack.pop_back();
        if (o == k) return true;
        push(probe.parents[static_cast<std::size_t>(o)]);
        if (const auto c = probe.constraints.find(o); c != probe.constraints.end())
            for (const int input : c->second.frameInputs()) push(input);
    }
    return false;
}

// Output k framed by a constraint's base from now on: what the base reads is no longer idle, and k hangs from no
// parent output. False, with nothing changed, where the base would read k itself (readsOutput).
bool adopt(RigProbe& probe, RigState& state, int k, const ConstraintBase& base)
{
    if (readsOutput(probe, base.frameInputs(), k)) return false;
    for (const int input : base.frameInputs())
        if (input >= 0) state.idle[static_cast<std::size_t>(input)] = 0;
    probe.constraints[k] = base;
    probe.parents[static_cast<std::size_t>(k)] = -1;
    return true;
}

// With perOutput, an output with a parent output (`hierarchy`) where a pair has neither order, relative or in
// world space, is non-compositional: it is set apart, in world space. True when one was.
bool setApartConflicts(const Pass& pass, const LearnOptions& options, const std::vector<int>& hierarchy,
                       RigState& state, RigProbe& probe, FrameHistory& history)
{
    auto setApart = [&](int k, const std::string& why) {
        const auto o = static_cast<std::size_t>(k);
        // An output a constraint frames stays with it: the ordering discards one of the pair, and what its base
        // cannot carry is held (holdOwnOverEpsilon).
        if (!options.perOutput || hierarchy[o] < 0 || state.nonCompositional[o] || probe.constraints.contains(k))
            return false;
        state.nonCompositional[o] = 1;
        probe.parents[o] = -1;
        history.world.try_emplace(k, why);
        return true;
    };
    bool any = false;
    for (const auto& [k, why] : pass.order.conflictOutputs) any = setApart(k, why) || any;
    return any;
}

// Scale channels the ordering gave way (OrderResult::held) are held at rest from now on, the constraint fits'
// poses included. True when one newly was.
bool holdScaleChannels(const Pass& pass, ConstraintFitter& fitter)
{
    bool newly = false;
    for (const auto& [c, why] : pass.order.held)
        if (const int i = pass.classes[static_cast<std::size_t>(c)].index; !fitter.held().contains(i)) {
            fitter.hold(i, why);
            newly = true;
        }
    return newly;
}

// The structured orderer took some pairs for commuting from their operators, which an output over epsilon
// belies: the rig decides every pair there. True when an output is newly distrusted.
bool distrustOverEpsilon(const Pass& pass, const LearnOptions& options, std::set<int>& distrusted)
{
    const Approximation& a = pass.approximation;
    bool newly = false;
    if (options.orderer == Orderer::structured)
        for (std::size_t o = 0; o < a.outputs.size(); ++o)
            if (!(a.outputs[o].validationError <= options.epsilon))
                newly = distrusted.insert(pass.rigOutput[o]).second || newly;
    return newly;
}

// A parameter fitted by a curve or sampled operator that reaches an output over epsilon, or over the absolute
// tolerance at a validation pose, gets twice its sample budget, up to 8 x maxSamples (its fit was exact at the
// samples, not between). True when one was raised.
bool raiseBudgets(const Pass& pass, const LearnOptions& options, std::vector<int>& budgets)
{
    const Approximation& a = pass.approximation;
    const std::vector<std::vector<int>> reach = a.reach();
    bool raised = false;
    for (std::size_t p = 0; p < a.parameters.size(); ++p) {
        int& budget = budgets[static_cast<std::size_t>(pass.indices[p])];
        if (!interpolated(a.parameters[p]) || budget >= 8 * options.maxSamples) continue;
        const bool over = std::any_of(reach[p].begin(), reach[p].end(), [&](int k) {
            const auto o = static_cast<std::size_t>(k);
            return !(a.outputs[o].validationError <= options.epsilon) ||
                   !(pass.positionErrors[o] <= options.absoluteTolerance);
        });
        if (!over) continue;
        budget *= 2;
        raised = true;
    }
    return raised;
}

// The parameters the last pass left out, each with why (a parameter with no effect on its own that changes
// what others do says so), into result.discarded in rig order.
void recordDiscards(const Pass& pass, RigProbe& probe, const LearnOptions& options, Approximation& result)
{
    std::map<int, std::string> reasons;
    for (const auto& c : pass.classes)
        if (!c.modelled) {
            const bool noEffect = c.reason.starts_with("no effect");
            const std::string coupled = noEffect ? couplingReason(probe, c.model.parameter, c.index, result,
                                                                  pass.indices, pass.rigOutput, options)
                                                 : std::string();
            reasons[c.index] = coupled.empty() ? c.reason : coupled;
        }
    for (const auto& [p, reason] : pass.order.discards) reasons[p] = reason;
    for (const auto& [p, reason] : reasons)
        result.discarded.push_back({probe.rig().parameters()[static_cast<std::size_t>(p)], reason});
}

// The outputs below k (in the rig's output hierarchy) that no constraint fitted are tried again: each was fitted
// while k looked modelled by operators, so k was its anchor and every parameter moving k was the anchor's, not a
// goal's (an IK chain's mid joint, fitted before the start joint's operators failed validation and it got its own
// chain, saw no helper moved apart from the start joint).
void retryBelow(int k, const std::vector<int>& hierarchy, const RigProbe& probe, const RigState& state,
                std::set<int>& tried)
{
    for (std::size_t d = 0; d < hierarchy.size(); ++d) {
        if (!state.nonCompositional[d] || probe.constraints.contains(static_cast<int>(d))) continue;
        int up = hierarchy[d];
        for (std::size_t steps = 0; up >= 0 && up != k && steps < hierarchy.size(); ++steps)
            up = hierarchy[static_cast<std::size_t>(up)];
        if (up == k) tried.erase(static_cast<int>(d));
    }
}

// Constraint operators for the non-compositional outputs, parents before children (constraint_fit.h). An output
// whose parent is now modelled by a constraint, or is itself back relative to its own parent, is first tried
// relative to it again (a toe under an IK foot, a claw tip under a claw under an IK hand: it failed there only while
// an ancestor was mispredicted); each output is fitted once, and again where an ancestor got a constraint after it
// was fitted (retryBelow). True when a frame changed.
// An output still over epsilon once its order is decided on the rig, though each parameter alone fitted an operator
// (a roll joint: each of the driver's angles alone turns it about its axis, together they do not compose), is tried
// with a constraint, and the outputs below it that no constraint fitted are tried again. True when one was found.
bool constrainOverEpsilon(const Pass& pass, RigProbe& probe, RigState& state, ConstraintFitter& fitter,
                          const std::vector<int>& hierarchy, std::set<int>& tried)
{
    bool changed = false;
    const Approximation& a = pass.approximation;
    for (std::size_t o = 0; o < a.outputs.size(); ++o) {
        const int k = pass.rigOutput[o];
        if (a.outputs[o].validationError <= fitter.epsilon() || probe.constraints.contains(k) ||
            !tried.insert(k).second)
            continue;
        std::string why;
        const std::optional<ConstraintBase> base = fitter.fit(k, state, why);
        if (!base || !adopt(probe, state, k, *base)) continue;
        retryBelow(k, hierarchy, probe, state, tried);
        changed = true;
    }
    return changed;
}

// An output given a planar chain but over epsilon in validation is tried as a twist share again, once. A roll joint
// under an IK forearm is fitted before the hand that drives it has its own chain (siblings, in rig order), and the
// chain fitted instead is checked only on what moves its inputs: the hand's twist is left to the roll joint's own
// operators, which do not compose. True when one was found.
bool twistOverEpsilon(const Pass& pass, RigProbe& probe, RigState& state, ConstraintFitter& fitter,
                      std::set<int>& retried)
{
    bool changed = false;
    const Approximation& a = pass.approximation;
    for (std::size_t o = 0; o < a.outputs.size(); ++o) {
        const int k = pass.rigOutput[o];
        const auto chain = probe.constraints.find(k);
        if (a.outputs[o].validationError <= fitter.epsilon() || chain == probe.constraints.end() ||
            chain->second.kind != ConstraintKind::planarChain || !retried.insert(k).second)
            continue;
        const std::optional<ConstraintBase> base = fitter.twistShare(k, state);
        if (!base || !adopt(probe, state, k, *base)) continue;
        changed = true;
    }
    return changed;
}

// An output that no constraint fitted when it was tried is tried as a twist share once more, once every other output
// has had its try: a roll joint whose driver, a hand turned by an orient constraint, is fitted after it (siblings, in
// rig order) reads the hand's constraint. True when one was found.
bool twistWhereUnfitted(RigProbe& probe, RigState& state, ConstraintFitter& fitter, const std::set<int>& fitted,
                        std::set<int>& retried)
{
    bool changed = false;
    for (const int k : fitted) {
        const auto i = static_cast<std::size_t>(k);
        if (!state.nonCompositional[i] || probe.constraints.contains(k) || !retried.insert(k).second) continue;
        const std::optional<ConstraintBase> base = fitter.twistShare(k, state);
        if (!base || !adopt(probe, state, k, *base)) continue;
        state.nonCompositional[i] = 0;
        changed = true;
    }
    return changed;
}

// The approximation output of rig output k in this pass, or -1.
int passOutput(const Pass& pass, int k)
{
    const auto it = std::find(pass.rigOutput.begin(), pass.rigOutput.end(), k);
    return it == pass.rigOutput.end() ? -1 : static_cast<int>(it - pass.rigOutput.begin());
}

// The outputs of `failing` whose parent output was itself over epsilon in this pass, each with that parent: they
// may have failed only because their parent was mispredicted (a parameter that pass kept and a later one discards).
void noteMispredictedParents(const Pass& pass, const RigProbe& probe, const std::set<int>& failing, double epsilon,
                             std::map<int, int>& mispredicted)
{
    for (const int k : failing) {
        const int p = probe.parentOf(k), o = p < 0 ? -1 : passOutput(pass, p);
        if (o >= 0 && !(pass.approximation.outputs[static_cast<std::size_t>(o)].validationError <= epsilon))
            mispredicted.try_emplace(k, p);
    }
}

// An output set apart after failing relative to a parent output that was mispredicted then, and that no constraint
// fitted, is tried relative to that parent again, once, where the parent now validates (a toe under a foot while a
// pair of the foot's parameters had no order: the foot validates once one is discarded). True when one was.
bool relativeWhereParentValidates(const Pass& pass, RigProbe& probe, RigState& state,
                                  const std::map<int, int>& mispredicted, double epsilon, std::set<int>& retried,
                                  std::set<int>& tried)
{
    bool changed = false;
    for (const auto& [k, p] : mispredicted) {
        const auto i = static_cast<std::size_t>(k);
        const int o = passOutput(pass, p);
        if (!state.nonCompositional[i] || probe.constraints.contains(k) ||
            state.nonCompositional[static_cast<std::size_t>(p)] || o < 0 ||
            !(pass.approximation.outputs[static_cast<std::size_t>(o)].validationError <= epsilon) ||
            readsOutput(probe, std::array{p}, k) || !retried.insert(k).second)
            continue;
        state.nonCompositional[i] = 0;
        probe.parents[i] = p;
        tried.erase(k);
        changed = true;
    }
    return changed;
}

// The last repair: an output a constraint frames that is still over epsilon has its own movers (parameters moving
// it but none of the base's inputs, composed after the base) held at rest, where they do not compose with it (an
// ikHandle's pole vector and twist channels turn the chain's plane about its line, not about the line at rest: 0.19
// cm per unit on a 3-joint chain). True when one was held.
bool holdOwnOverEpsilon(const Pass& pass, RigProbe& probe, ConstraintFitter& fitter)
{
    bool held = false;
    const Approximation& a = pass.approximation;
    const auto& names = probe.rig().outputs();
    for (std::size_t o = 0; o < a.outputs.size(); ++o) {
        const int k = pass.rigOutput[o];
        const auto base = probe.constraints.find(k);
        if (a.outputs[o].validationError <= fitter.epsilon() || base == probe.constraints.end()) continue;
        for (const int i : fitter.ownMovers(k, base->second)) {
            if (fitter.held().contains(i)) continue;
            fitter.hold(i, fmt::format("it moves {} apart from the inputs of its {}, and does not compose with it ({} "
                                       "validated {:.3g} cm per unit with it); it is held at its rest value",
                                       names[static_cast<std::size_t>(k)], constraintKindName(base->second.kind),
                                       names[static_cast<std::size_t>(k)], a.outputs[o].validationError));
            held = true;
        }
    }
    return held;
}

bool fitConstraints(RigProbe& probe, RigState& state, const std::vector<int>& hierarchy, ConstraintFitter& fitter,
                    FrameHistory& history, std::set<int>& tried, std::set<int>& relativeAgain)
{
    std::vector<int> order(hierarchy.size());
    std::vector<int> depth(hierarchy.size(), 0);
    for (std::size_t k = 0; k < hierarchy.size(); ++k) {
        order[k] = static_cast<int>(k);
        for (int p = hierarchy[k]; p >= 0 && depth[k] <= static_cast<int>(hierarchy.size());
             p = hierarchy[static_cast<std::size_t>(p)])
            ++depth[k];
    }
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
        return depth[static_cast<std::size_t>(a)] < depth[static_cast<std::size_t>(b)];
    });
    bool changed = false;
    std::set<int> changedNow;  // their children wait for a pass in the new frames
    for (const int k : order) {
        const auto i = static_cast<std::size_t>(k);
        if (!state.nonCompositional[i] || tried.contains(k)) continue;
        const int p = hierarchy[i];
        if (changedNow.contains(p)) continue;
        const bool parentModelled = p >= 0 && !state.nonCompositional[static_cast<std::size_t>(p)] &&
                                    !state.unreliable[static_cast<std::size_t>(p)];
        if (p >= 0 && !parentModelled && !tried.contains(p)) continue;  // its parent first
        const bool parentBack = probe.constraints.contains(p) || relativeAgain.contains(p);
        if (parentModelled && parentBack && !readsOutput(probe, std::array{p}, k) && relativeAgain.insert(k).second) {
            state.nonCompositional[i] = 0;
            probe.parents[i] = p;
            changed = true;
            changedNow.insert(k);
            continue;
        }
        tried.insert(k);
        std::string why;
        const std::optional<ConstraintBase> base = fitter.fit(k, state, why);
        const bool adopted = base && adopt(probe, state, k, *base);
        if (base && !adopted)
            why = fmt::format("its {} would read an output framed by it", constraintKindName(base->kind));
        if (!adopted) {
            history.constraint[k] = why;
            continue;
        }
        state.nonCompositional[i] = 0;
        changed = true;
        changedNow.insert(k);
    }
    return changed;
}

}  // namespace

Approximation learnApproximation(RigFunction& rig, const LearnOptions& options, const std::string& rigFile,
                                 std::vector<UnmodelledOutput>* unmodelled)
{
    options.validate();
    const auto start = std::chrono::steady_clock::now();
    const std::uint64_t evaluationsBefore = rig.evaluationCount();
    RigProbe probe(rig);
    const std::vector<Eigen::Matrix4d>& rest = probe.rest();
    const auto& parameters = rig.parameters();

    const std::vector<char> helper = rig.helperOutputs();
    RigState state{std::vector<char>(rest.size(), 0), std::vector<char>(rest.size(), 0), helper};
    std::map<int, std::string> dropped = singularOutputs(rest, state);  // rig output -> why it is left out
    // Frames: relative to the parent output where there is one (and it is usable).
    const std::vector<int> hierarchy = options.relativeFrames ? rig.outputParents() : std::vector<int>(rest.size(), -1);
    probe.parents = hierarchy;
    if (probe.parents.size() != rest.size())
        throw internalError(
            fmt::format("learnApproximation: {} output parents for {} outputs", probe.parents.size(), rest.size()));
    FrameHistory history;
    worldWhereParentUnusable(probe, state, history);

    RigPool pool(rig, options.threads == 0 ? static_cast<int>(std::max(1u, std::thread::hardware_concurrency()))
                                           : options.threads);
    std::vector<ParameterSamples> samples = firstSamples(pool, parameters.size(), rest, options);
    ConstraintFitter fitter(probe, samples, rig.outputParents(), helper, options);
    // Outputs a constraint was tried on; tried relative again; planar chains tried as twist shares again.
    std::set<int> fitted, relativeAgain, twistAgain, twistUnfitted;
    std::map<int, int> mispredicted;  // outputs that left a parent output mispredicted at the time -> that parent
    std::set<int> relativeValidated;  // of those, tried relative again where the parent validates
    ValidationPoses poses = drawPoses(parameters, options);
    Pass pass;
    // Repairs, each pass learning again from the samples already taken (DESIGN: validation decides).
    // First, scale channels the ordering gave way are held (holdScaleChannels). Then a relative output where learning
    // failed moves to world space (an output never goes back). Then outputs where a pair has neither order are set
    // apart (setApartConflicts), constraints are fitted (fitConstraints), a planar chain over epsilon is tried as a
    // twist share (twistOverEpsilon), then the rig decides the order of every pair on an output still over epsilon
    // (distrustOverEpsilon), then interpolated fits reaching one get more samples (raiseBudgets).
    std::vector<int> budgets(parameters.size(), options.maxSamples);
    std::set<int> distrusted;
    PairSamples pairs;
    std::uint64_t orderEvaluations = 0;  // over every pass
    while (true) {
        pass = learnPass(probe, state, samples, poses, options, budgets, distrusted, fitter.held(), pairs, rigFile);
        orderEvaluations += pass.order.evaluations;
        if (holdScaleChannels(pass, fitter)) continue;
        // Learned relative to an output now dropped: learn those again.
        if (worldWhereParentUnusable(probe, state, history)) continue;
        const std::set<int> failing = failingRelativeOutputs(pass, probe, options, history);
        noteMispredictedParents(pass, probe, failing, options.epsilon, mispredicted);
        for (const int k : failing) probe.parents[static_cast<std::size_t>(k)] = -1;
        if (!failing.empty()) continue;
        if (setApartConflicts(pass, options, hierarchy, state, probe, history)) {
            worldWhereParentUnusable(probe, state, history);
            continue;
        }
        if (options.perOutput && fitConstraints(probe, state, hierarchy, fitter, history, fitted, relativeAgain))
            continue;
        if (options.perOutput &&
            relativeWhereParentValidates(pass, probe, state, mispredicted, options.epsilon, relativeValidated, fitted))
            continue;
        if (options.perOutput && twistOverEpsilon(pass, probe, state, fitter, twistAgain)) continue;
        if (options.perOutput && twistWhereUnfitted(probe, state, fitter, fitted, twistUnfitted)) continue;
        if (distrustOverEpsilon(pass, options, distrusted)) continue;
        if (options.perOutput && constrainOverEpsilon(pass, probe, state, fitter, hierarchy, fitted)) continue;
        if (raiseBudgets(pass, options, budgets)) continue;
        if (!options.perOutput || !holdOwnOverEpsilon(pass, probe, fitter)) break;
    }

    Approximation result = std::move(pass.approximation);
    if (unmodelled) *unmodelled = history.unmodelled(result, pass.rigOutput);
    recordDiscards(pass, probe, options, result);
    for (std::size_t k = 0; k < rest.size(); ++k)
        if (state.unreliable[k] && !dropped.contains(static_cast<int>(k)))
            dropped[static_cast<int>(k)] =
                "history-dependent: it does not come back to its rest pose after other samples";
    for (const auto& [k, reason] : dropped)
        result.droppedOutputs.push_back({rig.outputs()[static_cast<std::size_t>(k)], reason});
    result.training.evaluations = rig.evaluationCount() - evaluationsBefore + pool.evaluationCount();
    result.training.orderEvaluations = orderEvaluations;
    result.training.orderer = std::string(ordererName(options.orderer));
    result.training.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
}

void validateApproximation(RigFunction& rig, Approximation& approximation, const LearnOptions& options)
{
    options.validate();
    const auto index = [](const auto& names, const std::string& name, const auto& nameOf) {
        const auto it =
            std::find_if(names.begin(), names.end(), [&](const auto& entry) { return nameOf(entry) == name; });
        return it == names.end() ? -1 : static_cast<int>(it - names.begin());
    };
    std::vector<int> indices, rigOutput;
    for (const ModelledParameter& m : approximation.parameters) {
        indices.push_back(index(rig.parameters(), m.parameter.name, [](const RigParameter& p) { return p.name; }));
        if (indices.back() < 0)
            throw internalError(fmt::format("validateApproximation: the rig has no parameter {}", m.parameter.name));
    }
    for (const ApproximationOutput& o : approximation.outputs)
        rigOutput.push_back(index(rig.outputs(), o.name, [](const std::string& n) { return n; }));
    RigProbe probe(rig);
    ValidationPoses poses = drawPoses(rig.parameters(), options);
    approximation.validation = validate(probe, approximation, indices, rigOutput, poses, options);
}

}  // namespace rig
