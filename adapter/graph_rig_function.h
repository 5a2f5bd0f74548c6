#pragma once
// The rig as a black box for the learner and the solver: a RigFunction backed by a private graph
// instance loaded from a rig file. Parameters are free keyable scalar input plugs named by globs
// ('L_arm_*.rotate?', 'hips.translate?'); outputs are joints (all, or by name globs), then helper frames
// (transforms and joints that are not outputs: IK goals, pole objects, aim targets), read as world
// matrices. Evaluations are counted; one object evaluates serially (the graph is stateful), instances
// of it in parallel (docs/rig-learn.md).

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "adapter/rig_auto.h"
#include "core/error.h"
#include "graph/graph.h"
#include "inversion/model/approximation.h"
#include "inversion/model/rig_function.h"

namespace rig {

struct GraphRigOptions {
    // Plug globs; each must match at least one free (unconnected) keyable scalar input plug. A vector
    // attribute ('hips.translate') stands for its X/Y/Z components.
    std::vector<std::string> parameterGlobs;
    // Joint-name globs; empty: every joint of the rig.
    std::vector<std::string> outputGlobs;
    // Plugins to load before reading the rig (as graph-eval --plugin).
    std::vector<std::string> plugins;
    // Plugs held at a value, not inverted (rig-learn --set: a mode or space switch, a rig setting): each one
    // number input that nothing drives and that is not a parameter, by its name (not a glob), the value in
    // the rig file's units (degrees for angles) within the attribute's limits. Set once when the rig loads,
    // so every instance() has them and resetState() keeps them.
    std::vector<HeldPlug> held{};
    // Ranges to learn over (rig-learn's spec `ranges:`) for parameters whose attribute declares no limit: the first
    // glob that matches a parameter gives its min and max in the rig file's units (degrees for angles), instead of
    // the default range around its value. Still no limit: the solver may go past it.
    struct LearnRange {
        std::string glob;
        double min = 0.0;
        double max = 0.0;
    };
    std::vector<LearnRange> ranges{};
    // Helper frames (RigFunction::helperOutputs), outputs after the joints: names or globs of transforms and joints
    // that are not outputs. Each glob must match at least one.
    std::vector<std::string> helperGlobs{};
    // Also every helper the rig shows (discoverHelpers): with the globs', each helper once, in name order.
    bool autoHelpers = false;
    // rig-learn --params auto (docs/rig-learn.md): after the globs' parameters, the channels of a Maya scene's
    // controls (controlChannels) that move an output at rest, each probed on the rig, time curves cut; and the
    // controls' settings (an ikFk switch) held at the scene's values. Refused for a YAML rig.
    bool autoParameters = false;
    // --outputs auto: also the joints the scene's skinClusters bind, or every joint where none binds one.
    bool autoOutputs = false;
    // A parameter that a time curve keys (timeCurveInput) is cut from its curve, keeping the value the curve gives
    // it: the learner sets it, the curve is the clip. Else it is driven, and no parameter.
    bool cutTimeCurves = false;
};

// What autoParameters and autoOutputs chose beside the parameters, outputs and held plugs, for a report and a spec.
struct AutoChoice {
    std::vector<std::string> controls;   // the scene's controls found (ControlChannels::controls)
    std::vector<PassedChannel> passed;   // their channels passed by, with why ("moves no output" included)
    std::vector<std::string> settings;   // the held plugs auto added (the controls' settings)
    std::vector<std::string> cutCurves;  // the parameters whose time curve was cut
    int skins = -1;                      // autoOutputs: the skinClusters binding them (0: every joint); -1: off
    std::uint64_t probeEvaluations = 0;  // the rig evaluations of the probe (not evaluationCount's)
};

// The options that load the rig of an approximation in the state it was learned in: its parameters, its
// outputs (not a blend's branch copies, which are joints of the rig: blend_merge.h) and its held plugs.
GraphRigOptions rigOptionsFor(const Approximation& approximation, std::vector<std::string> plugins = {});

// A parameter, output or helper glob, or a held plug, the rig cannot provide (no such plug or joint, a driven
// plug, not a joint, a value outside the attribute's limits). what() is the whole line ("RIG: parameter 'GLOB':
// REASON", ...); a caller that chose the names itself (rig-invert, from an approximation file) can say more
// from kind() ("parameter", "output", "helper" or "held plug"), name() (the glob or plug) and reason().
class RigSelectionError : public Error {
public:
    RigSelectionError(const std::string& message, std::string kind, std::string name, std::string reason)
        : Error(message), kind_(std::move(kind)), name_(std::move(name)), reason_(std::move(reason))
    {
    }
    const std::string& kind() const { return kind_; }
    const std::string& name() const { return name_; }
    const std::string& reason() const { return reason_; }

private:
    std::string kind_, name_, reason_;
};

// Sampling range of a parameter whose attribute declares no min/max, around its current value
// (docs/rig-learn.md): +-90 degrees for angles, +-50 cm for distances, +-1 otherwise; a positive scale
// (an attribute named scale*) from half to twice its value, which never passes through a zero scale.
inline constexpr double defaultAngleRangeDegrees = 90.0;
inline constexpr double defaultDistanceRangeCm = 50.0;
inline constexpr double defaultUnitlessRange = 1.0;
inline constexpr double defaultScaleFactor = 2.0;

class GraphRigFunction final : public RigFunction {
public:
    // Loads the rig and resolves the globs. Throws rig::Error (one line: "file:line:col: ..." for a
    // bad rig file), RigSelectionError (the glob and a suggestion when a glob matches nothing usable).
    GraphRigFunction(const std::filesystem::path& rigFile, const GraphRigOptions& options);

    const std::vector<RigParameter>& parameters() const override { return parameters_; }
    // The joints, in rig order, then the helpers, in name order. A joint output is its worldMatrix; a helper is its
    // worldMatrix moved to its rotate pivot, W [I | rp] (the same motion, its origin the point W rp): what a point,
    // aim or pole-vector constraint reads as a target's position (its parentMatrix (translate + rotatePivot +
    // rotatePivotTranslate), equal to W rp where the scale pivot is the rotate pivot or the scale is 1) and where an
    // ikHandle's goal is. A control whose transforms were frozen (translate 0, its place in rotatePivot) has its
    // worldMatrix's origin at its parent's, away from the point the rig reads (docs/maya.md).
    const std::vector<std::string>& outputs() const override { return outputNames_; }
    // A joint's: up the parentMatrix connections (a joint's `parent:`) through transforms and joints that are
    // not joint outputs (a helper is passed like any transform); a parentMatrix fed by anything else (a
    // multMatrix, a constraint) ends the walk at -1. A helper's: -1, it is learned in world space.
    std::vector<int> outputParents() const override { return outputParents_; }
    std::vector<char> helperOutputs() const override { return helperFlags_; }
    // Sets the parameter plugs whose value changed since the last call, evaluates, and reads the
    // outputs' worldMatrix. Throws an internal rig::Error for a wrong number of values, rig::Error for a
    // value the rig refuses (outside the attribute's limits).
    void evaluate(std::span<const double> values, std::vector<Eigen::Matrix4d>& worlds) override;
    std::uint64_t evaluationCount() const override { return evaluations_; }
    // FNV-1a 64 (16 hex digits) over the contents of the rig file and every file it includes, then the held
    // plugs' names and values when there are any (without, the rig files' alone, as before held plugs).
    std::string fingerprint() const override { return fingerprint_; }
    // The held plugs as set: each once, named as the rig names it, sorted by name, in the rig file's units.
    const std::vector<HeldPlug>& held() const { return held_; }
    // Shares the parsed rig (Graph::instance): no file is read again.
    std::unique_ptr<RigFunction> instance() const override;
    void resetState() override;
    // The rig file and every file it includes, in reading order.
    const std::vector<std::filesystem::path>& files() const { return files_; }
    // What auto chose (GraphRigOptions::autoParameters, autoOutputs), and the time curves cut.
    const AutoChoice& autoChoice() const { return auto_; }

    // The instance, for tools that also read or set other plugs. Plugs set behind this object's back
    // are overwritten only when the parameter's value changes.
    Graph& graph() { return *graph_; }
    const std::vector<Plug>& parameterPlugs() const { return parameterPlugs_; }
    const std::vector<Plug>& outputPlugs() const { return outputPlugs_; }

private:
    GraphRigFunction(const GraphRigFunction& other);
    // The outputs' names, plugs, parents and helper flags: the joints, then the helpers.
    void setOutputs(const std::vector<NodeId>& joints, const std::vector<NodeId>& helpers);

    std::unique_ptr<Graph> graph_;
    std::vector<RigParameter> parameters_;
    std::vector<Plug> parameterPlugs_;
    std::vector<double> current_;  // the value each parameter plug holds
    std::vector<std::string> outputNames_;
    std::vector<Plug> outputPlugs_;
    std::vector<int> outputParents_;
    std::vector<char> helperFlags_;
    // Per output, a helper's rotatePivot plug (node -1: none, a joint output's too): the helper is read at its rotate
    // pivot (outputs() below), the point the rig's constraints and IK handles read.
    std::vector<Plug> pivotPlugs_;
    // The outputs as last read, and their node's compute count then (notRead before the first read).
    static constexpr std::uint64_t notRead = ~std::uint64_t{0};
    std::vector<Eigen::Matrix4d> outputWorlds_;
    std::vector<std::uint64_t> computesSeen_;
    std::uint64_t evaluations_ = 0;
    std::string fingerprint_;
    std::vector<std::filesystem::path> files_;
    std::vector<HeldPlug> held_;
    AutoChoice auto_;
};

// The helper frames a rig shows for these outputs and parameter plugs (GraphRigOptions::autoHelpers, rig-learn's
// default): every transform or joint that is not an output, whose worldMatrix or worldInverseMatrix feeds a node
// upstream of an output (an IK goal, a pole object, an aim target, a parent), and which a parameter moves (the
// parameter's node is that node or upstream of it); or which no parameter moves but whose matrix feeds a node that
// is neither a transform nor a joint (a fixed aim target read by a constraint). Upstream and downstream follow
// connections node to node. In name order.
std::vector<NodeId> discoverHelpers(const GraphModel& model, const std::vector<NodeId>& outputs,
                                    const std::vector<Plug>& parameterPlugs);

// The nearest ancestor of `node` among the nodes of `outputOfNode` (its value: the output's index): up
// worldMatrix -> parentMatrix connections, through transforms and joints that are not outputs; -1 when anything
// else feeds a parentMatrix. The outputs' hierarchy (GraphRigFunction::outputParents, graph-eval --html's
// skeletons).
int parentOutput(const Graph& g, NodeId node, const std::map<NodeId, int>& outputOfNode);

// FNV-1a 64 of bytes, continuing from `hash` (start: the FNV offset basis).
std::uint64_t fnv1a64(std::string_view bytes, std::uint64_t hash = 0xcbf29ce484222325ull);

}  // namespace rig
