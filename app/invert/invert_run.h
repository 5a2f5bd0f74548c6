#pragma once
// rig-invert's work from its inputs to its curves and report, shared by the command line
// (tools/rig_invert.cpp) and the Python module (python/riginv.cpp), so that both give the same values,
// the same report and the same one-line errors (docs/rig-invert.md, docs/python.md).

#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "adapter/graph_rig_function.h"
#include "app/common/solve_settings.h"
#include "app/common/value_output.h"
#include "inversion/clip/clip_inversion.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/model/approximation.h"
#include "nodes/clips/target_clip.h"

namespace rig::app {

// The options for invertClip. Throws rig::Error naming the flag of a bad value (settings made in code: the command
// lines, the manifest and Python check theirs with the names they give them).
ClipInversionOptions clipInversionOptions(const SolveSettings& settings);

// The inputs of an inversion, however it starts (rig-invert's flags, rig-batch's flags and manifest, Python's
// Approximation.invert): the files it reads and the solve's settings, declared once so that they agree.
struct InversionInputs {
    std::string approximation;  // its file, or what names it in messages (one given in memory)
    std::string rig;
    std::string map;   // renames and scales the targets; "" for none
    std::string take;  // the animation to read from a clip file with several: a name or 0-based index; "" the first
    std::vector<std::string> plugins;
    bool strict = false;  // refuse an approximation learned from another version of the rig
    // Joints held where they are planted (app/invert/contacts_run.h): "auto" (detected), a contacts file, or "" (none).
    std::string contacts;
    SolveSettings settings;
};

// One inversion: its inputs, and the targets and frames to invert.
struct InvertJob : InversionInputs {
    // The approximation when already in memory; null: read from `approximation`, after the settings are checked.
    std::shared_ptr<const Approximation> loadedApproximation;
    // The targets: the clip file `clip`, or `targets` when set (joints and worlds as given, `file` naming
    // them in messages); either way renamed and scaled by the map file `map` ("" for none).
    std::string clip;
    std::optional<TargetClip> targets;
    std::optional<std::string> frames;  // A:B in the clip's numbering; none: the whole clip
    // Or the frames as clip indices (0-based), first and last: rig-batch's shards.
    std::optional<std::pair<int, int>> frameIndices;
    std::string after;                        // the curves of the chunk before (rig-invert --after), "" for none
    std::string contactsName = "--contacts";  // how messages name `contacts` (Python: "contacts")
    // Called after each reported frame with the frames done and the frames to report; may be empty.
    std::function<void(int done, int total)> progress;
    // Called with a warning line (the rig changed since learning); may be empty.
    std::function<void(const std::string& warning)> warning;
    // Called once the rig is loaded, before the work (rig-invert checks its outputs against the rig's files).
    std::function<void(const GraphRigFunction& rig)> rigLoaded;
};

struct InvertOutcome {
    std::shared_ptr<const Approximation> approximation;
    std::shared_ptr<GraphRigFunction> rig;  // the real rig, for measuring more (keys, the HTML report)
    TargetClip clip;                        // after the map
    ClipTargets targets;
    int first = 0;  // the first reported frame, an index into clip.frameNumbers
    ClipInversionSummary summary;
    std::vector<std::vector<double>> values;  // [reported frame][parameter], internal units
    // The same as solved, before each warm-start chain's continuity shift (rig-batch replays the shifts).
    std::vector<std::vector<double>> solved;
    // With settings.hybrid: the blocks solved on the real rig (HybridSolver::describe), one per line.
    std::string hybridBlocks;
    bool contactsAsked = false;  // the job named contacts (the report then has their slides, even with none found)
};

// Checks the settings, reads what the job names, binds the approximation to the rig and inverts the
// frames. Throws rig::Error with rig-invert's one-line messages.
InvertOutcome invert(const InvertJob& job);

// invert's steps, for rig-batch, which checks every clip of a library before any work. Each throws
// rig::Error with rig-invert's one-line messages.
// The approximation (job.loadedApproximation, or read from job.approximation) and the rig it names, loaded
// with the approximation's parameters, outputs and held plugs (rigOptionsFor); job.rigLoaded is called,
// then job.warning when the rig changed since learning (an error with job.strict).
struct LoadedRig {
    std::shared_ptr<const Approximation> approximation;
    std::shared_ptr<GraphRigFunction> rig;
};
LoadedRig loadRig(const InvertJob& job);
// The approximation bound to the rig by names.
RigBinding bindRig(const InvertJob& job, const Approximation& approximation, GraphRigFunction& rig);
// The job's targets (job.targets or the clip file), the map applied: renamed, scaled and, with its `retarget:`,
// retargeted onto the approximation's rest skeleton (adapter/retarget.h). `map`, when given, receives the map
// (its `weights:` are applied to the matched targets, applyTargetWeights).
TargetClip readTargets(const InvertJob& job, const Approximation& approximation, TargetMap* map = nullptr);
// The clip's joints matched to the approximation's outputs; none matching is an error.
ClipTargets matchClipTargets(const Approximation& approximation, const TargetClip& clip);

// A parameter's curve values in user units (degrees for angles, cm), as the curves files hold them:
// [reported frame][parameter].
std::vector<std::vector<double>> curveValues(const InvertOutcome& outcome);

// The curves as rig-invert writes them: graph-eval's JSON layout, or CSV.
std::string curvesJson(const InvertOutcome& outcome);
// The JSON curves in two steps, for rig-batch, which joins its shards' frames: the frames (values per frame
// in internal units, each frame's number in the clip) joined by ",\n", then the file around them.
std::string curvesJsonFrames(const Approximation& approximation, std::span<const double> frameNumbers,
                             const std::vector<std::vector<double>>& values);
std::string curvesJsonFile(std::string_view frames);
std::string curvesCsv(const InvertOutcome& outcome);

// The outputs the approximation does not model (non-compositional), in its order.
std::vector<std::string> unmodelledOutputs(const Approximation& approximation);

// A summary's frames per status ({"reached": N, "best_fit": N, ...}), and its residual joints
// ({joint: {frames, worst_position_error_cm, worst_rotation_error_deg}}), as the reports of rig-invert and rig-batch
// give them.
Json statusCountsJson(const ClipInversionSummary& summary);
Json residualJointsJson(const ClipInversionSummary& summary);
// The words of the summary's status counts, for a text report: "1 reached, 239 best fit" (zero counts left out).
std::string statusCountsText(const ClipInversionSummary& summary);
// What a model mismatch's fix names (rig-learn --range and --ranges-from): the rig file, the clip, its map, take and
// frames as the run was given them; "" where there is none (an empty rig or clip is said as RIG or CLIP).
struct MismatchFix {
    std::string rig, clip, map, take, frames;
};
// What a run that measured a failed frame says before exiting with code 3 (after "error: "): the count, the
// first one (`frameNumber`: its number in the clip), its status and joint, and what it means: for a model mismatch
// where a parameter left its learned range, which, and the rig-learn flags that learn the range the clip uses.
std::string failedFramesLine(const ClipInversionSummary& summary, double frameNumber, const MismatchFix& fix);
// A first failure's parameter outside its learned range in the reports (rig-invert's, rig-batch's, Python's): its
// name, unit ("deg", or "rig": the rig file's), learned, reached and suggested ranges (rig-learn --range); null for
// none.
Json rangeLeftJson(const RangeLeft& range);

// The --report-json report. `clip` names the targets (none for targets given in memory), `curvesFile` the
// curves written (none when nothing was), `curvesFingerprint` the FNV-1a 64 of the curves' JSON text.
Json invertReport(const InvertOutcome& outcome, const std::optional<std::string>& approximation, const std::string& rig,
                  const std::optional<std::string>& clip, const std::optional<std::string>& curvesFile,
                  const std::string& curvesFingerprint);

// 16 hex digits, as the report writes a fingerprint.
std::string fingerprintText(const std::string& text);

}  // namespace rig::app
