#pragma once
// rig-invert's, rig-batch's and Python's --contacts (contacts=): the contacts of a clip, detected (`auto`) or read
// from a file of frame ranges per joint, and their slides as the reports give them (docs/retargeting.md, Contacts).

#include <span>
#include <string>
#include <vector>

#include "app/common/value_output.h"
#include "inversion/clip/clip_inversion.h"
#include "nodes/clips/target_clip.h"

namespace rig::app {

// `spec` "auto": detectContacts on contactJoints with the documented thresholds; otherwise a contacts file (YAML or
// JSON): a map from joints (the approximation's outputs, as the clip's joints are after the map) to lists of frame
// ranges [first, last], inclusive, in the clip's numbering ("LeftFoot: [[1, 40], [81, 120]]"). Throws rig::Error
// with file:line:col for a bad file, `flag` naming the setting ("--contacts", "contacts").
std::vector<Contact> readContacts(const std::string& spec, const std::string& flag, const Approximation& approximation,
                                  const TargetClip& clip, const ClipTargets& targets);

// The report's object: {count, max_slide_cm, mean_slide_cm, per_contact: [{joint, first_frame, last_frame, slide_cm}]}
// (frames in the clip's numbering, `frameNumbers` indexed by clip index); null when no contacts were asked for.
Json contactsJson(const ClipInversionSummary& summary, const Approximation& approximation,
                  std::span<const double> frameNumbers, bool asked);

}  // namespace rig::app
