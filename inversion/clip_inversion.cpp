#include "inversion/clip_inversion.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "core/error.h"
#include "core/rotation_math.h"
#include "core/thread_clock.h"
#include "inversion/continuity.h"

namespace rig {
ClipTargets matchTargets(const Approximation& approximation, std::span<const std::string> joints,
                         std::span<const std::vector<Eigen::Matrix4d>> worlds)
{
    ClipTargets targets;
    for (const auto& joint : joints) {
        const auto it = std::find_if(approximation.outputs.begin(), approximation.outputs.end(),
                                     [&](const ApproximationOutput& o) { return o.name == joint; });
        targets.outputOfJoint.push_back(
            it == approximation.outputs.end() ? -1 : static_cast<int>(it - approximation.outputs.begin()));
        if (targets.outputOfJoint.back() >= 0) ++targets.matchedJoints;
        else targets.unmatchedJoints.push_back(joint);
    }
    if (targets.matchedJoints == 0)
        throw Error(fmt::format(
            "no joint of the clip is an output of the approximation (the clip has '{}', ...; the approximation "
            "'{}', ...); rename them with a map file",
            joints.empty() ? std::string() : joints.front(),
            approximation.outputs.empty() ? std::string() : approximation.outputs.front().name));
    for (const auto& frame : worlds) {
        auto& out = targets.frames.emplace_back(approximation.outputs.size());
        for (std::size_t j = 0; j < joints.size(); ++j) {
            const int o = targets.outputOfJoint[j];
            if (o < 0) continue;
            out[o].active = true;
            out[o].world = frame[j];
        }
    }
    return targets;
}

void ClipInversionOptions::validate() const
{
    solver.validate();
    if (polishCorrections < 0) throw Error(fmt::format("polishCorrections must be >= 0, got {}", polishCorrections));
    if (restartInterval <= 0) throw Error(fmt::format("restartInterval must be > 0 frames, got {}", restartInterval));
}

std::string ClipInversionSummary::briefReport() const
{
    return fmt::format(
        "{} frames, {} converged, {} stuck; real rig: worst {:.3g} cm and {:.3g} deg ({}, frame index {}), "
        "mean {:.3g} cm and {:.3g} deg; {:.3g} ms per frame",
        frames, convergedFrames, stuckFrames, maxPositionErrorCm, maxRotationErrorDeg, worstJoint, worstFrame,
        meanPositionErrorCm, meanRotationErrorDeg, msPerFrame);
}

void solveChainFrame(const Solver& solver, std::span<const JointTarget> targets, std::vector<double>& values,
                     double previousCost, ChainScratch& scratch, ChainFrame& frame)
{
    scratch.start.assign(values.begin(), values.end());  // the warm start
    frame.retried = frame.kept = false;
    frame.realRigEvaluations = 0;
    solver.solve(targets, values, frame.summary);
    const double tolerance = solver.options().targetTolerance;
    const double floor = 0.5 * tolerance * tolerance;
    if (!(previousCost < retryNever) || frame.summary.termination != TerminationType::stuck ||
        !(frame.summary.finalCost > 2.0 * previousCost + floor))
        return;
    frame.retried = true;
    solver.initialGuess(targets, scratch.start);
    SolveSummary& second = scratch.second;
    solver.solve(targets, scratch.start, second);
    if (!(second.finalCost < frame.summary.finalCost * (1.0 - 1e-9) - floor * 1e-6)) return;
    frame.kept = true;
    second.iterations += frame.summary.iterations;
    second.gaussNewtonIterations += frame.summary.gaussNewtonIterations;
    second.levenbergMarquardtIterations += frame.summary.levenbergMarquardtIterations;
    second.initialCost = frame.summary.initialCost;
    std::swap(frame.summary, second);
    values.swap(scratch.start);
}

ClipInversionSummary invertClip(const Solver& solver, RigBinding& rig, const ClipTargets& targets, int first, int last,
                                const ClipInversionOptions& options, std::vector<std::vector<double>>& values,
                                std::vector<std::vector<double>>* solvedValues)
{
    options.validate();
    const int frameCount = static_cast<int>(targets.frames.size());
    if (first < 0 || last >= frameCount || first > last)
        throw internalError(fmt::format("frames {}..{} are not within the clip's 0..{}", first, last, frameCount - 1));
    const Approximation& approximation = solver.approximation();
    const std::vector<double> rest = approximation.defaults();

    ClipInversionSummary summary;
    summary.leadInFrames = first % options.restartInterval;
    values.clear();
    if (solvedValues) solvedValues->clear();
    std::vector<double> current = rest;
    // Each chunk shifted by equivalences to meet the frame before it (continuity.h); the chain itself,
    // `current`, is what was solved.
    ChainContinuity continuity(solver.equivalences(), options.continueFrom);
    ChainScratch chainScratch;
    ChainFrame solved;
    double previousCost = 0.0;
    std::vector<Eigen::Matrix4d> worlds;
    std::vector<int> stuckCount(approximation.outputs.size(), 0);
    std::vector<double> stuckError(approximation.outputs.size(), 0.0);
    double positionSum = 0.0, rotationSum = 0.0;
    long long jointFrames = 0;
    using Clock = std::chrono::steady_clock;
    for (int frame = first - summary.leadInFrames; frame <= last; ++frame) {
        const auto& frameTargets = targets.frames[frame];
        const auto start = Clock::now();
        const double cpuStart = threadCpuSeconds();
        const bool restart = frame % options.restartInterval == 0;
        if (restart) {
            current = rest;
            if (options.coldStart) solver.initialGuess(frameTargets, current);
        }
        const double previous = options.retryStuck && !restart ? previousCost : retryNever;
        if (options.frameSolve) options.frameSolve(frameTargets, current, previous, solved);
        else solveChainFrame(solver, frameTargets, current, previous, chainScratch, solved);
        const SolveSummary& solve = solved.summary;
        const bool retried = solved.retried, kept = solved.kept;
        if (solve.termination != TerminationType::invalidTargets) previousCost = solve.finalCost;
        if (options.polishCorrections > 0 && !options.frameSolve &&
            solve.termination != TerminationType::invalidTargets)
            polish(solver, rig, frameTargets, current, options.polishCorrections);
        const std::span<const double> reported = continuity.next(current, restart);
        const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
        const double cpuSeconds = threadCpuSeconds() - cpuStart;
        if (frame < first) continue;

        summary.solveSeconds += seconds;
        summary.solveCpuSeconds += cpuSeconds;
        values.emplace_back(reported.begin(), reported.end());
        if (solvedValues) solvedValues->push_back(current);
        FrameInversion result;
        result.frame = frame;
        result.solve = solve;
        result.realRigEvaluations = solved.realRigEvaluations;
        summary.realRigEvaluations += solved.realRigEvaluations;
        rig.evaluate(reported, worlds);
        for (std::size_t o = 0; o < frameTargets.size(); ++o) {
            if (!frameTargets[o].active) continue;
            // A NaN target (reported by the solver) has no error to measure; a NaN rig is a miss.
            if (!frameTargets[o].world.topRows<3>().allFinite()) continue;
            if (!worlds[o].topRows<3>().allFinite()) {
                if (result.nonFiniteJoint.empty()) result.nonFiniteJoint = approximation.outputs[o].name;
                continue;
            }
            const double p = (worlds[o].block<3, 1>(0, 3) - frameTargets[o].world.block<3, 1>(0, 3)).norm();
            const double r =
                orientationAngle(worlds[o].topLeftCorner<3, 3>(), frameTargets[o].world.topLeftCorner<3, 3>()) * 180.0 /
                std::numbers::pi;
            if (!std::isfinite(p) || !std::isfinite(r)) continue;
            positionSum += p;
            rotationSum += r;
            ++jointFrames;
            if (p > result.positionErrorCm || result.worstJoint.empty()) {
                result.positionErrorCm = std::max(result.positionErrorCm, p);
                result.worstJoint = approximation.outputs[o].name;
            }
            result.rotationErrorDeg = std::max(result.rotationErrorDeg, r);
        }
        ++summary.frames;
        summary.retriedFrames += retried;
        summary.retriesKept += kept;
        if (solve.converged()) ++summary.convergedFrames;
        if (solve.termination == TerminationType::stuck) {
            ++summary.stuckFrames;
            for (const int k : solve.missedOutputs) {
                const std::size_t o = static_cast<std::size_t>(k);
                ++stuckCount[o];
                const double e = (worlds[o].block<3, 1>(0, 3) - frameTargets[o].world.block<3, 1>(0, 3)).norm();
                if (std::isfinite(e)) stuckError[o] = std::max(stuckError[o], e);
            }
        }
        if (!result.nonFiniteJoint.empty() && summary.nonFiniteFrames++ == 0) {
            summary.firstNonFiniteJoint = result.nonFiniteJoint;
            summary.firstNonFiniteFrame = frame;
        }
        if (result.positionErrorCm > summary.maxPositionErrorCm || summary.worstFrame < 0) {
            summary.maxPositionErrorCm = result.positionErrorCm;
            summary.worstJoint = result.worstJoint;
            summary.worstFrame = frame;
        }
        summary.maxRotationErrorDeg = std::max(summary.maxRotationErrorDeg, result.rotationErrorDeg);
        summary.perFrame.push_back(std::move(result));
        if (options.progress) options.progress(static_cast<double>(frame - first + 1) / (last - first + 1));
    }
    if (jointFrames > 0) {
        summary.meanPositionErrorCm = positionSum / static_cast<double>(jointFrames);
        summary.meanRotationErrorDeg = rotationSum / static_cast<double>(jointFrames);
    }
    for (std::size_t k = 0; k < stuckCount.size(); ++k)
        if (stuckCount[k] > 0)
            summary.stuckJoints.push_back({approximation.outputs[k].name, stuckCount[k], stuckError[k]});
    std::stable_sort(summary.stuckJoints.begin(), summary.stuckJoints.end(),
                     [](const auto& a, const auto& b) { return a.worstErrorCm > b.worstErrorCm; });
    summary.msPerFrame = summary.frames > 0 ? 1000.0 * summary.solveSeconds / summary.frames : 0.0;
    return summary;
}

}  // namespace rig
