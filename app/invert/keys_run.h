#pragma once
// rig-invert's keys and Maya .anim output (docs/keys-anim-report.md): the dense curves of an inversion made
// sparse on its real rig (--key-tolerance, adapter/key_reduction.h), the same clip keyed at a uniform
// step for comparison, and the curves as keyed JSON, keyed CSV or a .anim file.

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "adapter/key_reduction.h"
#include "app/common/value_output.h"
#include "app/invert/invert_run.h"
#include "nodes/curves/anim_file.h"

namespace rig::app {

struct KeySettings {
    double toleranceCm = KeyReductionOptions{}.toleranceCm;
    double toleranceDeg = KeyReductionOptions{}.toleranceDeg;
    std::string tangent = "auto";  // Maya's name of the keys' tangent type
};

// The tangent type of --key-tangent; rig::Error naming the flag.
TangentType keyTangent(const std::string& name);
// Checks the tolerances and the tangent (rig::Error naming the flag).
void checkKeySettings(const KeySettings& settings);

struct KeysOutcome {
    KeySettings settings;
    KeyedCurves keyed;
    UniformKeys uniform;
    std::size_t denseKeys = 0;  // one per frame and control: what the curves had

    double reduction() const;  // the fraction of the dense keys left out
};

// Keys the outcome's dense curves on its real rig, then finds the uniform step at the same tolerance.
// `progress(fraction)` may be empty.
KeysOutcome keyCurves(const InvertOutcome& outcome, const KeySettings& settings,
                      const std::function<void(double)>& progress);

// The keyed curves, values in user units: JSON {"tangent", "frames": [first, last], "curves": {plug: [[frame,
// value, in, out], ...]}}, or CSV with one row per key (plug,frame,value,in_tangent,out_tangent).
std::string keyedCurvesJson(const InvertOutcome& outcome, const KeysOutcome& keys);
std::string keyedCurvesCsv(const InvertOutcome& outcome, const KeysOutcome& keys);

// The curve of a plug of `graph` as Maya names the plug (node, attribute, angular, linear or unitless), without keys.
AnimFileCurve plugCurve(const Graph& graph, const std::string& plug);
// Per parameter, its curve as Maya names the plug (node, attribute, angular, linear or unitless) with its keys in user
// units (cm, degrees): the keys when given, else a key at every frame with `tangent`.
std::vector<AnimFileCurve> outputCurves(const InvertOutcome& outcome, const KeysOutcome* keys, TangentType tangent);

// The curves as a Maya .anim file: the keys when given, else a key at every frame with `tangent`.
std::string curvesAnim(const InvertOutcome& outcome, const KeysOutcome* keys, TangentType tangent);

// The "keys" object of the --report-json report.
Json keysReport(const InvertOutcome& outcome, const KeysOutcome& keys);

// The report's lines on standard output.
std::string keysText(const InvertOutcome& outcome, const KeysOutcome& keys);

}  // namespace rig::app
