#pragma once
// rig-invert and a Maya scene (docs/rig-invert.md): the recovered controls against a Maya scene clip's own curves
// (the report's "scene curves"), and the curves written back as a Maya ASCII scene (-o OUT.ma) that references the
// rig's scene and drives its controls with animCurve nodes, so that an animator opens it in Maya and keeps working.

#include <optional>
#include <string>
#include <vector>

#include "app/common/value_output.h"
#include "app/invert/invert_run.h"
#include "app/invert/keys_run.h"

namespace rig::app {

// One control that a time curve of the clip's scene drives: the worst difference over the reported frames between
// the recovered value and the curve's, in user units (degrees, cm).
struct SceneCurveDifference {
    std::string control;  // the approximation's parameter
    std::string unit;     // "deg", "cm" or "" (unitless)
    double worst = 0.0;
    double frame = 0.0;  // where it is worst
};

// The approximation's parameters that a time curve of the clip's scene drives (named with or without the scene's
// namespaces), the worst first; empty for a clip that is not a Maya scene.
std::vector<SceneCurveDifference> sceneCurveDifferences(const InvertOutcome& outcome);
// The report's lines: one per control (none when the list is empty).
std::string sceneCurvesText(const std::vector<SceneCurveDifference>& differences);
// {control: {"worst_difference": D, "unit": U, "frame": F}}.
Json sceneCurvesJson(const std::vector<SceneCurveDifference>& differences);

// Checks, before the work, that curves can be written as a Maya scene for `rig`: it must be a Maya scene, which OUT.ma
// references. rig::Error naming -o.
void checkMayaSceneOutput(const std::string& rig, const std::string& output);

// The curves as a Maya ASCII scene written to `output` (docs/rig-invert.md): `requires maya`, the rig scene's
// currentUnit (the clip's frame rate), a reference to `rig` (relative to the output's folder when given relative)
// under the namespace the clip's scene gave it (else the rig file's name), one animCurveTA/TL/TU node per control with
// the keys (or a key at every frame with `tangent`), connected to the control through the reference node's
// placeholders; the reference edits disconnect the rig's own time curves from those controls and set the plugs the
// approximation was learned holding. Its playback range is the reported frames.
std::string curvesMayaScene(const InvertOutcome& outcome, const KeysOutcome* keys, TangentType tangent,
                            const std::string& rig, const std::string& output);

}  // namespace rig::app
