#pragma once
// A rig's inversion choices in one file (docs/rig-learn.md, rigs/biped_inversion.yaml): `params:` and
// optionally `outputs:` and `helpers:` (helper frames), lists of globs (`helpers: auto`: found by rig-learn), `set:`, a
// map of plugs held at a value while learning, and `ranges:`, a map of parameter globs to the range each is learned
// over, which rig-learn --spec adds to the command line's and rig-bench learns the biped with.

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "adapter/graph_rig_function.h"
#include "inversion/model/approximation.h"

namespace rig {

struct InversionSpec {
    std::vector<std::string> params;   // parameter plug globs
    std::vector<std::string> outputs;  // output joint globs
    bool autoParams = false;           // `params: auto` (or 'auto' in the list): GraphRigOptions::autoParameters
    bool autoOutputs = false;          // `outputs: auto` (or 'auto' in the list): GraphRigOptions::autoOutputs
    std::vector<std::string> helpers;  // helper frame globs (GraphRigOptions::helperGlobs)
    bool autoHelpers = false;          // `helpers: auto` (GraphRigOptions::autoHelpers)
    bool noHelpers = false;            // `helpers: none`: no helper frame (rig-learn --no-helpers)
    std::vector<HeldPlug> set;         // held plugs, in the file's order, values in the rig file's units
    // `ranges:`, a map of parameter glob -> [min, max] (the rig file's units): where a control without declared
    // limits is learned (GraphRigOptions::ranges), in the file's order.
    std::vector<GraphRigOptions::LearnRange> ranges;
    std::map<std::string, std::string> places;     // glob -> its file:line:col, for messages about it
    std::map<std::string, std::string> setPlaces;  // held plug -> its file:line:col
};

// Throws rig::Error, one line naming the file (and line and column) and what to change.
InversionSpec readInversionSpec(const std::filesystem::path& file);

// The spec as a file readInversionSpec reads back the same: `header` as comment lines, then params, outputs,
// helpers, set (values as they round-trip) and ranges, each name quoted, one a line.
std::string inversionSpecYaml(const InversionSpec& spec, const std::vector<std::string>& header = {});

}  // namespace rig
