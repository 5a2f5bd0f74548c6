#include "inversion/clip/clip_inversion.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numbers>

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "core/error.h"
#include "core/rotation_math.h"
#include "core/same_bits.h"
#include "core/thread_clock.h"
#include "inversion/clip/continuity.h"

namespace rig {
ClipTargets matchTargets(const Approximation& approximation, std::span<const std::string> joints,
                         std::span<const std::vector<Eigen::Matrix4d>> worlds)
{
    ClipTargets targets;
    for (const auto& joint : joints) {
        const auto it = std::find_if(approximation.outputs.begin(), approximation.outputs.end(),
                                     [&](const ApproximationOutput& o) { return !o.helper && o.name == joint; });
        targets.outputOfJoint.push_back(
            it == approximation.outputs.end() ? -1 : static_cast<int>(it - approximation.outputs.begin()));
        if (targets.outputOfJoint.back() >= 0) ++targets.matchedJoints;
        else targets.unmatchedJoints.push_back(joint);
    }
    const auto first = [](const std::string& name) { return fmt::format("'{}', ...", name); };
    if (targets.matchedJoints == 0)
        throw Error(fmt::format(
            "no joint of the clip is an output of the approximation (the clip has {}; the approximation {}); "
            "rename them with a map file",
            joints.empty() ? "none" : first(joints.front()),
            approximation.outputs.empty() ? "none" : first(approximation.outputs.front().name)));
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
    if (mismatchPolishCorrections < 0)
        throw Error(fmt::format("mismatchPolishCorrections must be >= 0, got {}", mismatchPolishCorrections));
    if (restartInterval <= 0) throw Error(fmt::format("restartInterval must be > 0 frames, got {}", restartInterval));
    for (const Contact& c : contacts)
        if (c.output < 0 || c.first < 0 || c.first > c.last)
            throw Error(
                fmt::format("a contact must name an output and frames first <= last, got output {}, frames "
                            "{} to {}",
                            c.output, c.first, c.last));
}

std::string_view frameStatusName(FrameStatus status)
{
    return frameStatusSpellings.at(static_cast<std::size_t>(status)).words;
}

std::string frameStatusKey(FrameStatus status)
{
    return std::string(frameStatusSpellings.at(static_cast<std::size_t>(status)).key);
}

namespace {

// Whether error a is worse than b: a NaN is worse than any number, so that no maximum drops one.
bool worse(double a, double b) { return std::isnan(a) ? !std::isnan(b) : !std::isnan(b) && a > b; }

}  // namespace

int ClipInversionSummary::failedFrames() const
{
    int failed = 0;
    for (int k = 0; k < frameStatusCount; ++k)
        if (frameStatusFails(static_cast<FrameStatus>(k))) failed += statusFrames[static_cast<std::size_t>(k)];
    return failed;
}

void ClipInversionSummary::add(const FrameInversion& f, const std::vector<ApproximationOutput>& outputs)
{
    ++frames;
    ++statusFrames[static_cast<std::size_t>(f.status)];
    if (frameStatusFails(f.status) && firstFailedFrame < 0) {
        firstFailedFrame = f.frame;
        firstFailedStatus = f.status;
        firstFailedJoint = f.status == FrameStatus::invalidTargets && !f.invalidJoint.empty() ? f.invalidJoint
                           : !f.nonFiniteJoint.empty()                                        ? f.nonFiniteJoint
                           : f.status == FrameStatus::modelMismatch && f.mismatchOutput >= 0
                               ? outputs[static_cast<std::size_t>(f.mismatchOutput)].name
                           : !f.missed.empty() ? outputs[static_cast<std::size_t>(f.missed.front().output)].name
                                               : f.worstJoint;
        firstFailedRange = f.rangeLeft;
    } else if (f.rangeLeft.found() && f.rangeLeft.parameter == firstFailedRange.parameter) {
        firstFailedRange.cover(f.rangeLeft.low);
        firstFailedRange.cover(f.rangeLeft.high);
    }
    for (const auto& m : f.missed)
        addResidual({outputs[static_cast<std::size_t>(m.output)].name, 1, m.positionErrorCm, m.rotationErrorDeg,
                     m.scaledErrorCm});
    // A frame not measured has no error to be the worst: 0 there would make a run of invalid targets look exact.
    if (f.measured() && (worse(f.positionErrorCm, maxPositionErrorCm) || worstFrame < 0)) {
        maxPositionErrorCm = f.positionErrorCm;
        worstJoint = f.worstJoint;
        worstFrame = f.frame;
    }
    if (f.measured() && (worse(f.rotationErrorDeg, maxRotationErrorDeg) || worstRotationFrame < 0)) {
        maxRotationErrorDeg = f.rotationErrorDeg;
        worstRotationJoint = f.worstRotationJoint;
        worstRotationFrame = f.frame;
    }
    if (worse(f.modelGapCm, maxModelGapCm)) maxModelGapCm = f.modelGapCm;
    const double n = static_cast<double>(jointFrames), k = f.countedJoints;
    if (f.countedJoints > 0) {
        meanPositionErrorCm = (meanPositionErrorCm * n + f.positionErrorSumCm) / (n + k);
        meanRotationErrorDeg = (meanRotationErrorDeg * n + f.rotationErrorSumDeg) / (n + k);
    }
    jointFrames += f.countedJoints;
    realRigEvaluations += f.realRigEvaluations;
}

void ClipInversionSummary::merge(const ClipInversionSummary& later)
{
    if (later.firstFailedFrame >= 0 && firstFailedFrame < 0) {
        firstFailedFrame = later.firstFailedFrame;
        firstFailedStatus = later.firstFailedStatus;
        firstFailedJoint = later.firstFailedJoint;
        firstFailedRange = later.firstFailedRange;
    } else if (later.firstFailedRange.found() && later.firstFailedRange.parameter == firstFailedRange.parameter) {
        firstFailedRange.cover(later.firstFailedRange.low);
        firstFailedRange.cover(later.firstFailedRange.high);
    }
    for (int k = 0; k < frameStatusCount; ++k)
        statusFrames[static_cast<std::size_t>(k)] += later.statusFrames[static_cast<std::size_t>(k)];
    for (const auto& joint : later.residualJoints) addResidual(joint);
    sortResidualJoints();
    if (later.measured() && (worse(later.maxPositionErrorCm, maxPositionErrorCm) || worstFrame < 0)) {
        maxPositionErrorCm = later.maxPositionErrorCm;
        worstJoint = later.worstJoint;
        worstFrame = later.worstFrame;
    }
    if (later.measured() && (worse(later.maxRotationErrorDeg, maxRotationErrorDeg) || worstRotationFrame < 0)) {
        maxRotationErrorDeg = later.maxRotationErrorDeg;
        worstRotationJoint = later.worstRotationJoint;
        worstRotationFrame = later.worstRotationFrame;
    }
    if (worse(later.maxModelGapCm, maxModelGapCm)) maxModelGapCm = later.maxModelGapCm;
    const double n = static_cast<double>(jointFrames), k = static_cast<double>(later.jointFrames);
    if (later.jointFrames > 0) {
        meanPositionErrorCm = (meanPositionErrorCm * n + later.meanPositionErrorCm * k) / (n + k);
        meanRotationErrorDeg = (meanRotationErrorDeg * n + later.meanRotationErrorDeg * k) / (n + k);
    }
    jointFrames += later.jointFrames;
    joinSlides(contacts, later.contacts);
    multiplierUpdates += later.multiplierUpdates;
    frames += later.frames;
    retriedFrames += later.retriedFrames;
    retriesKept += later.retriesKept;
    solveSeconds += later.solveSeconds;
    solveCpuSeconds += later.solveCpuSeconds;
    setupSeconds += later.setupSeconds;
    setupCpuSeconds += later.setupCpuSeconds;
    realRigEvaluations += later.realRigEvaluations;
    msPerFrame = frames > 0 ? 1000.0 * solveSeconds / frames : 0.0;
}

void ClipInversionSummary::addResidual(const ResidualJoint& joint)
{
    auto it =
        std::find_if(residualJoints.begin(), residualJoints.end(), [&](const auto& r) { return r.name == joint.name; });
    if (it == residualJoints.end()) it = residualJoints.insert(residualJoints.end(), {joint.name});
    it->frames += joint.frames;
    if (worse(joint.worstPositionErrorCm, it->worstPositionErrorCm))
        it->worstPositionErrorCm = joint.worstPositionErrorCm;
    if (worse(joint.worstRotationErrorDeg, it->worstRotationErrorDeg))
        it->worstRotationErrorDeg = joint.worstRotationErrorDeg;
    if (worse(joint.worstScaledErrorCm, it->worstScaledErrorCm)) it->worstScaledErrorCm = joint.worstScaledErrorCm;
}

void ClipInversionSummary::sortResidualJoints()
{
    std::stable_sort(residualJoints.begin(), residualJoints.end(),
                     [](const auto& a, const auto& b) { return worse(a.worstScaledErrorCm, b.worstScaledErrorCm); });
}

std::string ClipInversionSummary::briefReport() const
{
    std::string counts;
    for (int k = 0; k < frameStatusCount; ++k)
        if (statusFrames[static_cast<std::size_t>(k)] > 0 || k == 0)
            counts += fmt::format("{}{} {}", counts.empty() ? "" : ", ", statusFrames[static_cast<std::size_t>(k)],
                                  frameStatusName(static_cast<FrameStatus>(k)));
    return fmt::format(
        "{} frames: {}; real rig: worst {:.3g} cm ({}, frame index {}) and {:.3g} deg ({}, frame index {}), "
        "mean {:.3g} cm and {:.3g} deg; {:.3g} ms per frame",
        frames, counts, maxPositionErrorCm, worstJoint, worstFrame, maxRotationErrorDeg, worstRotationJoint,
        worstRotationFrame, meanPositionErrorCm, meanRotationErrorDeg, msPerFrame);
}

namespace {

// The frame solved with the positions weighed rotationsLeadPositionWeight times their own, from `values`; false (and
// `values` unchanged) when no active target has a rotation to lead.
bool solveRotationsFirst(const Solver& solver, std::span<const JointTarget> targets, std::vector<double>& values,
                         ChainScratch& scratch)
{
    scratch.led.assign(targets.begin(), targets.end());
    bool rotations = false;
    for (JointTarget& t : scratch.led) {
        rotations = rotations || (t.active && t.rotationWeight > 0.0);
        t.positionWeight *= rotationsLeadPositionWeight;
    }
    if (!rotations) return false;
    solver.solve(scratch.led, values, scratch.second);
    return true;
}

// Whether the rotations lead the next frame, from this one's solve (`led`: with the rotations leading, `summary` the
// second solve's).
void decideLead(bool led, const SolveSummary& summary, ChainLead& lead)
{
    if (!led) {
        lead.wait = std::max(0, lead.wait - 1);
        lead.rotations = summary.longFirstStep && lead.wait == 0;
        return;
    }
    // It paid where the targets' own weights took one step from the rotations' answer.
    lead.rotations = summary.converged() && summary.iterations <= 1;
    if (lead.rotations) {
        lead.backoff = ChainLead::firstWait;
        return;
    }
    lead.wait = lead.backoff;
    lead.backoff = std::min(2 * lead.backoff, 1 << 20);
}

// A retry's answer (`second`, from `start`) kept in `frame` and `values` where it is cheaper.
void keepIfCheaper(SolveSummary& second, std::vector<double>& start, double floor, ChainFrame& frame,
                   std::vector<double>& values)
{
    if (!(second.finalCost < frame.summary.finalCost * (1.0 - 1e-9) - floor * 1e-6)) return;
    frame.kept = true;
    second.iterations += frame.summary.iterations;
    second.gaussNewtonIterations += frame.summary.gaussNewtonIterations;
    second.levenbergMarquardtIterations += frame.summary.levenbergMarquardtIterations;
    second.initialCost = frame.summary.initialCost;
    std::swap(frame.summary, second);
    values.swap(start);
}

// A warm solve that gave up (Solver::solveOrGiveUp) gone on from where it stopped, as solve() would have, where the
// fresh start did not converge; kept where it is cheaper than that start's answer.
void goOnFromStall(const Solver& solver, std::span<const JointTarget> targets, double floor, ChainScratch& scratch,
                   ChainFrame& frame, std::vector<double>& values)
{
    SolveSummary& again = scratch.second;
    solver.solve(targets, scratch.stalled, again);
    if (frame.summary.stalled) {
        // No fresh start was kept: the stalled solve's iterations and the answer gone on from it, never costlier.
        again.iterations += frame.summary.iterations;
        again.gaussNewtonIterations += frame.summary.gaussNewtonIterations;
        again.levenbergMarquardtIterations += frame.summary.levenbergMarquardtIterations;
        again.initialCost = frame.summary.initialCost;
        std::swap(frame.summary, again);
        values.swap(scratch.stalled);
        return;
    }
    keepIfCheaper(again, scratch.stalled, floor, frame, values);
}

void solveChainFrameOnce(const Solver& solver, std::span<const JointTarget> targets, std::vector<double>& values,
                         double previousCost, ChainScratch& scratch, ChainFrame& frame)
{
    scratch.start.assign(values.begin(), values.end());  // the warm start
    frame.retried = frame.kept = frame.repeated = false;
    frame.realRigEvaluations = 0;
    scratch.led.reserve(targets.size());  // grown at the chain's first frame, whether or not the rotations lead
    scratch.rest.reserve(values.size());  // and the third start's, whether or not a frame needs it
    scratch.stalled.reserve(values.size());
    const bool chainStart = !(previousCost < retryNever);
    if (chainStart) scratch.lead = ChainLead{};
    const bool led = scratch.lead.rotations && solveRotationsFirst(solver, targets, values, scratch);
    const double tolerance = solver.options().targetTolerance;
    const double floor = 0.5 * tolerance * tolerance;
    // A warm solve gives up only at a cost that a fresh start follows (below).
    if (chainStart) solver.solveCold(targets, values, frame.summary);
    else solver.solveOrGiveUp(targets, values, frame.summary, 2.0 * previousCost + floor);
    const bool stalled = frame.summary.stalled;
    if (stalled) scratch.stalled.assign(values.begin(), values.end());
    decideLead(led, frame.summary, scratch.lead);
    if (led) {
        frame.summary.iterations += scratch.second.iterations;
        frame.summary.gaussNewtonIterations += scratch.second.gaussNewtonIterations;
        frame.summary.levenbergMarquardtIterations += scratch.second.levenbergMarquardtIterations;
    }
    // A solve that used its iterations after such a jump is as far from the frame before as a stuck one (C_Robot_Run
    // restarted every 2 or 4 frames: the frame after a restart, warm-started from the restart's other split of the
    // pose, ends unconverged 1.3 cm off).
    const TerminationType t = frame.summary.termination;
    if (!(previousCost < retryNever) || (t != TerminationType::stuck && t != TerminationType::noConvergence) ||
        !(frame.summary.finalCost > 2.0 * previousCost + floor))
        return;
    frame.retried = true;
    // First the guess at the warm start: it keeps what the chain chose where the targets leave a choice (the split
    // of a pose between redundant controls: a body's world and root, a foot's roll, bank and rotation). Only where that
    // one is stuck too, the guess from rest, as a restart's: taken first, its other split sent C_Robot_Run's later
    // frames into slow solves that did not converge (docs/maya.md).
    solver.initialGuess(targets, scratch.start);
    SolveSummary& second = scratch.second;
    solver.solveCold(targets, scratch.start, second);
    keepIfCheaper(second, scratch.start, floor, frame, values);
    if (frame.summary.converged()) return;
    if (stalled) {
        goOnFromStall(solver, targets, floor, scratch, frame, values);
        if (frame.summary.converged()) return;
    }
    const std::vector<ModelledParameter>& parameters = solver.approximation().parameters;
    scratch.rest.resize(parameters.size());
    for (std::size_t i = 0; i < parameters.size(); ++i) scratch.rest[i] = parameters[i].parameter.defaultValue;
    solver.initialGuess(targets, scratch.rest);
    solver.solveCold(targets, scratch.rest, second);
    keepIfCheaper(second, scratch.rest, floor, frame, values);
}

bool sameTarget(const JointTarget& a, const JointTarget& b)
{
    return a.active == b.active && a.term == b.term && sameBits({&a.positionWeight, 1}, {&b.positionWeight, 1}) &&
           sameBits({&a.rotationWeight, 1}, {&b.rotationWeight, 1}) &&
           sameBits({a.world.data(), 16}, {b.world.data(), 16});
}

// Whether solveChainFrame's call is the memo's (ChainMemo), to the bit.
bool sameCall(const ChainMemo& memo, const Solver& solver, std::span<const JointTarget> targets,
              std::span<const double> start, double previousCost, const ChainLead& lead)
{
    return memo.valid && memo.solver == &solver && sameBits({&memo.previousCost, 1}, {&previousCost, 1}) &&
           memo.leadIn.rotations == lead.rotations && memo.leadIn.wait == lead.wait &&
           memo.leadIn.backoff == lead.backoff && sameBits(memo.start, start) &&
           std::equal(memo.targets.begin(), memo.targets.end(), targets.begin(), targets.end(), sameTarget);
}

}  // namespace

void solveChainFrame(const Solver& solver, std::span<const JointTarget> targets, std::vector<double>& values,
                     double previousCost, ChainScratch& scratch, ChainFrame& frame)
{
    ChainMemo& memo = scratch.memo;
    if (!memo.on) return solveChainFrameOnce(solver, targets, values, previousCost, scratch, frame);
    if (sameCall(memo, solver, targets, values, previousCost, scratch.lead)) {
        values.assign(memo.answer.begin(), memo.answer.end());
        frame = memo.frame;
        frame.repeated = true;
        scratch.lead = memo.leadOut;
        return;
    }
    memo.valid = false;  // until the solve below has returned
    memo.solver = &solver;
    memo.targets.assign(targets.begin(), targets.end());
    memo.start.assign(values.begin(), values.end());
    memo.previousCost = previousCost;
    memo.leadIn = scratch.lead;
    solveChainFrameOnce(solver, targets, values, previousCost, scratch, frame);
    memo.answer.assign(values.begin(), values.end());
    memo.frame = frame;
    memo.leadOut = scratch.lead;
    memo.valid = true;
}

int solveHeldFrame(HeldFrameScratch& scratch, const HeldSolve& solveOnce, std::span<const JointTarget> targets,
                   std::vector<ContactHold>& holds, std::vector<double>& values, double previousCost, ChainFrame& frame)
{
    std::vector<JointTarget>& held = scratch.held;
    std::vector<Eigen::Matrix4d>& worlds = scratch.worlds;
    ChainFrame& round = scratch.round;
    int updates = 0;
    for (int k = 0;; ++k) {
        applyHolds(holds, targets, held);
        // Only the first solve may retry from the initial guess: later ones start at the answer they correct.
        solveOnce(held, values, k == 0 ? previousCost : retryNever, k == 0 ? frame : round);
        if (k > 0) {
            frame.summary.iterations += round.summary.iterations;
            frame.summary.gaussNewtonIterations += round.summary.gaussNewtonIterations;
            frame.summary.levenbergMarquardtIterations += round.summary.levenbergMarquardtIterations;
            frame.summary.termination = round.summary.termination;
            frame.summary.finalCost = round.summary.finalCost;
            frame.realRigEvaluations += round.realRigEvaluations;
        }
        if (frame.summary.termination == TerminationType::invalidTargets || k + 1 >= contactSolves) return updates;
        scratch.evaluator.evaluate(values, worlds);
        double worst = 0.0;
        for (const ContactHold& h : holds)
            worst = std::max(worst, (worlds[static_cast<std::size_t>(h.output)].block<3, 1>(0, 3) - h.position).norm());
        if (!(worst > contactToleranceCm)) return updates;  // met (or not finite: no update helps)
        // The method of multipliers: the target moves past the hold by what the solve left, so the next solve's
        // weighted rows carry the force the other targets pull with.
        for (ContactHold& h : holds)
            h.shift += h.position - worlds[static_cast<std::size_t>(h.output)].block<3, 1>(0, 3);
        ++updates;
    }
}

namespace {

// The real rig (`real`) and the approximation (`modelled`) at a frame's reported values against its targets: the
// errors, the missed outputs and the model's gap, into `f`; returns whether a missed output is one the
// approximation does not model and no solve fitted on the real rig.
bool measureFrame(const Approximation& a, const SolverOptions& o, RealRigFit fit, std::span<const JointTarget> targets,
                  std::span<const Eigen::Matrix4d> real, std::span<const Eigen::Matrix4d> modelled, FrameInversion& f)
{
    constexpr double degrees = 180.0 / std::numbers::pi;
    bool unfitted = false;
    double worstDisagreement = 0.0;  // the gap of f.mismatchOutput when it disagrees
    for (std::size_t k = 0; k < targets.size(); ++k) {
        const JointTarget& t = targets[k];
        if (!t.active) continue;
        // An unusable target has no error to measure: the solve says invalidTargets.
        if (!t.world.topRows<3>().allFinite()) {
            if (f.invalidJoint.empty()) f.invalidJoint = a.outputs[k].name;
            continue;
        }
        if (!real[k].topRows<3>().allFinite()) {
            if (f.nonFiniteJoint.empty()) f.nonFiniteJoint = a.outputs[k].name;
            continue;
        }
        const bool position = t.positionWeight > 0, rotation = t.rotationWeight > 0;
        const auto distance = [&](const Eigen::Matrix4d& m, const Eigen::Matrix4d& n) {
            const double p = position ? (m.block<3, 1>(0, 3) - n.block<3, 1>(0, 3)).stableNorm() : 0.0;
            const double r = rotation ? orientationAngle(m.topLeftCorner<3, 3>(), n.topLeftCorner<3, 3>()) : 0.0;
            return std::pair{p, r};
        };
        const auto [p, r] = distance(real[k], t.world);
        const std::string& name = a.outputs[k].name;
        f.positionErrorSumCm += p;
        f.rotationErrorSumDeg += r * degrees;
        ++f.countedJoints;
        if (worse(p, f.positionErrorCm) || f.worstJoint.empty()) {
            f.positionErrorCm = p;
            f.worstJoint = name;
        }
        if (worse(r * degrees, f.rotationErrorDeg) || f.worstRotationJoint.empty()) {
            f.rotationErrorDeg = r * degrees;
            f.worstRotationJoint = name;
        }
        const double error = worse(p, o.rotationScaleCm * r) ? p : o.rotationScaleCm * r;
        const bool onRealRig =
            fit == RealRigFit::everyOutput || (fit == RealRigFit::unmodelledOutputs && !a.outputs[k].modelled);
        if (!(error <= o.targetTolerance)) {
            f.missed.push_back({static_cast<int>(k), p, r * degrees, error});
            if (!a.outputs[k].modelled && !onRealRig && !unfitted) {
                unfitted = true;
                if (!f.disagrees) f.mismatchOutput = static_cast<int>(k);
            }
        }
        if (onRealRig || !a.outputs[k].modelled) continue;
        const auto [gp, gr] = distance(modelled[k], real[k]);
        const double gap = worse(gp, o.rotationScaleCm * gr) ? gp : o.rotationScaleCm * gr;
        if (worse(gap, f.modelGapCm)) f.modelGapCm = gap;
        // The approximation's word on this output holds where its gap is small beside the error it leaves.
        if (!(gap <= std::max(o.targetTolerance, modelAgreement * error)) &&
            (!f.disagrees || worse(gap, worstDisagreement))) {
            f.disagrees = true;
            f.mismatchOutput = static_cast<int>(k);
            worstDisagreement = gap;
        }
    }
    return unfitted;
}

FrameStatus frameStatus(const FrameInversion& f, bool unfittedMiss)
{
    const TerminationType t = f.solve.termination;
    if (t == TerminationType::invalidTargets || t == TerminationType::noTargets) return FrameStatus::invalidTargets;
    // A solve whose cost overflowed (a target 1e160 cm away: its square is past a double's range) measured nothing.
    if (!f.nonFiniteJoint.empty() || !std::isfinite(f.positionErrorCm) || !std::isfinite(f.rotationErrorDeg) ||
        !std::isfinite(f.solve.finalCost))
        return FrameStatus::nonFinite;
    if (f.missed.empty()) return FrameStatus::reached;
    if (t == TerminationType::noConvergence) return FrameStatus::notConverged;
    if (unfittedMiss || f.disagrees) return FrameStatus::modelMismatch;
    return FrameStatus::bestFit;
}

// The real rig's joints at reported frame `frame` against each covering contact's reference (its first reported
// frame's position), into `slides` (a contact's entry made at its first reported frame, in the contacts' order).
void measureSlides(std::span<const Contact> contacts, int frame, std::span<const Eigen::Matrix4d> real,
                   std::vector<ContactSlide>& slides)
{
    for (const Contact& c : contacts) {
        if (frame < c.first || frame > c.last) continue;
        auto it = std::find_if(slides.begin(), slides.end(),
                               [&](const ContactSlide& s) { return s.output == c.output && s.first == c.first; });
        if (it == slides.end()) it = slides.insert(slides.end(), {c.output, c.first, c.last, frame, {}, 0.0});
        it->add(real[static_cast<std::size_t>(c.output)].block<3, 1>(0, 3));
    }
}

}  // namespace

void FrameInversion::clear()
{
    std::array<std::string*, 6> names{&worstJoint,   &worstRotationJoint,  &nonFiniteJoint,
                                      &invalidJoint, &rangeLeft.parameter, &solve.worstOutput};
    std::array<std::string, 6> kept;
    for (std::size_t i = 0; i < names.size(); ++i) kept[i] = std::move(*names[i]);
    std::vector<Missed> missedKept = std::move(missed);
    std::vector<int> missedOutputsKept = std::move(solve.missedOutputs);
    *this = FrameInversion{};
    for (std::size_t i = 0; i < names.size(); ++i) {
        kept[i].clear();
        *names[i] = std::move(kept[i]);
    }
    missedKept.clear();
    missed = std::move(missedKept);
    missedOutputsKept.clear();
    solve.missedOutputs = std::move(missedOutputsKept);
}

void judgeFrame(const Approximation& approximation, const SolverOptions& options, RealRigFit fit,
                std::span<const JointTarget> targets, std::span<const Eigen::Matrix4d> real,
                std::span<const Eigen::Matrix4d> modelled, FrameInversion& frame)
{
    const bool unfitted = measureFrame(approximation, options, fit, targets, real, modelled, frame);
    frame.status = frameStatus(frame, unfitted);
}

namespace {

// The callers' frames and contacts within the clip and the approximation: a caller's mistake, not a user's.
void checkClipRange(const Approximation& approximation, const ClipTargets& targets, int first, int last,
                    const ClipInversionOptions& options)
{
    options.validate();
    const int frameCount = static_cast<int>(targets.frames.size());
    if (first < 0 || last >= frameCount || first > last)
        throw internalError(fmt::format("frames {}..{} are not within the clip's 0..{}", first, last, frameCount - 1));
    for (const Contact& c : options.contacts)
        if (c.last >= frameCount || c.output >= static_cast<int>(approximation.outputs.size()))
            throw internalError(
                fmt::format("a contact of output {} over frames {}..{} is not within the clip's "
                            "0..{} and outputs",
                            c.output, c.first, c.last, frameCount - 1));
}

// Whether invertClip polishes the frames the real rig judges small model mismatches (ClipInversionOptions).
bool polishesMismatches(const ClipInversionOptions& o)
{
    return o.polishCorrections == 0 && o.mismatchPolishCorrections > 0 && !o.frameSolve;
}

// Whether frame `f`, as judged, is a model mismatch it polishes: missed by at most smallMismatch times `tolerance`.
bool smallMismatch(const ClipInversionOptions& o, double tolerance, const FrameInversion& f)
{
    if (!polishesMismatches(o) || f.status != FrameStatus::modelMismatch ||
        f.solve.termination == TerminationType::invalidTargets)
        return false;
    double worst = 0.0;
    for (const FrameInversion::Missed& m : f.missed) worst = std::max(worst, m.scaledErrorCm);
    return worst <= ClipInversionOptions::smallMismatch * tolerance;
}

}  // namespace

ClipInversionSummary invertClip(const Solver& solver, RigBinding& rig, const ClipTargets& targets, int first, int last,
                                const ClipInversionOptions& options, std::vector<std::vector<double>>& values,
                                std::vector<std::vector<double>>* solvedValues)
{
    checkClipRange(solver.approximation(), targets, first, last, options);
    const Approximation& approximation = solver.approximation();
    const std::vector<double> rest = approximation.defaults();

    ClipInversionSummary summary;
    summary.leadInFrames = first % options.restartInterval;
    values.clear();
    if (solvedValues) solvedValues->clear();
    std::vector<double> current = rest;
    // Each chunk shifted by equivalences to meet the warm frame before it (continuity.h), where the approximation and
    // the real rig find the same pose; the chain itself, `current`, is what was solved. The frame before the lead-in
    // (a restart frame) is a warm one unless every frame restarts.
    PoseCheck samePose(approximation, &rig);
    ChainContinuity continuity(solver.equivalences(), options.continueFrom, options.restartInterval > 1, &samePose);
    ChainScratch chainScratch;
    ChainFrame solved;
    double previousCost = 0.0;
    std::vector<Eigen::Matrix4d> worlds, modelled;
    const HeldSolve solveOnce = [&](std::span<const JointTarget> t, std::vector<double>& v, double previous,
                                    ChainFrame& f) {
        if (options.frameSolve) options.frameSolve(t, v, previous, f);
        else solveChainFrame(solver, t, v, previous, chainScratch, f);
    };
    std::vector<ContactHold> holds;
    std::vector<Eigen::Vector3d> shifts(options.contacts.size(), Eigen::Vector3d::Zero());
    std::vector<JointTarget> heldTargets;
    HeldFrameScratch heldScratch(approximation);
    using Clock = std::chrono::steady_clock;
    {
        const auto setupStart = Clock::now();
        const double setupCpuStart = threadCpuSeconds();
        solver.prepare(targets.frames[static_cast<std::size_t>(first - summary.leadInFrames)]);
        summary.setupSeconds = std::chrono::duration<double>(Clock::now() - setupStart).count();
        summary.setupCpuSeconds = threadCpuSeconds() - setupCpuStart;
    }
    for (int frame = first - summary.leadInFrames; frame <= last; ++frame) {
        const auto& frameTargets = targets.frames[frame];
        const auto start = Clock::now();
        const double cpuStart = threadCpuSeconds();
        const bool restart = frame % options.restartInterval == 0;
        if (restart) {
            current = rest;
            if (options.coldStart) solver.initialGuess(frameTargets, current);
        }
        const double previous = restart ? retryNever : options.retryStuck ? previousCost : noRetry;
        if (restart) std::fill(shifts.begin(), shifts.end(), Eigen::Vector3d::Zero());
        if (options.holdContacts) contactHolds(options.contacts, targets, frame, shifts, holds);
        const int rounds = holds.empty()
                               ? (solveOnce(frameTargets, current, previous, solved), 0)
                               : solveHeldFrame(heldScratch, solveOnce, frameTargets, holds, current, previous, solved);
        for (const ContactHold& h : holds) shifts[static_cast<std::size_t>(h.contact)] = h.shift;
        const SolveSummary& solve = solved.summary;
        if (solve.termination != TerminationType::invalidTargets) previousCost = solve.finalCost;
        if (options.polishCorrections > 0 && !options.frameSolve &&
            solve.termination != TerminationType::invalidTargets) {
            // The polish keeps the holds as the solve left them (its targets the held ones).
            applyHolds(holds, frameTargets, heldTargets);
            polish(solver, rig, heldTargets, current, options.polishCorrections);
        }
        double seconds = std::chrono::duration<double>(Clock::now() - start).count();
        double cpuSeconds = threadCpuSeconds() - cpuStart;
        std::span<const double> reported = continuity.next(current, restart);
        FrameInversion result;
        const auto judge = [&] {
            result.clear();
            result.frame = frame;
            result.solve = solve;
            result.realRigEvaluations = solved.realRigEvaluations;
            rig.evaluate(reported, worlds);
            heldScratch.evaluator.evaluate(reported, modelled);
            judgeFrame(approximation, solver.options(), options.realRigFit, frameTargets, worlds, modelled, result);
        };
        // Judged at the lead-in frames too where a small mismatch may be polished: the chain goes on from the
        // polished values, and a chunk's must be one run's.
        if (frame >= first || polishesMismatches(options)) judge();
        if (smallMismatch(options, solver.options().targetTolerance, result)) {
            const auto polishStart = Clock::now();
            const double polishCpuStart = threadCpuSeconds();
            applyHolds(holds, frameTargets, heldTargets);
            polish(solver, rig, heldTargets, current, options.mismatchPolishCorrections);
            seconds += std::chrono::duration<double>(Clock::now() - polishStart).count();
            cpuSeconds += threadCpuSeconds() - polishCpuStart;
            reported = continuity.again(current);
            judge();
        }
        if (frame < first) continue;

        summary.solveSeconds += seconds;
        summary.solveCpuSeconds += cpuSeconds;
        values.emplace_back(reported.begin(), reported.end());
        if (solvedValues) solvedValues->push_back(current);
        if (result.status == FrameStatus::modelMismatch)
            result.rangeLeft = rangeLeft(approximation, reported, result.mismatchOutput);
        summary.retriedFrames += solved.retried;
        summary.retriesKept += solved.kept;
        summary.multiplierUpdates += rounds;
        measureSlides(options.contacts, frame, worlds, summary.contacts);
        summary.add(result, approximation.outputs);
        summary.perFrame.push_back(std::move(result));
        if (options.progress) options.progress(static_cast<double>(frame - first + 1) / (last - first + 1));
    }
    summary.sortResidualJoints();
    summary.msPerFrame = summary.frames > 0 ? 1000.0 * summary.solveSeconds / summary.frames : 0.0;
    return summary;
}

}  // namespace rig
