// rig-learn: learns a rig's approximation (sections 3 and 4 of the talk) and writes it to a file,
// with a readable report on standard output and, optionally, a JSON one (docs/rig-learn.md).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>

#include <fmt/format.h>

#include "adapter/inversion_spec.h"
#include "app/common/output_file.h"
#include "app/common/progress_bar.h"
#include "app/learn/learn_ranges.h"
#include "app/learn/learn_run.h"
#include "core/error.h"
#include "core/table.h"
#include "inversion/model/approximation_io.h"
#include "inversion/model/learned_range.h"
#include "inversion/solve/pole_hold.h"
#include "tools/cli_common.h"

namespace rig {
namespace {

struct Options {
    std::string rig;
    std::vector<std::string> params;
    std::vector<std::string> outputs;
    std::vector<std::string> helpers;  // --helpers, then the spec's
    bool autoHelpers = false;          // --auto-helpers or the spec's `helpers: auto`
    bool noHelpers = false;            // --no-helpers or the spec's `helpers: none`
    std::string output;
    bool outputGiven = false;
    std::string writeSpec;  // --write-spec: the parameters, outputs and held plugs chosen, as a spec
    std::string epsilon;
    bool epsilonGiven = false;
    std::string orderer = "structured";
    std::string reportJson;
    bool reportGiven = false;
    std::vector<std::string> plugins;
    std::vector<std::string> sets;                    // --set PLUG=VALUE
    std::vector<HeldPlug> held;                       // --set's, then the spec's for other plugs
    std::vector<std::string> rangeFlags;              // --range PLUG=MIN:MAX
    std::vector<GraphRigOptions::LearnRange> ranges;  // --range's, then the spec's
    app::RangesFrom rangesFrom;                       // --ranges-from CLIP, --map, --take, --frames
    std::string rangesFromFrames;
    std::string spec;
    std::map<std::string, std::string> specPlaces;     // glob -> its file:line:col in the spec, for messages
    std::map<std::string, std::string> specSetPlaces;  // held plug of the spec -> its file:line:col
    bool allowInexact = false;
    bool worldSpace = false;
    bool noPerOutput = false;
    int threads = 0;
};

// A spec file adds its globs to the command line's, and its held plugs but those --set names: the command
// line's value wins, as a flag overrides a configuration file.
void readSpec(Options& options)
{
    InversionSpec spec = readInversionSpec(options.spec);
    options.params.insert(options.params.end(), spec.params.begin(), spec.params.end());
    options.outputs.insert(options.outputs.end(), spec.outputs.begin(), spec.outputs.end());
    // "auto" among the globs is what app::rigOptions reads as auto.
    if (spec.autoParams) options.params.push_back("auto");
    if (spec.autoOutputs) options.outputs.push_back("auto");
    options.helpers.insert(options.helpers.end(), spec.helpers.begin(), spec.helpers.end());
    options.autoHelpers = options.autoHelpers || spec.autoHelpers;
    options.noHelpers = options.noHelpers || spec.noHelpers;
    options.specPlaces.merge(spec.places);
    options.ranges.insert(options.ranges.end(), spec.ranges.begin(), spec.ranges.end());
    for (const HeldPlug& h : spec.set) {
        const bool overridden = std::any_of(options.held.begin(), options.held.end(),
                                            [&](const HeldPlug& given) { return given.plug == h.plug; });
        if (overridden) continue;
        options.held.push_back(h);
        options.specSetPlaces[h.plug] = spec.setPlaces.at(h.plug);
    }
}

std::string valueText(const RigParameter& p, double internal)
{
    return fmt::format("{:.4g}{}", app::parameterUserValue(p, internal), p.angular ? " deg" : "");
}

std::string rangeText(const RigParameter& p)
{
    return fmt::format("{:g}..{:g}{}", app::parameterUserValue(p, p.min), app::parameterUserValue(p, p.max),
                       p.angular ? " deg" : "");
}

std::string vectorText(const Eigen::Vector3d& v)
{
    // Rounding noise (1e-16 cm) and -0 print as 0.
    auto clean = [](double x) { return std::abs(x) < 1e-9 ? 0.0 : x; };
    return fmt::format("({:.4g}, {:.4g}, {:.4g})", clean(v.x()), clean(v.y()), clean(v.z()));
}

// Per-output modelling: the non-compositional outputs with why, and per parameter that moves one, where it is
// modelled and where not.
std::string unmodelledText(const app::LearnOutcome& learned)
{
    const Approximation& a = learned.approximation;
    if (learned.unmodelled.empty()) return {};
    const auto names = [&](const std::vector<int>& outputs) {
        std::vector<std::string> list;
        for (const int k : outputs) list.push_back(a.outputs[static_cast<std::size_t>(k)].name);
        return fmt::format("{}", fmt::join(list, ", "));
    };
    std::string out = fmt::format(
        "\nNot modelled: {} outputs are non-compositional (no product of operators reproduces them; rig-invert "
        "--hybrid fits them on the real rig)\n",
        learned.unmodelled.size());
    for (const UnmodelledOutput& u : learned.unmodelled) out += fmt::format("  {}: {}\n", u.name, u.reason);
    out += "Where the parameters that move them are modelled:\n";
    for (const ModelledParameter& m : a.parameters) {
        if (m.unmodelledOutputs.empty()) continue;
        out += m.outputs.empty()
                   ? fmt::format("  {}: real rig only, on {}\n", m.parameter.name, names(m.unmodelledOutputs))
                   : fmt::format("  {}: modelled on {}; not on {}\n", m.parameter.name, names(m.outputs),
                                 names(m.unmodelledOutputs));
    }
    return out;
}

// The rig's helper frames the approximation left out: the learner keeps only those a constraint operator reads.
std::vector<std::string> helpersNotKept(const app::LearnOutcome& learned)
{
    std::vector<std::string> names;
    for (const std::string& helper : learned.helpers)
        if (std::none_of(learned.approximation.outputs.begin(), learned.approximation.outputs.end(),
                         [&](const ApproximationOutput& o) { return o.name == helper; }))
            names.push_back(helper);
    return names;
}

// The validation's figures, and how many of the rig's outputs (the first line's count) they cover: the
// non-compositional ones are not predicted, the dropped ones not learned, the helpers no constraint reads not kept.
std::string validationText(const app::LearnOutcome& learned)
{
    const Approximation& a = learned.approximation;
    const ValidationSummary& v = a.validation;
    std::string out = fmt::format(
        "Validation on {} random poses within the limits of the modelled parameters, real rig against "
        "approximation:\n",
        v.poses);
    if (v.poses == 0 || a.parameters.empty()) return out + "  not run (no poses or nothing modelled)\n";
    const int validated = app::validatedOutputs(a);
    // A blend's branch copies are no rig output: measured through their blends.
    const auto copies = static_cast<std::size_t>(std::count_if(
        a.outputs.begin(), a.outputs.end(), [](const auto& o) { return o.helper && rigOutputName(o.name) != o.name; }));
    const auto unmodelled = a.outputs.size() - copies - static_cast<std::size_t>(validated);
    const std::size_t notKept = helpersNotKept(learned).size();
    out += fmt::format("  validated {} of {} outputs", validated,
                       a.outputs.size() - copies + a.droppedOutputs.size() + notKept);
    if (copies > 0) out += fmt::format(" (and {} branch copies of blends, through their blends)", copies);
    if (unmodelled > 0) out += fmt::format("; {} not modelled (listed above)", unmodelled);
    if (!a.droppedOutputs.empty()) out += fmt::format("; {} left out (listed above)", a.droppedOutputs.size());
    if (notKept > 0)
        out += fmt::format("; {} helper frame{} not kept (no constraint operator reads {})", notKept,
                           notKept == 1 ? "" : "s", notKept == 1 ? "it" : "them");
    out += "\n";
    // Epsilon bounds the error per unit moved, not the error of a pose that moves many parameters far: said on the
    // line whose figure may be above epsilon, so that the two read together.
    out += fmt::format(
        "  position error: worst {:.3g} cm ({}, pose {}), mean {:.3g} cm (whole poses; epsilon is per unit moved; "
        "sampled curves refined to {:g} cm)\n",
        v.maxPositionErrorCm, v.worstOutput, v.worstPose, v.meanPositionErrorCm, learned.absoluteTolerance);
    out += fmt::format("  rotation error: worst {:.3g} deg, mean {:.3g} deg\n", v.maxRotationErrorDeg,
                       v.meanRotationErrorDeg);
    out += fmt::format("  per unit of the parameters moved: worst {:.3g} cm ({}), epsilon {:g} cm: {}\n",
                       v.maxRelativeError, v.worstRelativeOutput.empty() ? "-" : v.worstRelativeOutput, a.epsilon,
                       v.withinEpsilon ? "within" : "EXCEEDED");
    if (v.nonFinitePoses > 0)
        out += fmt::format("  {} poses not measured: the rig gave a non-finite matrix there\n", v.nonFinitePoses);
    if (v.singularPoses > 0)
        out += fmt::format(
            "  {} output poses not measured ({} first): a twist share's driver at gimbal lock, or its "
            "swing or twist a half turn, where a rig's twist is decided by rounding (limit poses hit them)\n",
            v.singularPoses, v.singularOutput);
    return out;
}

// The outputs learned with a constraint operator, each with what its base reads (docs/rig-learn.md).
std::string constraintsText(const Approximation& a)
{
    if (a.constraints.empty()) return {};
    const auto name = [&](int k) { return a.outputs[static_cast<std::size_t>(k)].name; };
    std::string out = fmt::format("\nConstraint operators: {} outputs\n", a.constraints.size());
    for (const ApproximationOutput& o : a.outputs) {
        if (o.constraint < 0) continue;
        const ConstraintBase& c = a.constraints[static_cast<std::size_t>(o.constraint)];
        if (c.kind == ConstraintKind::blend) {
            const std::string rule = c.blend.mode == BlendMode::eulerChannels
                                         ? fmt::format("Euler channels in {}", rotateOrderName(c.blend.order))
                                         : std::string("slerp");
            out += fmt::format("  {}: blend of {} and {} relative to {} by {} ({}, translation and stretch linear)\n",
                               o.name, name(c.ik), name(c.fk), c.anchor < 0 ? "the world" : name(c.anchor),
                               a.parameters[static_cast<std::size_t>(c.weight)].parameter.name, rule);
            continue;
        }
        if (c.kind == ConstraintKind::twistShare) {
            const std::string reading = c.readOrder == c.twistOrder
                                            ? std::string("swing-twist")
                                            : fmt::format("its angles in {} read in {}", rotateOrderName(c.readOrder),
                                                          rotateOrderName(c.twistOrder));
            out += fmt::format("  {}: {}, turns with {}, {:.6g} of {}'s twist about {} relative to {} ({})\n", o.name,
                               constraintKindName(c.kind), c.anchor < 0 ? "the world" : name(c.anchor), c.share,
                               name(c.driver), "xyz"[c.twistAxis],
                               c.driverParent < 0 ? "the world" : name(c.driverParent), reading);
            continue;
        }
        if (c.kind == ConstraintKind::oriented) {
            out += fmt::format("  {}: {}, carried by {}, turning as {}\n", o.name, constraintKindName(c.kind),
                               c.anchor < 0 ? "the world" : name(c.anchor), name(c.orient));
            continue;
        }
        const auto& knots = c.shape.rigid.knots();
        out += fmt::format(
            "  {}: {}, root carried by {}, goal {}, pole {}{}; shape {} knots over reaches {:.4g}..{:.4g} cm\n", o.name,
            constraintKindName(c.kind), c.anchor < 0 ? "the world" : name(c.anchor), name(c.goal),
            c.goalTurns     ? "none (its rest plane turned by the goal's rotation, then minimally onto its line: an "
                              "ikSCsolver turning toward its handle)"
            : c.minimalTurn ? "none (its rest plane turned minimally onto the goal: an ikSCsolver)"
            : c.restPlane   ? "none (its rest plane)"
            : c.worldUp     ? "a world axis from the root (a world up)"
            : c.pole < 0    ? "fixed to the anchor"
            : c.poleTurns   ? "turned by " + name(c.pole) + " (a direction in its axes)"
                            : name(c.pole),
            c.orient < 0 ? "" : ", turning as " + name(c.orient), knots.size(), c.restReach + knots.front(),
            c.restReach + knots.back());
    }
    // What the joints cannot decide of a chain: its pole's distance and place along the chain (pole_hold.h).
    for (const PoleHold& hold : poleHolds(a)) {
        std::vector<std::string> controls;
        for (const int p : hold.parameters)
            controls.push_back(a.parameters[static_cast<std::size_t>(p)].parameter.name);
        out += fmt::format(
            "  held at rest where the joints cannot decide: {} (the pole's distance from the chain and "
            "its place along it; the plane it spans is solved)\n",
            fmt::join(controls, ", "));
    }
    // And of an aim: its target's distance along the line of sight.
    for (const AimHold& hold : aimHolds(a)) {
        std::vector<std::string> controls;
        for (const int p : hold.parameters)
            controls.push_back(a.parameters[static_cast<std::size_t>(p)].parameter.name);
        out += fmt::format(
            "  held at the solve's start where the joints cannot decide: {} (the aim target's distance along the "
            "line of sight; its direction is solved)\n",
            fmt::join(controls, ", "));
    }
    return out;
}

// What auto chose (--params auto, --outputs auto) and the time curves cut, under the report's first line.
std::string autoText(const AutoChoice& a)
{
    std::string out;
    if (!a.controls.empty()) {
        std::size_t moved = 0;
        for (const PassedChannel& p : a.passed) moved += p.why == "moves no output" ? 1 : 0;
        out += fmt::format(
            "Auto parameters: the channels of {} controls that move an output ({} channels passed by: locked, not "
            "keyable, driven by the rig, or moving no output ({}); --write-spec lists them)\n",
            a.controls.size(), a.passed.size(), moved);
    }
    if (a.skins > 0)
        out += fmt::format("Auto outputs: the joints {} skinCluster{} bind\n", a.skins, a.skins > 1 ? "s" : "");
    else if (a.skins == 0) out += "Auto outputs: every joint (no skinCluster binds one)\n";
    if (!a.cutCurves.empty())
        out += fmt::format("Time curves cut (the learner sets these channels; the curves are the clip): {}\n",
                           a.cutCurves.size());
    return out;
}

// --ranges-from: the clip's statuses on the first approximation, and each range widened to cover it.
std::string clipRangesText(const app::ClipRanges& c)
{
    std::string out = fmt::format("Ranges from {}{}: on a first approximation {}; ", c.clip,
                                  c.frames.empty() ? "" : " frames " + c.frames, c.firstStatuses);
    if (c.widened.empty()) return out + "every control stayed within its learning range (learned once)\n";
    out += fmt::format(
        "{} learning range{} widened to the values reached and {:g}% of the range's width, then learned again\n",
        c.widened.size(), c.widened.size() == 1 ? "" : "s", 100 * rangeMargin);
    // A solve's rounding noise about a value of 0 (1e-10 degrees) prints as 0.
    const auto shown = [](double x) { return std::abs(x) < 1e-6 ? 0.0 : x; };
    for (const app::WidenedRange& w : c.widened) {
        const char* unit = w.angular ? " deg" : "";
        out += fmt::format("  {}: {:g}..{:g}{} -> {:g}..{:g}{} (reached {:.4g}..{:.4g})\n", w.parameter, w.learnedMin,
                           w.learnedMax, unit, w.min, w.max, unit, shown(w.low), shown(w.high));
    }
    return out;
}

std::string readableReport(const app::LearnOutcome& learned, const Options& options)
{
    const Approximation& a = learned.approximation;
    // The outputs counted as the validation counts them, the helper frames among them said apart.
    const std::string helpers = learned.helpers.empty()
                                    ? ""
                                    : fmt::format(" ({} helper frame{} among them)", learned.helpers.size(),
                                                  learned.helpers.size() == 1 ? "" : "s");
    std::string out =
        fmt::format("rig-learn {}: {} parameters, {} outputs{}, epsilon {:g} cm per unit moved, orderer {}\n",
                    options.rig, learned.rigParameters, learned.rigOutputs, helpers, a.epsilon, a.training.orderer);
    out += autoText(learned.autoChoice);
    if (!a.held.empty()) out += fmt::format("Held (not inverted): {}\n", app::heldText(a.held));
    if (learned.clipRanges) out += clipRangesText(*learned.clipRanges);
    if (!learned.helpers.empty()) {
        const std::vector<std::string> notKept = helpersNotKept(learned);
        out += fmt::format("Helpers (kept where a constraint operator reads them; never targets): {}{}\n",
                           fmt::join(learned.helpers, ", "),
                           notKept.empty() ? "; all kept"
                           : notKept.size() == learned.helpers.size()
                               ? "; none kept"
                               : fmt::format("; not kept: {}", fmt::join(notKept, ", ")));
    }
    out += "\n";
    out += fmt::format("Modelled: {} parameters, in composition order (outermost first)\n", a.parameters.size());
    std::vector<std::vector<std::string>> rows{
        {"#", "parameter", "form", "axis", "pivot (cm)", "fit error", "samples", "outputs", "range"}};
    for (std::size_t p = 0; p < a.parameters.size(); ++p) {
        const ModelledParameter& m = a.parameters[p];
        const bool one = m.operators.size() == 1;
        const Operator* op = one ? &m.operators.front() : nullptr;
        const bool hasAxis = op && op->traits().hasAxis;
        const bool hasPivot = op && op->traits().hasPivot;
        const std::string outputs = m.unmodelledOutputs.empty()
                                        ? fmt::format("{}", m.outputs.size())
                                        : fmt::format("{} (+{} not)", m.outputs.size(), m.unmodelledOutputs.size());
        rows.push_back({fmt::format("{}", p + 1), m.parameter.name, app::storedForm(m),
                        hasAxis ? vectorText(op->axis) : "-", hasPivot ? vectorText(op->pivot) : "-",
                        fmt::format("{:.2g}", m.fitError), fmt::format("{}", m.samples), outputs,
                        rangeText(m.parameter)});
    }
    out += alignTable(rows, {"  ",
                             {Align::right, Align::left, Align::left, Align::left, Align::left, Align::left,
                              Align::left, Align::left, Align::left}});
    const auto redundant = redundantParameters(a);
    if (!redundant.empty())
        out +=
            fmt::format("\nRedundant: {} pairs with the same effect (an inversion must split it)\n", redundant.size());
    for (const auto& [i, j] : redundant)
        out += fmt::format("  {} and {}\n", a.parameters[static_cast<std::size_t>(i)].parameter.name,
                           a.parameters[static_cast<std::size_t>(j)].parameter.name);
    std::string saturated;
    for (const ModelledParameter& m : a.parameters)
        for (const auto& [from, to] : m.noEffect)
            saturated += fmt::format("  {}: no effect from {} to {}\n", m.parameter.name, valueText(m.parameter, from),
                                     valueText(m.parameter, to));
    if (!saturated.empty())
        out += "\nSaturated: ranges where a control moves nothing (an inversion cannot tell values there apart)\n" +
               saturated;
    out += unmodelledText(learned);
    out += fmt::format("\nDiscarded: {} parameters\n", a.discarded.size());
    for (const auto& d : a.discarded) out += fmt::format("  {}: {}\n", d.parameter.name, d.reason);
    std::vector<std::string> world;
    int relative = 0;
    for (const ApproximationOutput& o : a.outputs) {
        if (o.parent >= 0) ++relative;
        else if (o.constraint < 0) world.push_back(o.name);
    }
    out += constraintsText(a);
    out += fmt::format(
        "\nFrames: {} outputs learned relative to their parent output, {} with a constraint operator, "
        "{} in world space{}{}\n",
        relative, a.constraints.size(), world.size(), world.empty() ? "" : ": ", fmt::join(world, ", "));
    for (const DroppedOutput& d : a.droppedOutputs) out += fmt::format("  left out: {}: {}\n", d.name, d.reason);
    out += fmt::format(
        "\nTraining: {} rig evaluations ({} for the composition order), {:.2f} s learning, {:.2f} s loading "
        "the rig\n",
        a.training.evaluations, a.training.orderEvaluations, a.training.seconds, learned.loadSeconds);
    out += validationText(learned);
    if (a.validation.withinEpsilon || options.allowInexact) out += fmt::format("\nWrote {}\n", options.output);
    else out += fmt::format("\nNot written: {} (over epsilon; --allow-inexact writes it anyway)\n", options.output);
    return out;
}

// --write-spec alone: the rig loaded with what auto chose, written as a spec, nothing learned.
int writeSpecOnly(const Options& options, const app::LearnJob& job)
{
    const GraphRigFunction rig(job.rig, app::rigOptions(job));
    std::vector<app::NamedFile> read;
    for (const auto& file : rig.files()) read.push_back({"a file the rig reads", file});
    app::checkDistinctFiles(read, {{"--write-spec", options.writeSpec}});
    app::writeFileAtomically(options.writeSpec, app::autoSpecText(rig, options.rig));
    const std::vector<char> helper = rig.helperOutputs();
    std::cout << fmt::format("rig-learn {}: {} parameters, {} output joints, {} held plugs\n", options.rig,
                             rig.parameters().size(), std::count(helper.begin(), helper.end(), 0), rig.held().size())
              << autoText(rig.autoChoice()) << fmt::format("Wrote {}\n", options.writeSpec);
    return 0;
}

int run(Options& options)
{
    if (!options.outputGiven && options.writeSpec.empty())
        throw Error("--output is required; run 'rig-learn --help' for usage");
    if (options.rig.empty())
        throw Error("no rig file given; usage: rig-learn RIG.yaml --params GLOB... -o APPROX.yaml");
    for (const std::string& assignment : options.sets) options.held.push_back(app::parseHeldPlug(assignment));
    for (const std::string& assignment : options.rangeFlags) options.ranges.push_back(app::parseLearnRange(assignment));
    if (!options.spec.empty()) readSpec(options);
    if (options.params.empty()) throw Error("--params is required; run 'rig-learn --help' for usage");
    // Bad outputs and flags are reported before any work.
    app::OutputFiles files;
    if (options.outputGiven) files.add(options.output, "approximation.yaml");
    if (options.reportGiven) files.add(options.reportJson, "report.json", "--report-json");
    if (!options.writeSpec.empty()) app::checkOutputFile(options.writeSpec, "spec.yaml", "--write-spec");
    const std::vector<app::NamedFile> outputs{{"-o", options.output},
                                              {"--report-json", options.reportGiven ? options.reportJson : ""},
                                              {"--write-spec", options.writeSpec}};
    app::checkDistinctFiles({{"the rig file", options.rig},
                             {"the spec", options.spec},
                             {"the clip", options.rangesFrom.clip},
                             {"the map", options.rangesFrom.map}},
                            outputs);
    app::LearnJob job{options.rig, options.params, options.outputs, options.plugins, {}, {}};
    job.held = options.held;
    job.ranges = options.ranges;
    job.helpers = options.helpers;
    job.autoHelpers = options.autoHelpers;
    job.noHelpers = options.noHelpers;
    if (options.epsilonGiven) job.options.epsilon = app::parseEpsilon(options.epsilon);
    job.options.orderer = app::ordererFromName(options.orderer);
    job.options.relativeFrames = !options.worldSpace;
    job.options.perOutput = !options.noPerOutput;
    job.options.threads = options.threads;
    if (!options.outputGiven) return writeSpecOnly(options, job);
    const std::vector<GraphRigOptions::LearnRange> flagRanges(
        options.ranges.begin(), options.ranges.begin() + static_cast<std::ptrdiff_t>(options.rangeFlags.size()));
    job.rigLoaded = [&](const GraphRigFunction& rig) {
        app::checkLearnRanges(rig, flagRanges, "--range");
        std::vector<app::NamedFile> read;
        for (const auto& file : rig.files()) read.push_back({"a file the rig reads", file});
        app::checkDistinctFiles(read, outputs);
        if (!options.writeSpec.empty())
            app::writeFileAtomically(options.writeSpec, app::autoSpecText(rig, options.rig));
    };
    app::ProgressBar bar("learning");
    job.options.progress = [&](std::string_view stage, double fraction) {
        bar.update(app::learningFraction(stage, fraction), std::string(stage));
    };
    std::optional<app::LearnOutcome> learned;
    try {
        learned.emplace(options.rangesFrom.clip.empty() ? app::learn(job)
                                                        : app::learnCoveringClip(job, options.rangesFrom));
    }
    catch (const RigSelectionError& e) {
        // A glob or a held plug of the spec: say where it is written.
        const auto& places = e.kind() == "held plug" ? options.specSetPlaces : options.specPlaces;
        const auto place = places.find(e.name());
        if (place == places.end()) throw;
        throw Error(fmt::format("{}: {} '{}' of the spec does not fit {} ({}); fix or remove it", place->second,
                                e.kind(), e.name(), options.rig, e.reason()));
    }
    bar.finish();
    const Approximation& approximation = learned->approximation;

    // What the learner measured as wrong is not written as if it were fine (docs/rig-learn.md: exit 3).
    const std::string failure = app::validationFailure(approximation);
    const bool write = failure.empty() || options.allowInexact;
    if (write) files.set(options.output, approximationToYaml(approximation));
    if (options.reportGiven)
        files.set(options.reportJson,
                  app::jsonText(app::learnReport(*learned, options.rig, options.output, write), 2) + "\n");
    files.commit();
    std::cout << readableReport(*learned, options);
    if (approximation.parameters.empty())
        std::cerr << "warning: no parameter could be modelled; the approximation is empty (see the discards above)\n";
    if (failure.empty()) return 0;
    if (options.allowInexact) {
        std::cerr << oneLine(fmt::format("warning: {}; written anyway (--allow-inexact)", failure)) << '\n';
        return 0;
    }
    std::cerr << oneLine(fmt::format("error: {}; {} not written (--allow-inexact writes it anyway)", failure,
                                     options.output))
              << '\n';
    return 3;
}

}  // namespace
}  // namespace rig

int main(int argc, char** argv)
{
    rig::Options options;
    CLI::App app{
        "rig-learn: learn a rig's approximation (operators and composition order) for inversion.\n\n"
        "Example:\n"
        "  rig-learn rigs/examples/arm.yaml --params 'shoulder.rotate?' 'wrist.rotate?' -o arm_approx.yaml\n\n"
        "Parameters are free keyable plugs named by globs; outputs are joints (default: all). Angles are\n"
        "degrees in the report, radians in the file. See docs/rig-learn.md.",
        "rig-learn"};
    app.add_option("rig", options.rig, "Rig file: a YAML rig or a Maya ASCII scene");
    app.add_option(
        "--params", options.params,
        "Parameter plug globs, e.g. 'L_arm_*.rotate?' 'hips.translate?' (one or more; repeatable); 'auto' in "
        "a Maya scene: the keyable, unlocked channels of its controls that move an output");
    app.add_option("--spec", options.spec,
                   "YAML file with 'params:', 'outputs:' and 'helpers:' lists of globs (or 'helpers: auto'), added to "
                   "--params, --outputs and --helpers, a 'set:' map of held plugs, added to --set, and a 'ranges:' "
                   "map of parameter globs to [MIN, MAX] learning ranges, after --range's");
    app.add_option("--outputs", options.outputs,
                   "Output joint-name globs (default: every joint of a YAML rig; 'auto', a Maya scene's default: the "
                   "joints its skinClusters bind, or every joint where none binds one)");
    app.add_option("--helpers", options.helpers,
                   "Helper frames: transforms or joints that are not outputs (IK goals, pole objects, aim targets), "
                   "learned but never targets, by name globs (repeatable; without --helpers or --auto-helpers "
                   "they are found as --auto-helpers does)");
    app.add_flag("--auto-helpers", options.autoHelpers,
                 "Also find the helper frames: transforms or joints whose world matrix feeds the outputs and that "
                 "a parameter moves");
    app.add_flag("--no-helpers", options.noHelpers,
                 "No helper frame, so no IK chain or aim (twist shares read joints only): what does not compose "
                 "stays unmodelled, for rig-invert --hybrid")
        ->excludes("--auto-helpers");
    app.add_option(
           "--range", options.rangeFlags,
           "Learn a parameter without declared limits over MIN..MAX: PLUG=MIN:MAX, PLUG a glob, in the rig file's "
           "units (degrees for angles), e.g. L_knee_fk_ctrl.rotateX=-90:160 (repeatable; as a spec's 'ranges:', "
           "ahead of them)")
        ->allow_extra_args(false);
    auto* rangesFrom = app.add_option(
        "--ranges-from", options.rangesFrom.clip,
        "Learn over the ranges a clip's motion uses: learn, invert CLIP on it as rig-invert does, widen each range "
        "the clip leaves (by 10% of its width past the values reached), learn again, and print what was widened");
    app.add_option("--map", options.rangesFrom.map, "With --ranges-from: the map file of the clip (as rig-invert's)")
        ->needs(rangesFrom);
    app.add_option("--take", options.rangesFrom.take, "With --ranges-from: the clip's take, a name or 0-based index")
        ->needs(rangesFrom);
    app.add_option("--frames", options.rangesFromFrames, "With --ranges-from: the clip's frames A:B")
        ->needs(rangesFrom);
    app.add_option("--set", options.sets,
                   "Hold a plug at a value while learning, not inverted: PLUG=VALUE in the rig file's units, e.g. "
                   "L_leg_settings.ikFk=1 (repeatable; wins over the spec's 'set:')")
        ->allow_extra_args(false);
    app.add_option("-o,--output", options.output,
                   "Approximation file to write (YAML); required unless --write-spec is given, which then writes the "
                   "spec alone");
    app.add_option("--write-spec", options.writeSpec,
                   "Write the parameters, outputs and held plugs chosen (what 'auto' found) as a spec to edit and "
                   "learn with --spec");
    app.add_option("--epsilon", options.epsilon,
                   "Validation threshold, cm of frame-point error per unit of a parameter (default 0.001)");
    app.add_option("--orderer", options.orderer,
                   "Composition orderer: structured (default: tests only pairs that share an output where their "
                   "operators do not commute) or talk (tests every pair on the rig)")
        ->check(CLI::IsMember({"talk", "structured"}));
    app.add_option("--report-json", options.reportJson, "Also write the report as JSON to this file");
    app.add_flag("--no-per-output", options.noPerOutput,
                 "The talk's behaviour: discard one parameter of a pair that cannot be ordered, instead of leaving "
                 "the output where parameters do not compose unmodelled (fitted by rig-invert --hybrid)");
    app.add_flag("--world-space", options.worldSpace,
                 "Learn every output in world space, as the talk does (default: relative to its parent output where "
                 "that validates)");
    app.add_flag(
        "--allow-inexact", options.allowInexact,
        "Write the approximation even when its validation exceeds epsilon (otherwise exit code 3, nothing written)");
    app.add_option("--threads", options.threads,
                   "Rig instances evaluating at the same time: 1 serial, N parallel, 0 all cores (default); the "
                   "approximation is the same for any count")
        ->check(rig::cli::threadCount());
    app.add_option("--plugin", options.plugins, "Load a node plugin before reading the rig (repeatable)")
        ->allow_extra_args(false);
    return rig::cli::runMain(app, argc, argv, [&] {
        options.epsilonGiven = app.count("--epsilon") > 0;
        options.outputGiven = app.count("--output") > 0;
        options.reportGiven = app.count("--report-json") > 0;
        if (app.count("--frames") > 0) options.rangesFrom.frames = options.rangesFromFrames;
        return rig::run(options);
    });
}
