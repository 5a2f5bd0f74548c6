#pragma once
// rig-invert's work from its inputs to its curves and report, shared by the command line
// (tools/rig_invert.cpp) and the Python module (python/riginv.cpp), so that both give the same values,
// the same report and the same one-line errors (docs/rig-invert.md, docs/python.md).

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "inversion/approximation.h"
#include "inversion/clip_inversion.h"
#include "nodes/clips/target_clip.h"
#include "nodes/graph_rig_function.h"
#include "tools/value_output.h"

namespace rig::cli {

// rig-invert's flags that shape the solve.
struct InvertSettings {
    int threads = 0;  // 0: all cores
    bool noPartition = false;
    bool blockByBlock = false;
    std::string jacobian = "analytic";  // or "fd"
    int polish = 0;
    int restartEvery = ClipInversionOptions{}.restartInterval;
    bool restStarts = false;
};

// The options for invertClip. Throws rig::Error naming the flag of a bad value.
ClipInversionOptions clipInversionOptions(const InvertSettings& settings);

struct InvertJob {
    // The approximation; null: read from `approximationName`, after the settings are checked.
    std::shared_ptr<const Approximation> approximation;
    std::string approximationName;  // its file, or what names it in messages
    std::string rig;
    std::vector<std::string> plugins;
    bool strict = false;  // refuse an approximation learned from another version of the rig
    // The targets: the clip file `clip`, or `targets` when set (joints and worlds as given, `file` naming
    // them in messages); either way renamed and scaled by the map file `map` ("" for none).
    std::string clip;
    std::optional<TargetClip> targets;
    std::string map;
    std::optional<std::string> frames;  // A:B in the clip's numbering; none: the whole clip
    std::string after;                  // the curves of the chunk before (rig-invert --after), "" for none
    InvertSettings settings;
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
    TargetClip clip;       // after the map
    ClipTargets targets;
    int first = 0;         // the first reported frame, an index into clip.frameNumbers
    ClipInversionSummary summary;
    std::vector<std::vector<double>> values;  // [reported frame][parameter], internal units
};

// Checks the settings, reads what the job names, binds the approximation to the rig and inverts the
// frames. Throws rig::Error with rig-invert's one-line messages.
InvertOutcome invert(const InvertJob& job);

// A parameter's curve values in user units (degrees for angles, cm), as the curves files hold them:
// [reported frame][parameter].
std::vector<std::vector<double>> curveValues(const InvertOutcome& outcome);

// The curves as rig-invert writes them: graph-eval's JSON layout, or CSV.
std::string curvesJson(const InvertOutcome& outcome);
std::string curvesCsv(const InvertOutcome& outcome);

// The --report-json report. `clip` names the targets (none for targets given in memory), `curvesFile` the
// curves written (none when nothing was), `curvesFingerprint` the FNV-1a 64 of the curves' JSON text.
Json invertReport(const InvertOutcome& outcome, const std::optional<std::string>& approximation,
                  const std::string& rig, const std::optional<std::string>& clip,
                  const std::optional<std::string>& curvesFile, const std::string& curvesFingerprint);

// 16 hex digits, as the report writes a fingerprint.
std::string fingerprintText(const std::string& text);

}  // namespace rig::cli
