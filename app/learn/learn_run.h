#pragma once
// rig-learn's work from a rig file and globs to an approximation and its JSON report, shared by the
// command line (tools/rig_learn.cpp) and the Python module (python/riginv.cpp), so that both learn the
// same approximation and give the same report and one-line errors (docs/rig-learn.md, docs/python.md).

#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "adapter/graph_rig_function.h"
#include "app/common/value_output.h"
#include "inversion/learn/learner.h"

namespace rig::app {

// --epsilon's text as a number: positive and finite, else rig::Error saying so.
double parseEpsilon(const std::string& text);

// "structured" or "talk", else rig::Error (the command line's CLI11 check says the same).
Orderer ordererFromName(const std::string& name);

// --set PLUG=VALUE: a plug held at a finite number (the rig file's units) while learning, else rig::Error
// saying what the flag expects.
HeldPlug parseHeldPlug(const std::string& assignment);

// --range PLUG=MIN:MAX: a learning range as a spec's `ranges:` entry gives one (the rig file's units, finite, min <
// max; PLUG a glob), else rig::Error saying what the flag expects.
GraphRigOptions::LearnRange parseLearnRange(const std::string& assignment);

// Every range of `ranges` must match a parameter of the rig that declares no limits (a range applies to no other);
// else rig::Error naming it, `where` (e.g. "--range") and what to give instead.
void checkLearnRanges(const GraphRigFunction& rig, const std::vector<GraphRigOptions::LearnRange>& ranges,
                      const std::string& where);

// Overall fraction done from the learner's stage and the fraction of that stage (the first samples and
// the classification are most of the work; ordering and validation share the rest).
double learningFraction(std::string_view stage, double fraction);

struct LearnJob {
    std::string rig;
    std::vector<std::string> params;   // parameter plug globs
    std::vector<std::string> outputs;  // output joint globs; empty: every joint
    std::vector<std::string> plugins;
    LearnOptions options;
    // Called once the rig is loaded, before the work (rig-learn checks its outputs against the rig's files).
    std::function<void(const GraphRigFunction& rig)> rigLoaded;
    std::vector<HeldPlug>
        held{};  // plugs held at a value, not inverted (rig-learn --set); recorded in the approximation
    std::vector<GraphRigOptions::LearnRange> ranges{};  // the spec's `ranges:` (GraphRigOptions::ranges)
    std::vector<std::string> helpers{};                 // helper frame globs (--helpers, the spec's `helpers:`)
    bool autoHelpers = false;                           // --auto-helpers, the spec's `helpers: auto`
    bool noHelpers = false;  // --no-helpers, the spec's `helpers: none`: no helper frame, no constraint operator
};

// Whether the rig's helper frames are found by discoverHelpers (graph_rig_function.h): when asked for, and by
// default, when no helper is named (the learner keeps only the helpers a constraint reads, so a rig without
// constraints learns as it would without helpers). The one place this default is decided.
bool discoversHelpers(const LearnJob& job);

// The rig's options for a job: its globs, plugins, held plugs, ranges and helpers; "auto" among the parameter or
// output globs (rig-learn --params auto, a spec's `params: auto`) is GraphRigOptions::autoParameters or autoOutputs,
// and a Maya scene's outputs are auto unless globs name them; a Maya scene's time curves are cut from the
// parameters they key (GraphRigOptions::cutTimeCurves). The one place these defaults are decided.
GraphRigOptions rigOptions(const LearnJob& job);

// What auto chose as a spec the user edits and learns with (rig-learn --write-spec, docs/rig-learn.md): the rig's
// parameters, joint outputs and held plugs by name, with comment lines saying what auto found and passed by.
std::string autoSpecText(const GraphRigFunction& rig, const std::string& rigFile);

// A learning range rig-learn --ranges-from widened to cover a clip (learn_ranges.h), in the rig file's units
// (degrees for angles): the range learned first, the values the clip reached on it, the range learned then.
struct WidenedRange {
    std::string parameter;
    bool angular = false;
    double learnedMin = 0.0, learnedMax = 0.0;
    double low = 0.0, high = 0.0;
    double min = 0.0, max = 0.0;
};

// What --ranges-from did: the clip (and its frames, "" for all), its frames' statuses on the first approximation
// (statusCountsText) and the ranges widened, in the approximation's parameter order.
struct ClipRanges {
    std::string clip;
    std::string frames;
    std::string firstStatuses;
    std::vector<WidenedRange> widened;
};

struct LearnOutcome {
    Approximation approximation;
    std::size_t rigParameters = 0;     // what the globs gave
    std::size_t rigOutputs = 0;        // joints and helpers
    std::vector<std::string> helpers;  // the rig's helper outputs, in order (named or found)
    double loadSeconds = 0.0;          // loading the rig
    // The non-compositional outputs with why (what the learner measured; the approximation file does not hold it).
    std::vector<UnmodelledOutput> unmodelled;
    AutoChoice autoChoice{};                 // what auto chose, and the time curves cut
    std::optional<ClipRanges> clipRanges{};  // with --ranges-from
    double absoluteTolerance = 0.0;  // cm: what sampled curves were refined to (LearnOptions::absoluteTolerance)
};

// A parameter's form as the approximation holds it, from its operators (the learner's classification, `form`,
// may name operators of outputs later found non-compositional): "rotation", "rotation (curve)", "sampledRigid"
// for one operator shared by its outputs, "per output: 2 rotation 1 sampledRigid" for one per output, "blend weight"
// for a switch's weight (its blends' parameter), "none (real rig only)" for others without operators.
std::string storedForm(const ModelledParameter& m);

// Loads the rig and learns. Throws rig::Error with rig-learn's one-line messages (RigSelectionError for
// a glob the rig cannot provide).
LearnOutcome learn(const LearnJob& job);

// The outputs the validation measured: the modelled ones (non-compositional outputs are not predicted; a blend's
// branch copies are measured through their blends), none when it did not run (no poses, or nothing modelled).
int validatedOutputs(const Approximation& approximation);

// The --report-json report. `approximation` is the file written, or to be written (none: none named);
// `written` whether it was.
Json learnReport(const LearnOutcome& outcome, const std::string& rig, const std::optional<std::string>& approximation,
                 bool written);

// Why an approximation must not be written as if it were fine (over epsilon, or non-finite validation
// poses), as one line without the file name; "" when it is within epsilon.
std::string validationFailure(const Approximation& approximation);

}  // namespace rig::app
