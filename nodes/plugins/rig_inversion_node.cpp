// rigInversion (a plugin): drives a rig's parameters from target joints with a learned approximation
// (docs/inversion-tutorial.md). target[k] is the target of the approximation's output k; value[i] is
// parameter i (the approximation's composition order), angles in degrees as unitless numbers, so that a
// connection to an angle plug turns them into radians as any unitless source does. heldValue[j] is the
// approximation's held plug j at the value it was learned with (the rig file's units, so degrees too):
// wired to the rig like the parameters, it keeps the rig in the state its approximation describes.
//
// Warm start (a stateful node, as production solvers are): an evaluation at time t starts from the
// solution at t - 1 when the previous evaluation was at t - 1, from the same start again when it was at t,
// and from the rest values otherwise (the first evaluation, scrubbing backwards, a jump) and at restart
// frames (t - startFrame a multiple of restartInterval); a start from rest is made a cold start
// (Solver::initialGuess) unless `coldStart` is off, and a warm start that ends stuck after a jump in
// cost is solved again from the guess (solveChainFrame). A chain that starts at a restart frame played in
// order is shifted by equivalences to meet the frame before it where that one was warm (inversion/clip/continuity.h;
// after another restart frame it is reported as solved, as a clip of that frame alone). rig-invert
// follows the same rules, so the node played frame after frame gives rig-invert's curves.
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <thread>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "adapter/graph_rig_function.h"
#include "core/error.h"
#include "core/pool.h"
#include "core/shared_file.h"
#include "graph/graph.h"
#include "graph/node_registry.h"
#include "graph/plug_glob.h"
#include "inversion/clip/clip_inversion.h"
#include "inversion/clip/contacts.h"
#include "inversion/clip/continuity.h"
#include "inversion/clip/hybrid_solve.h"
#include "inversion/model/approximation_io.h"
#include "inversion/solve/residual_term.h"
#include "inversion/solve/solver.h"
#include "nodes/clips/target_clip.h"
#include "nodes/contact_ranges.h"

namespace rig {
namespace {

enum Attr : AttrId {
    file,
    map,
    target,
    targetWeight,
    rotationWeight,
    maxIterations,
    threads,
    partition,
    restartInterval,
    coldStart,
    startFrame,
    sceneTime,
    value,
    status,
    iterations,
    worstErrorCm,
    parameterNames,
    outputNames,
    heldValue,
    heldNames,
    hybrid,
    rigFile,
    realRigEvaluations,
    residualTermName,
    contactsFile,
    statusOnRealRig,
};

// What a frame's compute writes and reads within itself: the targets, the solve's scratch and figures, the judgement,
// the outputs' values, the contacts' scratch with the approximation's evaluator. Borrowed from the shared model's pool
// for one compute, so that a crowd's members, solved one after the other on a thread, reuse one set warm in the cache
// instead of each reading its own from memory; a frame allocates nothing.
struct FrameScratch {
    explicit FrameScratch(const Approximation& approximation) : held(approximation) { chain.memo.on = false; }
    std::vector<JointTarget> targets;
    ChainScratch chain;
    ChainFrame frame;
    FrameInversion judged;
    std::vector<Eigen::Matrix4d> modelled, real;  // the approximation's and the real rig's outputs at the values
    std::vector<double> outputValues;             // the values in the outputs' units (degrees for angles)
    HeldFrameScratch held;
};

// An approximation and the solver built on it: read-only (Solver is const and thread-safe), so every node
// that reads the same file with the same solver settings shares one (a crowd's members: the model is
// shared, each node keeps its own state: warm start, hybrid solve), with a pool of frame scratch.
struct Loaded {
    std::string path;
    std::unique_ptr<Approximation> approximation;
    std::unique_ptr<Solver> solver;
    SolverOptions options;
    std::unique_ptr<Pool<FrameScratch>> scratch = std::make_unique<Pool<FrameScratch>>();
};

// The status attribute's names, from the statuses' one table (clip_inversion.h), in FrameStatus order.
std::vector<std::string> statusEnumNames()
{
    std::vector<std::string> names;
    for (const FrameStatusSpelling& s : frameStatusSpellings) names.emplace_back(s.enumName);
    return names;
}

std::string joinLines(const std::vector<std::string>& lines)
{
    std::string out;
    for (const auto& line : lines) out += (out.empty() ? "" : "\n") + line;
    return out;
}

Approximation readApproximation(const std::string& path, std::string_view node)
{
    if (path.empty()) throw Error(fmt::format("{}.file is empty; give the approximation file rig-learn wrote", node));
    try {
        return readApproximationFile(path);
    }
    catch (const Error& e) {
        throw e.in(fmt::format("{}.file", node));
    }
}

// The shared model for `path` and `options`, read when no node holds it (core/shared_file.h).
std::shared_ptr<const Loaded> sharedModel(const std::string& path, const SolverOptions& options, std::string_view node)
{
    const std::string extra = fmt::format("{} {} {}", options.maxIterations, options.threads, options.partition);
    return sharedFileValue<Loaded>(path, extra, [&] {
        Loaded fresh;
        fresh.path = path;
        fresh.approximation = std::make_unique<Approximation>(readApproximation(path, node));
        fresh.solver = std::make_unique<Solver>(*fresh.approximation, options);
        fresh.options = options;
        return fresh;
    });
}

// The node's map: it scales, renames and weights the targets it is given frame by frame; retargeting needs the
// clip's rest pose, which the node's targets do not carry, so a map asking for it is refused, not half applied.
TargetMap nodeMap(const std::string& path)
{
    if (path.empty()) return {};
    TargetMap map = readTargetMap(path);
    if (map.retarget.enabled)
        throw Error(
            fmt::format("{}: the rigInversion node applies a map's 'scale:', 'joints:', 'ignore:' and "
                        "'weights:' only; 'retarget:' is for rig-invert and rig-batch (docs/retargeting.md)",
                        map.retarget.where));
    return map;
}

// Per output, the map's weights (1 and 1 where it names none), as rig-invert sets them on the same map's targets.
std::vector<TargetWeight> outputWeights(const TargetMap& map, const Approximation& a)
{
    std::vector<TargetWeight> weights(a.outputs.size());
    for (const auto& [joint, weight] : map.weights) {
        const auto named = [&](const ApproximationOutput& o) { return o.name == joint; };
        const auto it = std::find_if(a.outputs.begin(), a.outputs.end(), named);
        if (it == a.outputs.end())
            throw Error(
                fmt::format("{}: weights for '{}', which is not an output of the approximation; check the "
                            "name (the rig's)",
                            weight.where, messageExcerpt(joint)));
        weights[static_cast<std::size_t>(it - a.outputs.begin())] = weight;
    }
    return weights;
}

const ResidualTerm& targetTerm(const std::string& name, std::string_view node)
{
    try {
        return residualTerm(name);
    }
    catch (const Error& e) {
        throw e.in(fmt::format("{}.term", node));
    }
}

class RigInversionNode : public Node {
public:
    void compute(ComputeContext& c) override
    {
        const std::string node(c.nodeName());
        load(c, node);
        const Approximation& a = *loaded_->approximation;
        const Borrowed<FrameScratch> scratch(*loaded_->scratch, [&] { return std::make_unique<FrameScratch>(a); });
        targetsOf(c, a, scratch->targets);
        solve(c, node, *scratch);
        c.setOutput(status, static_cast<int>(judge(*scratch)));
        c.setOutput(statusOnRealRig, binding_ != nullptr);
        writeOutputs(c, a, *scratch);
    }

private:
    // The approximation and its solver, read and made again only when `file` or the solver's settings change,
    // and the map's scale.
    void load(ComputeContext& c, const std::string& node)
    {
        SolverOptions options;
        options.maxIterations = c.getInt(maxIterations);
        options.threads = c.getInt(threads);
        options.partition = c.getBool(partition);
        try {
            options.validate();
        }
        catch (const Error& e) {
            throw e.in(node);
        }
        const std::string& path = c.getString(file);
        const bool newFile = !loaded_ || loaded_->path != path;
        bool mapStale = false;
        if (newFile || loaded_->options.maxIterations != options.maxIterations ||
            loaded_->options.threads != options.threads || loaded_->options.partition != options.partition) {
            dropRealRig();
            loaded_ = sharedModel(path, options, node);
            rest_ = loaded_->approximation->defaults();
            mapStale = true;  // its weights name the outputs of the model just read
            // A warm start is kept across new solver settings, unless the file changed under it.
            if (newFile || solution_.size() != loaded_->approximation->parameters.size()) solution_.clear();
        }
        loadContacts(c.getString(contactsFile), node);
        const std::string& mapPath = c.getString(map);
        if (mapStale || mapPath != mapPath_) {
            const TargetMap read = nodeMap(mapPath);
            scale_ = read.scale;
            weights_ = outputWeights(read, *loaded_->approximation);
            mapPath_ = mapPath;
        }
    }

    // `contacts`: a contacts file's ranges (nodes/contact_ranges.h) in scene time, read again when the path or the
    // approximation changes.
    void loadContacts(const std::string& path, const std::string& node)
    {
        if (path == contactsPath_ && contactsModel_ == loaded_.get()) return;
        contacts_.clear();
        contactsPath_ = path;
        contactsModel_ = loaded_.get();
        if (!path.empty()) {
            const Approximation& a = *loaded_->approximation;
            try {
                for (const ContactRange& r : readContactRanges(path)) {
                    const auto o = std::find_if(a.outputs.begin(), a.outputs.end(),
                                                [&](const ApproximationOutput& out) { return out.name == r.joint; });
                    if (o == a.outputs.end())
                        throw Error(
                            fmt::format("{}: '{}' is not an output of the approximation; name a joint the "
                                        "node targets (LeftFoot)",
                                        formatMark(r.jointMark), messageExcerpt(r.joint)));
                    if (r.first > r.last)
                        throw Error(fmt::format("{}: frame range [{}, {}] ends before it starts; give [first, last]",
                                                formatMark(r.rangeMark), r.first, r.last));
                    contacts_.push_back({static_cast<int>(o - a.outputs.begin()), r.first, r.last});
                }
            }
            catch (const Error& e) {
                throw e.in(fmt::format("{}.contacts", node));
            }
        }
        holds_.assign(contacts_.size(), std::nullopt);
        shifts_.assign(contacts_.size(), Eigen::Vector3d::Zero());
        startShifts_ = shifts_;
    }

    // The holds of the contacts that cover time `t` (inversion/clip/contacts.h): each at its target's position at the
    // contact's first frame, as rig-invert holds it when the node plays the frames in order (entered later, at
    // the first frame it evaluates inside the contact), with the multiplier carried along the chain.
    void contactHoldsAt(double t, std::span<const JointTarget> targets)
    {
        frameHolds_.clear();
        for (std::size_t i = 0; i < contacts_.size(); ++i) {
            const NodeContact& c = contacts_[i];
            const JointTarget& target = targets[static_cast<std::size_t>(c.output)];
            if (t < c.first || t > c.last || !target.active) {
                holds_[i].reset();
                continue;
            }
            if (t == c.first || !holds_[i]) holds_[i] = target.world.block<3, 1>(0, 3);
            frameHolds_.push_back(
                {static_cast<int>(i), c.output, *holds_[i], t == c.first ? Eigen::Vector3d::Zero() : shifts_[i]});
        }
    }

    // The connected targets, scaled to cm, with their weights (the map's times the node's attributes'), into
    // `targets`; those past the outputs reach nothing.
    void targetsOf(ComputeContext& c, const Approximation& a, std::vector<JointTarget>& targets) const
    {
        targets.assign(a.outputs.size(), JointTarget{});
        const ResidualTerm& term = targetTerm(c.getString(residualTermName), c.nodeName());
        const double rotation = c.getDouble(rotationWeight);
        c.forEachElement<Eigen::Matrix4d>(target, [&](int k, const Eigen::Matrix4d& world) {
            if (k >= static_cast<int>(targets.size())) return;
            targets[k].active = true;
            targets[k].world = world;
            targets[k].world.block<3, 1>(0, 3) *= scale_;
            targets[k].positionWeight = weights_[static_cast<std::size_t>(k)].position;
            targets[k].rotationWeight = rotation * weights_[static_cast<std::size_t>(k)].rotation;
            setTerm(targets[k], term);
        });
        c.forEachElement<double>(targetWeight, [&](int k, double w) {
            if (k < static_cast<int>(targets.size())) targets[k].positionWeight *= w;
        });
    }

    // The frame solved from where the warm-start rule (top of the file) starts it, into solution_, and shifted as
    // rig-invert reports it into reported_.
    void solve(ComputeContext& c, const std::string& node, FrameScratch& scratch)
    {
        const std::vector<JointTarget>& targets = scratch.targets;
        const Approximation& a = *loaded_->approximation;
        const double t = c.getDouble(sceneTime);
        const int interval = std::max(1, c.getInt(restartInterval));
        const double sinceStart = t - c.getDouble(startFrame);
        const bool restartFrame =
            sinceStart == std::floor(sinceStart) && std::fmod(sinceStart, static_cast<double>(interval)) == 0.0;
        // What was reported for the frame before this one, when played in order and that frame was a warm one
        // (continuity shifts: a chain meets a warm frame before it, never a restart frame).
        const bool advanced = !solution_.empty() && t == previousTime_ + 1.0;
        if (advanced && previousWarm_) before_ = reported_;
        else if (advanced) before_.clear();
        else if (solution_.empty() || t != previousTime_) before_.clear();
        const bool chainStart = solution_.empty() || restartFrame || !(t == previousTime_ || t == previousTime_ + 1.0);
        if (chainStart) {
            start_ = rest_;
            if (c.getBool(coldStart)) loaded_->solver->initialGuess(targets, start_);
            startCost_ = retryNever;  // a restart is not retried, as in rig-invert
            std::fill(startShifts_.begin(), startShifts_.end(), Eigen::Vector3d::Zero());
            startLead_ = ChainLead{};
        } else if (t != previousTime_) {
            start_ = solution_;
            startCost_ = solutionCost_;
            startShifts_ = shifts_;
            startLead_ = lead_;
        }
        solution_ = start_;
        shifts_ = startShifts_;
        scratch.chain.lead = startLead_;  // a frame solved again leads as it did the first time
        HybridSolver* h = hybridSolver(c, node, realRig(c, node));
        hybridSolved_ = h != nullptr;
        // Captured through one reference, so that the function holds it in place instead of allocating.
        const struct {
            const Solver& solver;
            HybridSolver* hybrid;
            ChainScratch& chain;
        } with{*loaded_->solver, h, scratch.chain};
        const HeldSolve solveOnce = [&with](std::span<const JointTarget> asked, std::vector<double>& v, double previous,
                                            ChainFrame& f) {
            if (with.hybrid) with.hybrid->solveFrame(asked, v, previous, with.chain, f);
            else solveChainFrame(with.solver, asked, v, previous, with.chain, f);
        };
        contactHoldsAt(t, targets);
        if (frameHolds_.empty()) solveOnce(targets, solution_, startCost_, scratch.frame);
        else solveHeldFrame(scratch.held, solveOnce, targets, frameHolds_, solution_, startCost_, scratch.frame);
        lead_ = scratch.chain.lead;
        for (const ContactHold& held : frameHolds_) shifts_[static_cast<std::size_t>(held.contact)] = held.shift;
        const SolveSummary& summary = scratch.frame.summary;
        solutionCost_ = summary.termination == TerminationType::invalidTargets ? startCost_ : summary.finalCost;
        previousTime_ = t;
        previousWarm_ = !chainStart;
        // A chain after a restart frame played in order meets the frame before it, as rig-invert reports it.
        // The shift is checked on the real rig where the node has one (`rig`), on the approximation otherwise.
        const Equivalences& equivalences = loaded_->solver->equivalences();
        if (chainStart && before_.empty()) shift_ = noShift(equivalences);
        else if (chainStart) {
            PoseCheck samePose(a, binding_.get());
            shift_ = checkedContinuityShift(equivalences, before_, solution_, &samePose);
        }
        reported_.resize(solution_.size());
        applyShift(equivalences, shift_, solution_, reported_);
    }

    // The values as reported and the solve's figures, assigned in place every frame; the names and held values of
    // the approximation, written when it changes (a crowd solves every member every frame).
    void writeOutputs(ComputeContext& c, const Approximation& a, FrameScratch& scratch)
    {
        const SolveSummary& summary = scratch.frame.summary;
        std::vector<double>& values = scratch.outputValues;
        values.resize(a.parameters.size());
        for (std::size_t i = 0; i < a.parameters.size(); ++i)
            values[i] = a.parameters[i].parameter.angular ? reported_[i] * 180.0 / std::numbers::pi : reported_[i];
        c.assignOutputElements(value, values);
        c.setOutput(iterations, summary.iterations);
        c.setOutput(worstErrorCm, summary.maxPositionErrorCm);
        c.setOutput(realRigEvaluations, scratch.frame.realRigEvaluations);
        if (namesWritten_ == loaded_.get()) return;
        namesWritten_ = loaded_.get();
        std::vector<Value> held;
        std::vector<std::string> names;
        for (const auto& p : a.parameters) names.push_back(p.parameter.name);
        c.setOutput(parameterNames, joinLines(names));
        names.clear();
        for (const auto& o : a.outputs) names.push_back(o.name);
        c.setOutput(outputNames, joinLines(names));
        names.clear();
        for (const HeldPlug& h : a.held) {
            held.emplace_back(h.value);
            names.push_back(h.plug);
        }
        c.setOutputElements(heldValue, std::move(held));
        c.setOutput(heldNames, joinLines(names));
    }

    // The frame's status at reported_ (clip_inversion.h, judgeFrame): on the node's own rig where `rig` names one, as
    // rig-invert judges it (with the hybrid solve's fit, as rig-invert --hybrid does); otherwise on the
    // approximation, where an output it does not model is a miss and a gap to the real rig goes unseen.
    FrameStatus judge(FrameScratch& s)
    {
        const Approximation& a = *loaded_->approximation;
        s.judged.clear();
        s.judged.solve = s.frame.summary;
        s.held.evaluator.evaluate(reported_, s.modelled);
        if (binding_) binding_->evaluate(reported_, s.real);
        judgeFrame(a, loaded_->options, hybridSolved_ ? RealRigFit::unmodelledOutputs : RealRigFit::none, s.targets,
                   binding_ ? s.real : s.modelled, s.modelled, s.judged);
        return s.judged.status;
    }

    // The node's own instance of the rig file `rig` (relative to the rig file that names the node; in the
    // approximation's held state) and its binding, loaded when `rig` names one and made again when it or the
    // approximation changes: the hybrid solve fits on it, and the frame's status is judged on it as rig-invert judges
    // it. Null when `rig` is empty.
    RigBinding* realRig(ComputeContext& c, const std::string& node)
    {
        const std::string& path = c.getString(rigFile);
        if (binding_ && path == rigPath_) return binding_.get();
        dropRealRig();
        if (path.empty()) return nullptr;
        // The rig as rig-invert loads it: helpers as helpers, a blend's branch copies as the joints they copy.
        const GraphRigOptions options = rigOptionsFor(*loaded_->approximation);
        try {
            realRig_ = std::make_unique<GraphRigFunction>(path, options);
            binding_ = std::make_unique<RigBinding>(*loaded_->approximation, *realRig_);
        }
        catch (const Error& e) {
            throw e.in(fmt::format("{}.rig", node));
        }
        rigPath_ = path;
        return binding_.get();
    }

    // With `hybrid` on and an approximation that leaves outputs unmodelled: the hybrid solve on `rig` (realRig),
    // made again with it. Null otherwise.
    HybridSolver* hybridSolver(ComputeContext& c, const std::string& node, RigBinding* rig)
    {
        const Approximation& a = *loaded_->approximation;
        if (!c.getBool(hybrid) || !a.hasUnmodelledOutputs()) return nullptr;
        if (!rig)
            throw Error(
                fmt::format("{}.rig is empty; the hybrid solve evaluates the rig the approximation was learned "
                            "from ({}): give its file",
                            node, a.rigFile));
        if (hybrid_) return hybrid_.get();
        const int threads = loaded_->options.threads > 0
                                ? loaded_->options.threads
                                : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
        hybrid_ = std::make_unique<HybridSolver>(*loaded_->solver, *rig, threads);
        return hybrid_.get();
    }
    // Before the approximation or the solver it refers to goes.
    void dropRealRig()
    {
        hybrid_.reset();
        binding_.reset();
        realRig_.reset();
    }

    std::shared_ptr<const Loaded> loaded_;
    std::unique_ptr<GraphRigFunction> realRig_;  // the node's own rig (`rig`), its binding, and the hybrid solve
    std::unique_ptr<RigBinding> binding_;
    std::unique_ptr<HybridSolver> hybrid_;
    std::string rigPath_;
    bool hybridSolved_ = false;  // whether the frame solved last was solved by hybrid_
    std::string mapPath_;
    double scale_ = 1.0;
    std::vector<TargetWeight> weights_;  // per output, from the map
    double previousTime_ = 0.0;
    bool previousWarm_ = false;  // the frame at previousTime_ continued a chain (was not its first frame)
    std::vector<double> start_;
    double startCost_ = retryNever;     // the cost of the frame start_ came from (retryNever: from rest)
    double solutionCost_ = retryNever;  // the cost of solution_
    ChainLead startLead_;           // whether the rotations lead the frame start_ starts (clip_inversion.h), as start_
    ChainLead lead_;                // whether they lead the frame after solution_'s, as solution_
    std::vector<double> solution_;  // the chain's, as solved
    ChunkShift shift_;              // of the current chain (inversion/clip/continuity.h)
    std::vector<double> reported_;  // solution_ shifted: the values output
    const Loaded* namesWritten_ = nullptr;  // the model whose names and held values the outputs hold
    // `contacts`: the file's ranges (scene time), each contact's hold once entered, the multipliers of the frame
    // solved and of the frame the next solve starts from (as start_ and solution_).
    struct NodeContact {
        int output = -1;
        double first = 0.0, last = 0.0;
    };
    std::string contactsPath_;
    const Loaded* contactsModel_ = nullptr;
    std::vector<NodeContact> contacts_;
    std::vector<std::optional<Eigen::Vector3d>> holds_;
    std::vector<Eigen::Vector3d> shifts_, startShifts_;
    std::vector<ContactHold> frameHolds_;
    std::vector<double> before_;  // reported_ of the frame before, when played in order; empty otherwise
    std::vector<double> rest_;    // the approximation's defaults
};

// connect: {targets: NODE_OR_GLOB, parameters: true, namespace: NS}
//   targets: a bvhClip node (its worldMatrix[j] by jointNames), or a glob of nodes with a worldMatrix
//   (the joints of another rig); each target joint, renamed by the node's map file, that is an output of
//   the approximation is connected to target[k]. parameters: value[i] -> the rig's parameter plug i, and
//   heldValue[j] -> the rig's held plug j; with namespace NS, the plugs NS:ctrl.attr of the rig included
//   under NS.
void connectByNames(Graph& graph, NodeId id, const YAML::Node& field, const YamlFieldContext& context);

// Errors of the engine (a cycle, a plug already driven) and of the files get the place of `connect:`.
void connectField(Graph& graph, NodeId id, const YAML::Node& field, const YamlFieldContext& context)
{
    try {
        connectByNames(graph, id, field, context);
    }
    catch (const Error& e) {
        const std::string message = e.what();
        if (message.starts_with(context.where(field).substr(0, context.where(field).find(':')))) throw;
        throw Error(fmt::format("{}: {}", context.where(field), message));
    }
}

// The approximation's output that a target joint is (renamed by the map), or -1.
int outputOfJoint(const Approximation& a, const TargetMap& targetMap, const std::string& joint)
{
    const auto renamed = targetMap.rename.count(joint) ? targetMap.rename.at(joint) : joint;
    if (std::find(targetMap.ignore.begin(), targetMap.ignore.end(), joint) != targetMap.ignore.end()) return -1;
    for (std::size_t k = 0; k < a.outputs.size(); ++k)  // a helper frame is never a target
        if (!a.outputs[k].helper && a.outputs[k].name == renamed) return static_cast<int>(k);
    return -1;
}

// `targets: v`: each joint of the bvhClip or glob v that is an output, to its target[k].
void connectTargets(Graph& graph, const std::string& node, const YAML::Node& v, const Approximation& a,
                    const TargetMap& targetMap, const YamlFieldContext& context)
{
    int connected = 0;
    const NodeId clip = graph.findNode(v.Scalar());
    if (clip >= 0 && graph.nodeType(clip).name() == "bvhClip") {
        const auto names = std::get<std::string>(graph.getValue(graph.plug(v.Scalar() + ".jointNames")));
        std::vector<std::string> joints;
        for (std::size_t s = 0; s <= names.size();) {
            const auto e = std::min(names.find('\n', s), names.size());
            if (e > s) joints.push_back(names.substr(s, e - s));
            s = e + 1;
        }
        for (std::size_t j = 0; j < joints.size(); ++j)
            if (const int k = outputOfJoint(a, targetMap, joints[j]); k >= 0) {
                graph.connect(graph.plug(fmt::format("{}.worldMatrix[{}]", v.Scalar(), j)),
                              graph.plug(fmt::format("{}.target[{}]", node, k)));
                ++connected;
            }
    } else {
        std::vector<Plug> sources;
        try {
            sources = matchPlugs(graph, v.Scalar() + ".worldMatrix");
        }
        catch (const Error& e) {
            throw Error(fmt::format("{}: targets: {}", context.where(v), e.what()));
        }
        for (const Plug& source : sources)
            if (const int k = outputOfJoint(a, targetMap, graph.nodeName(source.node)); k >= 0) {
                graph.connect(source, graph.plug(fmt::format("{}.target[{}]", node, k)));
                ++connected;
            }
    }
    if (connected == 0)
        throw Error(
            fmt::format("{}: no joint of '{}' is an output of the approximation ({}, ...); give a map "
                        "file that renames them",
                        context.where(v), v.Scalar(), a.outputs.empty() ? "" : a.outputs[0].name));
}

// `parameters: true`: value[i] to the rig's parameter plug i, and heldValue[j] to its held plug j; `prefix`
// ("NAMESPACE:" or empty) names the copy of the rig to drive when a graph holds several (a crowd).
void connectParameters(Graph& graph, const std::string& node, const YAML::Node& v, const Approximation& a,
                       const std::string& prefix, const YamlFieldContext& context)
{
    for (std::size_t i = 0; i < a.parameters.size(); ++i) {
        const std::string name = prefix + a.parameters[i].parameter.name;
        Plug destination;
        try {
            destination = graph.plug(name);
        }
        catch (const Error&) {
            throw Error(
                fmt::format("{}: the approximation drives '{}', which this graph does not have: it "
                            "was learned from another rig ({}); include that rig or learn this one",
                            context.where(v), name, a.rigFile));
        }
        graph.connect(graph.plug(fmt::format("{}.value[{}]", node, i)), destination);
    }
    // The held plugs too: the rig must be in the state the approximation was learned in.
    for (std::size_t j = 0; j < a.held.size(); ++j) {
        const HeldPlug& h = a.held[j];
        const std::string plug = prefix + h.plug;
        Plug destination;
        try {
            destination = graph.plug(plug);
        }
        catch (const Error&) {
            throw Error(
                fmt::format("{}: the approximation was learned with '{}' held at {}, which this graph does "
                            "not have: it was learned from another rig ({}); include that rig or learn this one",
                            context.where(v), plug, h.value, a.rigFile));
        }
        if (const Connection* c = graph.incomingConnection(destination))
            throw Error(
                fmt::format("{}: the approximation was learned with {} held at {}, but {} drives it here; "
                            "the node holds it at that value: disconnect it, or learn the rig in another "
                            "state (rig-learn --set)",
                            context.where(v), plug, h.value, graph.plugName(c->source)));
        graph.connect(graph.plug(fmt::format("{}.heldValue[{}]", node, j)), destination);
    }
}

void connectByNames(Graph& graph, NodeId id, const YAML::Node& field, const YamlFieldContext& context)
{
    const std::string node = graph.nodeName(id);
    if (!field.IsMap())
        throw Error(fmt::format("{}: 'connect' is a map {{targets: NODE, parameters: true}}", context.where(field)));
    const Approximation a = readApproximation(std::get<std::string>(graph.getValue(graph.plug(node + ".file"))), node);
    const std::string mapPath = std::get<std::string>(graph.getValue(graph.plug(node + ".map")));
    const TargetMap targetMap = nodeMap(mapPath);
    outputWeights(targetMap, a);  // a weight naming no output is said here, with the map's line, before any frame
    // `namespace: NS` (a crowd's member, included under NS): the parameters are NS:ctrl.plug.
    std::string prefix;
    if (const YAML::Node ns = field["namespace"]) {
        if (!ns.IsScalar() || ns.Scalar().empty())
            throw Error(fmt::format("{}: 'namespace' is the namespace of the rig to drive (as in include:)",
                                    context.where(ns)));
        prefix = ns.Scalar() + ":";
    }
    for (const auto& entry : field) {
        const std::string key = entry.first.Scalar();
        const YAML::Node& v = entry.second;
        if (key == "targets") {
            if (!v.IsScalar()) throw Error(fmt::format("{}: 'targets' is a node name or a glob", context.where(v)));
            connectTargets(graph, node, v, a, targetMap, context);
        } else if (key == "parameters") {
            if (!v.IsScalar() || (v.Scalar() != "true" && v.Scalar() != "false"))
                throw Error(fmt::format("{}: 'parameters' is true or false", context.where(v)));
            if (v.Scalar() == "true") connectParameters(graph, node, v, a, prefix, context);
        } else if (key != "namespace") {
            throw Error(fmt::format("{}: unknown key '{}' in 'connect'; it has 'targets', 'parameters' and 'namespace'",
                                    context.where(entry.first), key));
        }
    }
}

}  // namespace
}  // namespace rig

extern "C" void initializePlugin(rig::NodeRegistry& registry)
{
    using namespace rig;
    NodeTypeBuilder b("rigInversion");
    b.description(
        "Drives a rig's parameters from target joints with an approximation learned by rig-learn "
        "(docs/inversion-tutorial.md). target[k] is the target of the approximation's output k; "
        "value[i] its parameter i, angles in degrees. Warm-starts from the previous frame when time "
        "moves on by one frame. The rig-file field `connect: {targets: NODE_OR_GLOB, parameters: true}` "
        "wires it by the names stored in the approximation, the held plugs (heldValue[j]) with the parameters; "
        "`namespace: NS` drives the copy of the rig included under NS (a crowd's member).");
    b.input(file, "file", ValueType::String)
        .filePath()
        .doc("Approximation file (rig-learn -o), relative to the rig file that names it; read again when it changes.");
    b.input(map, "map", ValueType::String)
        .filePath()
        .doc(
            "Map file (docs/rig-invert.md), relative to the rig file that names it: the targets' scale to cm and their "
            "joint names for `connect`.");
    b.input(target, "target", ValueType::Matrix4).array().doc("Target world matrix of each approximation output.");
    b.input(targetWeight, "targetWeight", ValueType::Double).array().doc("Position weight of each target (default 1).");
    b.input(rotationWeight, "rotationWeight", ValueType::Double)
        .defaultValue(1.0)
        .min(0.0)
        .doc("Weight of the rotation residuals against the positions.");
    b.input(maxIterations, "maxIterations", ValueType::Int)
        .defaultValue(SolverOptions{}.maxIterations)
        .min(1)
        .doc("Most solver iterations per evaluation.");
    b.input(threads, "threads", ValueType::Int)
        .defaultValue(0)
        .min(0)
        .doc("Solver threads (0: all cores); the values do not depend on it.");
    b.input(partition, "partition", ValueType::Bool)
        .defaultValue(true)
        .doc("Solve independent limbs as separate problems.");
    b.input(restartInterval, "restartInterval", ValueType::Int)
        .defaultValue(120)
        .min(1)
        .doc("Frames between warm-start restarts, as rig-invert --restart-every.");
    b.input(coldStart, "coldStart", ValueType::Bool)
        .defaultValue(true)
        .doc(
            "A restart starts from the approximation's initial guess for the targets, not from rest (rig-invert "
            "--rest-starts turns it off).");
    b.input(startFrame, "startFrame", ValueType::Double).defaultValue(1.0).doc("The clip's first frame.");
    b.input(sceneTime, "time", ValueType::Double).unit(Unit::Time).sceneTime().doc("The frame being solved.");
    b.output(value, "value", ValueType::Double)
        .array()
        .doc("Each parameter of the approximation, angles in degrees (unitless).");
    b.output(status, "status", ValueType::Enum)
        .enumNames(statusEnumNames())
        .doc(
            "The frame's status as rig-invert names it (docs/rig-invert.md): reached (every target within 1e-3 cm), "
            "bestFit (stationary with a residual: out of the rig's reach, or a local minimum), modelMismatch, "
            "notConverged, nonFinite, "
            "invalidTargets. Judged on the real rig where `rig` names it (the node's own instance; statusOnRealRig "
            "on), "
            "on the approximation otherwise, where a target it does not model is a miss and its gap to the real rig "
            "(a control past its learned range) goes unseen. A small model mismatch that rig-invert polishes on the "
            "real rig by default stays a modelMismatch here: the node makes no corrections on the real rig.");
    b.output(iterations, "iterations", ValueType::Int).doc("Solver iterations of this evaluation.");
    b.output(worstErrorCm, "worstErrorCm", ValueType::Double)
        .doc("Worst target position error on the approximation, cm.");
    b.output(parameterNames, "parameterNames", ValueType::String).doc("The parameters, one per line.");
    b.output(outputNames, "outputNames", ValueType::String).doc("The outputs (target joints), one per line.");
    b.output(heldValue, "heldValue", ValueType::Double)
        .array()
        .doc(
            "Each plug the approximation was learned with held, at its held value (the rig file's units, angles in "
            "degrees, unitless); `connect: {parameters: true}` wires them to the rig.");
    b.output(heldNames, "heldNames", ValueType::String).doc("The held plugs, one per line.");
    b.input(hybrid, "hybrid", ValueType::Bool)
        .defaultValue(false)
        .doc(
            "Fit the outputs the approximation does not model (an IK leg) by Gauss-Newton on the real rig after the "
            "approximation's solve, as rig-invert --hybrid (docs/solver.md); needs `rig`.");
    b.input(rigFile, "rig", ValueType::String)
        .filePath()
        .doc(
            "The rig file the approximation was learned from, relative to the rig file that names it: the node "
            "evaluates its own instance of it, in the approximation's held state, to judge `status` as rig-invert "
            "does and for the hybrid solve; empty: no real rig, status is the approximation's judgement.");
    b.output(realRigEvaluations, "realRigEvaluations", ValueType::Int)
        .doc("Real-rig evaluations of this evaluation's hybrid solve (0 without it).");
    b.input(residualTermName, "term", ValueType::String)
        .defaultValue(std::string("jointTarget"))
        .doc(
            "The residual term of every target (docs/solver.md): jointTarget (position and rotation) or position "
            "(the position alone, three rows; rotationWeight is not used).");
    b.input(contactsFile, "contacts", ValueType::String)
        .filePath()
        .doc(
            "A contacts file (docs/retargeting.md, Contacts), relative to the rig file that names it: joints planted "
            "over frame ranges in scene time, each held at its target's position at the range's first frame with a "
            "priority above the other targets, as rig-invert --contacts FILE holds them when played in order.");
    b.output(statusOnRealRig, "statusOnRealRig", ValueType::Bool)
        .doc(
            "Whether `status` was judged on the real rig (`rig` given), as rig-invert judges it; off: on the "
            "approximation, which cannot see where it disagrees with the rig (a modelMismatch there reads bestFit).");
    b.affectsAll();
    b.stateful();
    b.yamlConnector("connect", connectField);
    registry.add(b.factory<RigInversionNode>().build());
}
