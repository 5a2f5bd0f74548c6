#pragma once
// Inverting a clip: one solve per frame on the approximation, warm-started from the previous frame,
// then the real rig re-evaluated with the recovered values to measure what the animator will see.
//
// Warm-start chains and chunks. Frame i (0-based in the clip) is warm-started from frame i - 1's
// solution, except at restart frames (i a multiple of `restartInterval`), which start again from the
// rest values, or from Solver::initialGuess on the frame's targets (`coldStart`, the default). A run over frames
// [first, last] therefore begins its chain at the restart frame at or before `first` and solves the lead-in frames
// without reporting them. Angular parameters move continuously inside a chain (the solver keeps a periodic control at
// the equivalent value nearest its warm start, never whole turns away); a restart starts again from its targets, so the
// values reported for each chain after the first are shifted as a whole by equivalences (whole turns, the other Euler
// solution: inversion/clip/continuity.h) to meet the frame before it. The chain is unchanged, so chunks give, bit for
// bit, the values and per-frame errors of one run over the whole clip, provided each chunk after the first continues
// from the values reported for the frame before its lead-in (`continueFrom`).

#include <array>
#include <functional>
#include <limits>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "inversion/clip/contacts.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/model/approximation.h"
#include "inversion/model/learned_range.h"
#include "inversion/solve/solver_options.h"

namespace rig {

// Targets of a clip, matched to the approximation's outputs by name.
struct ClipTargets {
    std::vector<int> outputOfJoint;                // per clip joint: its approximation output, -1 for none
    std::vector<std::vector<JointTarget>> frames;  // [frame][output]
    int matchedJoints = 0;                         // clip joints that are outputs
    std::vector<std::string> unmatchedJoints;      // clip joints that are not (not targets)
};

// Throws rig::Error when no clip joint is an output of the approximation.
ClipTargets matchTargets(const Approximation& approximation, std::span<const std::string> joints,
                         std::span<const std::vector<Eigen::Matrix4d>> worlds);

// One frame of a warm-start chain (invertClip and the rigInversion node): solve from `values` (the warm
// start, out the solution). When it ends stuck (or unconverged) at a cost above twice `previousCost` plus
// 0.5 targetTolerance^2, it is solved again from Solver::initialGuess at the same warm start and the
// cheaper answer is kept (ClipInversionOptions::retryStuck); where that one does not converge either, once more from
// Solver::initialGuess at the rest values (as a restart frame starts), the cheapest kept. `previousCost` = retryNever:
// a chain's first frame (a restart), solved by Solver::solveCold and not retried; noRetry: a later frame never retried.
// The warm solve gives up where its cost stalls above that retry bound (Solver::solveOrGiveUp); where neither fresh
// start converges, it goes on from where it stopped, and the cheapest answer is kept.
// `frame` is the result; it and `scratch` keep their storage from frame to frame, so that a chain allocates
// nothing once they have grown.
//
// The rotations lead (docs/solver.md, long chains): after a frame whose first step was longer than the angular trust
// region allows (SolveSummary::longFirstStep), the next frame is solved first with every position weighed
// rotationsLeadPositionWeight times its own, then from that answer with the targets' own weights. The targets' world
// rotations fix each joint's local rotation without the lever arms that make a long chain's far positions so far from
// linear; where the targets are reached, the second solve takes one step. The rotations keep leading while that holds
// (the second solve converges at its first step). Where it does not (targets out of reach: the two weightings have
// different optima), the lead did not pay, and the next one waits 4 frames, then 8, 16, ... Targets without a rotation
// to lead are solved plainly. A chain's first frame (`previousCost` = retryNever) starts without a lead, so that a
// chunk of a clip solves as the whole clip does from the same restart frame.
inline constexpr double retryNever = std::numeric_limits<double>::infinity();
inline constexpr double noRetry = std::numeric_limits<double>::max();  // no finite cost is above twice it
struct ChainFrame {
    SolveSummary summary;  // of the answer kept; iterations of every solve the frame ran
    bool retried = false;
    bool kept = false;           // the second answer was cheaper
    int realRigEvaluations = 0;  // of a hybrid solve (hybrid_solve.h); 0 on the approximation alone
    bool repeated = false;       // the call was the last one's: its answer taken, not solved again (ChainMemo)
};
inline constexpr double rotationsLeadPositionWeight = 0.01;
// Whether the rotations lead a chain's next frame: state carried from frame to frame, as the values are (a caller that
// solves one frame again, as the rigInversion node does when its inputs change, restores it with the values).
struct ChainLead {
    bool rotations = false;  // the next frame is solved with the rotations leading
    // After a lead that did not pay, the frames to wait before the rotations lead again, and the wait after the next
    // one that does not (doubled each time, back to firstWait once a lead pays).
    int wait = 0;
    int backoff = firstWait;
    static constexpr int firstWait = 4;
};
// A chain frame's last call and what it gave. A solve is a pure function of its targets and start (a Solver is const),
// and solveChainFrame of those, the previous cost and the lead: a call the same as the last one to the bit (a held pose
// of a clip, the same targets from the answer the same targets gave) with the same solver gives the same answer,
// summary and all, and is not solved again. Off (`on` false) where one scratch serves many chains in turn (the
// rigInversion node's pool, shared by a crowd's members): the last call is then another chain's, and keeping it would
// only add to what a frame writes.
struct ChainMemo {
    bool on = true;
    bool valid = false;
    const Solver* solver = nullptr;
    std::vector<JointTarget> targets;
    std::vector<double> start;
    double previousCost = 0.0;
    ChainLead leadIn, leadOut;
    std::vector<double> answer;
    ChainFrame frame;
};
struct ChainScratch {
    std::vector<double> start;    // the warm start, for the second solve
    std::vector<double> rest;     // the rest values, for a third
    std::vector<double> stalled;  // where a warm solve gave up (Solver::solveOrGiveUp), to go on from
    SolveSummary second;
    ChainLead lead;                // reset at a chain's first frame (previousCost = retryNever)
    std::vector<JointTarget> led;  // a led frame's targets, positions weighed rotationsLeadPositionWeight times theirs
    ChainMemo memo;
};
void solveChainFrame(const Solver& solver, std::span<const JointTarget> targets, std::vector<double>& values,
                     double previousCost, ChainScratch& scratch, ChainFrame& frame);

// One frame with contacts held (inversion/clip/contacts.h): `solveOnce` (a chain frame's solve on the held targets) run
// again with each hold's multiplier updated until every held output is within contactToleranceCm of its hold on the
// approximation, or contactSolves solves. `holds` come in with their shifts (contactHolds) and leave with the last;
// `frame` sums the solves' iterations. Returns the multiplier updates made.
using HeldSolve = std::function<void(std::span<const JointTarget> targets, std::vector<double>& values,
                                     double previousCost, ChainFrame& frame)>;
// What solveHeldFrame reuses from frame to frame (a player holds contacts every frame): the approximation's evaluator
// and the held targets, the worlds and the later rounds' figures.
struct HeldFrameScratch {
    explicit HeldFrameScratch(const Approximation& approximation) : evaluator(approximation) {}
    ApproximationEvaluator evaluator;
    std::vector<JointTarget> held;
    std::vector<Eigen::Matrix4d> worlds;
    ChainFrame round;
};
int solveHeldFrame(HeldFrameScratch& scratch, const HeldSolve& solveOnce, std::span<const JointTarget> targets,
                   std::vector<ContactHold>& holds, std::vector<double>& values, double previousCost,
                   ChainFrame& frame);

// How a chain solves one frame: `values` in, the warm start (at a restart frame, the start the options
// chose), out, the solution; `previousCost` as solveChainFrame takes it; `frame` the result. Empty: the
// approximation's solver, as rig-invert runs it (solveChainFrame). rig-bench plugs its peers in (Gauss-Newton
// on the real rig, Ceres), so that every solver runs in the very same chains.
using FrameSolveStrategy = std::function<void(std::span<const JointTarget> targets, std::vector<double>& values,
                                              double previousCost, ChainFrame& frame)>;

// Which outputs the per-frame solve fits on the real rig itself (a hybrid solve: those the approximation does
// not model; a peer such as Gauss-Newton on the real rig: every output). A frame left with a residual there is a
// best fit without the approximation's agreement, which the other outputs need (FrameStatus).
enum class RealRigFit { none, unmodelledOutputs, everyOutput };

struct ClipInversionOptions {
    SolverOptions solver;
    RealRigFit realRigFit = RealRigFit::none;
    // Real-rig polish corrections per frame (inversion/clip/rig_binding.h, polish()); 0: approximation only.
    int polishCorrections = 0;
    // With polishCorrections 0, a frame the real rig judges a model mismatch missed by at most smallMismatch times
    // targetTolerance (the larger of the position error and rotationScaleCm times the rotation's) is polished with
    // mismatchPolishCorrections, and judged again: a gap that small is the learned curves' rounding (C_Robot_Rig's
    // ToeRoll driven key, kinked at its rest value: 0.0033 cm and 0.064 degrees, 11 times the tolerance on the
    // rotation scale), which the polish's correction by the gap at the answer takes out; a larger one is a model to
    // learn again, polished only when asked. 0 corrections: never.
    int mismatchPolishCorrections = 2;
    static constexpr double smallMismatch = 20.0;
    // Frames between warm-start restarts (see above), > 0. 120 frames: one second of a 120 fps clip,
    // so a chunk re-solves at most 119 lead-in frames.
    int restartInterval = 120;
    // Restart frames start from Solver::initialGuess (the approximation's structure decomposes each
    // joint's target) rather than from the rest values, which can lie in another basin of the cost.
    bool coldStart = true;
    // A warm-started frame that ends stuck or unconverged with a cost above twice the previous frame's (a jump into
    // another basin: a gimbal lock passed, a fast turn) is solved again from Solver::initialGuess started
    // at the warm start, and the cheaper answer kept; where that does not converge either, from
    // Solver::initialGuess at the rest values too (solveChainFrame). A clip the rig cannot reach exactly stays
    // stuck at a steady cost and is not solved again.
    bool retryStuck = true;
    // The values (internal units, one per parameter) reported for the frame just before the first frame
    // solved (the restart frame at or before `first`): the chunk before, as one run over both reported it.
    // The first chain is shifted to meet them, as later chains meet theirs. Empty: the first chain is
    // reported as solved.
    std::vector<double> continueFrom;
    // Called after each reported frame with the fraction done; may be empty.
    std::function<void(double fraction)> progress;
    // The per-frame solve; empty: the solver's (see FrameSolveStrategy). A strategy gets no polish.
    FrameSolveStrategy frameSolve;
    // Joints planted over frame ranges (inversion/clip/contacts.h), each held at its target's position at the contact's
    // first frame with a priority above the other targets, and its slide on the real rig measured
    // (ClipInversionSummary::contacts). Empty: none.
    std::vector<Contact> contacts;
    // false: the contacts' slides measured but the contacts not held (a run to compare with).
    bool holdContacts = true;

    // Throws rig::Error naming the field (and the solver's fields).
    void validate() const;
};

// How far the approximation and the real rig may disagree on an output, at a frame's answer, for that answer to be
// the real rig's best fit: a fraction of the error the real rig leaves there (or targetTolerance, if larger). An
// approximation is exact within its validation epsilon on the poses it was learned for; past them (a sampled
// operator extrapolated: the biped's sliding knees beyond 90 degrees) its gap grows, and a gap this small beside
// the residual moves the best fit by no more than this fraction of it.
inline constexpr double modelAgreement = 0.1;

// What a frame's answer is, judged on the real rig at the values reported for it (docs/rig-invert.md, Frame
// statuses). Only reached and bestFit are answers a run may exit 0 with.
enum class FrameStatus {
    reached,         // every counted target within targetTolerance on the real rig
    bestFit,         // stationary with a residual, where the approximation and the real rig agree (each output's gap
                     // within modelAgreement of its error): the pose is out of the rig's reach, or a local minimum
    modelMismatch,   // a target missed on the real rig where the approximation and the real rig disagree beyond
                     // targetTolerance, or an output the approximation does not model and no solve fitted
    notConverged,    // the solve used its iterations
    nonFinite,       // the real rig gave a non-finite matrix, or an error is not finite
    invalidTargets,  // a target cannot be used (not finite, singular) or none is active: no answer
};
inline constexpr int frameStatusCount = 6;
// Every spelling of each status, in FrameStatus order: the one table that text reports, JSON keys and the
// rigInversion node's enum read, so that no two places spell a status apart. `words`: text and the JSON values of
// rig-invert, rig-batch and Python ("best fit"); `key`: a JSON object's key, its count's in `status_frames`
// ("best_fit"); `enumName`: the rigInversion node's `status` attribute, named as attribute values are (camelCase:
// graph-eval writes "bestFit" in JSON, table and CSV alike).
struct FrameStatusSpelling {
    std::string_view words, key, enumName;
};
inline constexpr std::array<FrameStatusSpelling, frameStatusCount> frameStatusSpellings{{
    {"reached", "reached", "reached"},
    {"best fit", "best_fit", "bestFit"},
    {"model mismatch", "model_mismatch", "modelMismatch"},
    {"not converged", "not_converged", "notConverged"},
    {"non-finite", "non_finite", "nonFinite"},
    {"invalid targets", "invalid_targets", "invalidTargets"},
}};
// frameStatusSpellings' words: "reached", "best fit", "model mismatch", "not converged", "non-finite", ...
std::string_view frameStatusName(FrameStatus status);
// frameStatusSpellings' key, the JSON key of its count: "reached", "best_fit", "model_mismatch", ...
std::string frameStatusKey(FrameStatus status);
inline bool frameStatusFails(FrameStatus status)
{
    return status != FrameStatus::reached && status != FrameStatus::bestFit;
}

struct FrameInversion {
    int frame = 0;  // index in the clip, 0-based
    FrameStatus status = FrameStatus::reached;
    SolveSummary solve;  // on the approximation (a hybrid solve's: on the real rig)
    // Real rig against the targets, over the counted halves of the active targets: the worst position error and
    // its joint, the worst rotation error and its joint (each their own). A non-finite error is kept as it is
    // (never dropped, never 0) and makes the frame nonFinite.
    double positionErrorCm = 0.0;
    std::string worstJoint;
    double rotationErrorDeg = 0.0;
    std::string worstRotationJoint;
    // Largest disagreement of the approximation with the real rig at the reported values over the counted
    // outputs it models (cm, a rotation as rotationScaleCm * radians); 0 for outputs fitted on the real rig.
    double modelGapCm = 0.0;
    // Some counted output's gap is over max(targetTolerance, modelAgreement * its real-rig error): the
    // approximation's answer cannot be taken as the real rig's best fit there.
    bool disagrees = false;
    // What makes it a modelMismatch: the output whose gap disagrees most, else a missed output the approximation
    // does not model and no solve fitted; -1 for none. And with it, where invertClip judged it, the parameter
    // outside its learned range that moves that output (learned_range.h; found() false for none).
    int mismatchOutput = -1;
    RangeLeft rangeLeft;
    // Outputs further than targetTolerance on the real rig, increasing, each with its errors there: position (cm) and
    // rotation (degrees) apart, and the larger of the position error and rotationScaleCm * the rotation in radians,
    // the one measure the tolerance judges (cm on the rotation scale: never shown as a distance).
    struct Missed {
        int output = -1;
        double positionErrorCm = 0.0;
        double rotationErrorDeg = 0.0;
        double scaledErrorCm = 0.0;
    };
    std::vector<Missed> missed;
    // Sums over the counted halves of the active targets, for the clip's means.
    double positionErrorSumCm = 0.0;
    double rotationErrorSumDeg = 0.0;
    int countedJoints = 0;
    std::string nonFiniteJoint;  // a joint the real rig gave a non-finite matrix for, or ""
    std::string invalidJoint;    // a joint whose target is not finite (not measured), or ""
    int realRigEvaluations = 0;  // by the solve (a hybrid solve's second stage), not by this measurement
    // Whether the real rig was measured against some target here: a frame of invalid targets was not, and its
    // errors and joints are reported as null, never as 0.
    bool measured() const { return countedJoints > 0; }
    // Back to a new frame's figures, the names' and the list's storage kept: a player judges every frame.
    void clear();
};

struct ClipInversionSummary {
    int frames = 0;
    std::array<int, frameStatusCount> statusFrames{};  // frames per FrameStatus
    int retriedFrames = 0;                             // solved again from the initial guess (retryStuck)
    int retriesKept = 0;                               // of which the second answer was cheaper and kept
    // The first frame whose status fails (frameStatusFails), its status and the joint that shows it (a model
    // mismatch's: FrameInversion::mismatchOutput); -1: none. A model mismatch's parameter outside its learned range,
    // covering the values it took over the frames that blamed it too.
    int firstFailedFrame = -1;
    FrameStatus firstFailedStatus = FrameStatus::reached;
    std::string firstFailedJoint;
    RangeLeft firstFailedRange;
    // The outputs frames left further than targetTolerance on the real rig, with how many frames did and their worst
    // position (cm) and rotation (degrees) errors on those frames, each its own worst: the joints that carry the
    // residual. Ordered by worstScaledErrorCm (FrameInversion::Missed::scaledErrorCm), the measure that missed them.
    struct ResidualJoint {
        std::string name;
        int frames = 0;
        double worstPositionErrorCm = 0.0;
        double worstRotationErrorDeg = 0.0;
        double worstScaledErrorCm = 0.0;
    };
    std::vector<ResidualJoint> residualJoints;
    // Real rig, over every counted half of every active target of every measured frame. Maxima and means keep a
    // NaN or an infinity (no figure hides one); when no frame was measured (measured() is false) they are 0 and the
    // frames -1, which reports show as null.
    double maxPositionErrorCm = 0.0;
    double meanPositionErrorCm = 0.0;  // mean over joints and frames
    double maxRotationErrorDeg = 0.0;
    double meanRotationErrorDeg = 0.0;
    std::string worstJoint;  // of the worst position error
    int worstFrame = -1;     // 0-based clip index
    std::string worstRotationJoint;
    int worstRotationFrame = -1;
    double maxModelGapCm = 0.0;  // FrameInversion::modelGapCm, worst over frames
    double solveSeconds =
        0.0;  // solver and polish time of the reported frames (lead-in and the error measurement excluded)
    double solveCpuSeconds = 0.0;  // the same span in this thread's CPU time (steadier on a busy machine)
    double msPerFrame = 0.0;       // solveSeconds per reported frame, ms
    // The solver's one-time setup for the clip's targets (Solver::prepare: its plan and the initial guess's steps),
    // before the first frame and not in solveSeconds; wall-clock and this thread's CPU time.
    double setupSeconds = 0.0;
    double setupCpuSeconds = 0.0;
    int leadInFrames = 0;              // solved before `first` to join the warm-start chain
    long long realRigEvaluations = 0;  // by the solves of the reported frames (a hybrid solve's); 0 otherwise
    long long jointFrames = 0;         // the (joint, frame) pairs the means are over
    std::vector<FrameInversion> perFrame;
    // The contacts that cover reported frames, in the options' order, with their slides on the real rig.
    std::vector<ContactSlide> contacts;
    int multiplierUpdates =
        0;  // contacts: multiplier updates over the reported frames (solves beyond one per held frame)

    int count(FrameStatus status) const { return statusFrames[static_cast<std::size_t>(status)]; }
    bool measured() const { return jointFrames > 0; }
    int failedFrames() const;
    // Adds one frame's figures (its status, errors, residual joints, first failure), as invertClip gathers them
    // frame after frame (perFrame is not touched); `outputs` names the approximation's outputs. rig-batch joins
    // its shards' summaries with merge().
    void add(const FrameInversion& frame, const std::vector<ApproximationOutput>& outputs);
    // Adds another summary of later frames (sums, maxima with the first frame on a tie, the first failure).
    void merge(const ClipInversionSummary& later);
    // residualJoints, the largest scaled error first (a NaN first of all).
    void sortResidualJoints();
    // `frames` more frames that left joint `joint.name` off its target, with their worst errors.
    void addResidual(const ResidualJoint& joint);
    std::string briefReport() const;
};

// Judges one frame at the values reported for it: `real`, the real rig's output matrices there, and `modelled`, the
// approximation's, against `targets`; fills `frame`'s errors, missed outputs, model gap and status (frame.solve must
// hold its solve's summary). Without a real rig (the rigInversion node without `rig`), `real` may be the
// approximation's matrices: the status is then the approximation's word, and an output it does not model is a miss.
void judgeFrame(const Approximation& approximation, const SolverOptions& options, RealRigFit fit,
                std::span<const JointTarget> targets, std::span<const Eigen::Matrix4d> real,
                std::span<const Eigen::Matrix4d> modelled, FrameInversion& frame);

// Inverts frames [first, last] (0-based, inclusive) of `targets`. `values` receives one row per reported
// frame, one value per Approximation::parameters entry (internal units). `rig` evaluates the real rig.
// `solvedValues`, when given, receives the same rows as solved, before each chain's shift (ChainContinuity):
// rig-batch solves a clip's chains apart and replays the shifts over them.
ClipInversionSummary invertClip(const Solver& solver, RigBinding& rig, const ClipTargets& targets, int first, int last,
                                const ClipInversionOptions& options, std::vector<std::vector<double>>& values,
                                std::vector<std::vector<double>>* solvedValues = nullptr);

}  // namespace rig
