#pragma once
// rig-learn --ranges-from (docs/rig-learn.md, Ranges): learning ranges that cover a clip's motion, taken from the
// clip inverted on a first approximation, shared by the command line and the Python module (learn(ranges_from=)).

#include <optional>
#include <string>

#include "app/learn/learn_run.h"

namespace rig::app {

// The clip whose motion the learning ranges must cover, read as rig-invert reads its --clip, --map, --take and
// --frames.
struct RangesFrom {
    std::string clip;
    std::string map;   // "" for none
    std::string take;  // "" for the first
    std::optional<std::string> frames;
};

// Learns `job` (the first approximation, over the ranges it gives), inverts the clip on it as rig-invert does
// (app::invert, default solve settings), widens the learning range of each parameter without declared limits that
// the clip takes past it (widenedRange: its values and a margin of rangeMargin of its width, never narrower), and
// learns again with those ranges ahead of the job's. The outcome's clipRanges says what was widened; where nothing
// was, the first approximation is the answer, learned once. Throws rig::Error with rig-learn's and rig-invert's
// one-line messages.
LearnOutcome learnCoveringClip(const LearnJob& job, const RangesFrom& from);

}  // namespace rig::app
