#include "inversion/learn/blend_merge.h"

#include <algorithm>
#include <functional>
#include <map>
#include <set>
#include <utility>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {
namespace {

int find(const Approximation& a, const std::string& name)
{
    for (std::size_t k = 0; k < a.outputs.size(); ++k)
        if (a.outputs[k].name == name) return static_cast<int>(k);
    return -1;
}

// Where a branch's parameter's operators on output k go in the merge (-1: nowhere).
using OperatorMap = std::function<int(int)>;

// The parameters of both branches, each once, in a topological order of what each branch's order says on the merged
// outputs its operators act on (an output only one branch's operators reach keeps that branch's order; two shared
// parameters on the IK branch's outputs alone keep its order), ties in the IK branch's order, then the FK branch's.
std::vector<std::string> mergedOrder(const Approximation& ik, const OperatorMap& ikMap, const Approximation& fk,
                                     const OperatorMap& fkMap)
{
    std::vector<std::string> names;
    std::map<std::string, int> id;
    for (const Approximation* a : {&ik, &fk})
        for (const ModelledParameter& m : a->parameters)
            if (id.emplace(m.parameter.name, static_cast<int>(names.size())).second) names.push_back(m.parameter.name);
    std::vector<std::set<int>> after(names.size());
    std::vector<int> before(names.size(), 0);
    const auto edges = [&](const Approximation& a, const OperatorMap& map) {
        std::map<int, int> last;  // merged output -> the branch's last parameter acting on it so far
        for (const ModelledParameter& m : a.parameters)
            for (const int k : m.outputs) {
                const int o = map(k), p = id.at(m.parameter.name);
                if (o < 0) continue;
                if (const auto it = last.find(o);
                    it != last.end() && it->second != p && after[static_cast<std::size_t>(it->second)].insert(p).second)
                    ++before[static_cast<std::size_t>(p)];
                last[o] = p;
            }
    };
    edges(ik, ikMap);
    edges(fk, fkMap);
    std::set<int> ready;
    for (std::size_t p = 0; p < names.size(); ++p)
        if (!before[p]) ready.insert(static_cast<int>(p));
    std::vector<std::string> order;
    while (!ready.empty()) {
        const int p = *ready.begin();
        ready.erase(ready.begin());
        order.push_back(names[static_cast<std::size_t>(p)]);
        for (const int q : after[static_cast<std::size_t>(p)])
            if (--before[static_cast<std::size_t>(q)] == 0) ready.insert(q);
    }
    if (order.size() != names.size())
        throw Error(
            "switch branches: the IK and FK branches compose their shared parameters in orders that do not "
            "merge; learn both with the same --orderer");
    return order;
}

// A constraint's inputs moved through `map` (-1 stays -1).
template <class Map>
ConstraintBase remapped(ConstraintBase c, const Map& map)
{
    for (int* input : c.outputFields())
        if (*input >= 0) *input = map(*input);
    return c;
}

// The merged approximation's outputs as built: where each branch's outputs went.
struct OutputMaps {
    std::vector<int> ikShared, ikCopy;  // per IK output: its merged output, and its IK copy (switched only)
    std::vector<int> fkShared, fkCopy;  // per FK output: its merged output (shared or FK only), its FK copy
    std::vector<char> ikSwitched, fkSwitched;
};

// One branch's output copied into `m`, its parent and constraint inputs through `map`.
template <class Map>
ApproximationOutput copyOutput(const Approximation& from, int k, const Map& map, Approximation& m)
{
    ApproximationOutput o = from.outputs[static_cast<std::size_t>(k)];
    if (o.parent >= 0) o.parent = map(o.parent);
    if (o.constraint >= 0) {
        m.constraints.push_back(remapped(from.constraints[static_cast<std::size_t>(o.constraint)], map));
        o.constraint = static_cast<int>(m.constraints.size()) - 1;
    }
    return o;
}

OutputMaps mergeOutputs(const SwitchBranches& s, Approximation& m)
{
    const Approximation &ik = *s.ik, &fk = *s.fk;
    OutputMaps maps{std::vector<int>(ik.outputs.size()),     std::vector<int>(ik.outputs.size(), -1),
                    std::vector<int>(fk.outputs.size(), -1), std::vector<int>(fk.outputs.size(), -1),
                    std::vector<char>(ik.outputs.size(), 0), std::vector<char>(fk.outputs.size(), 0)};
    for (const SwitchBranches::Switched& w : s.switched) {
        const int a = find(ik, w.output), b = find(fk, w.output);
        if (a < 0 || b < 0)
            throw Error(fmt::format("switch branches: the switched output '{}' is not an output of the {} branch",
                                    w.output, a < 0 ? "IK" : "FK"));
        maps.ikSwitched[static_cast<std::size_t>(a)] = maps.fkSwitched[static_cast<std::size_t>(b)] = 1;
    }
    // Shared outputs keep the IK branch's indices; the copies and the FK branch's own outputs follow.
    for (std::size_t k = 0; k < ik.outputs.size(); ++k) maps.ikShared[k] = static_cast<int>(k);
    int next = static_cast<int>(ik.outputs.size());
    for (std::size_t k = 0; k < ik.outputs.size(); ++k)
        if (maps.ikSwitched[k]) maps.ikCopy[k] = next++;
    for (std::size_t k = 0; k < fk.outputs.size(); ++k) {
        const int shared = find(ik, fk.outputs[k].name);
        maps.fkShared[k] = shared >= 0 ? shared : next++;
        if (maps.fkSwitched[k]) maps.fkCopy[k] = next++;
    }
    m.outputs.resize(static_cast<std::size_t>(next));
    const auto ikMap = [&](int k) { return maps.ikShared[static_cast<std::size_t>(k)]; };
    const auto ikCopyMap = [&](int k) {
        return maps.ikSwitched[static_cast<std::size_t>(k)] ? maps.ikCopy[static_cast<std::size_t>(k)] : ikMap(k);
    };
    const auto fkCopyMap = [&](int k) {
        return maps.fkSwitched[static_cast<std::size_t>(k)] ? maps.fkCopy[static_cast<std::size_t>(k)]
                                                            : maps.fkShared[static_cast<std::size_t>(k)];
    };
    for (std::size_t k = 0; k < ik.outputs.size(); ++k) {
        if (!maps.ikSwitched[k]) {
            m.outputs[k] = copyOutput(ik, static_cast<int>(k), ikMap, m);
            continue;
        }
        m.outputs[k] = ik.outputs[k];  // a blend (makeBlends): its branches' copies hold the modelling
        ApproximationOutput copy = copyOutput(ik, static_cast<int>(k), ikCopyMap, m);
        copy.name += "@ik";
        copy.helper = true;
        m.outputs[static_cast<std::size_t>(maps.ikCopy[k])] = std::move(copy);
    }
    for (std::size_t k = 0; k < fk.outputs.size(); ++k) {
        if (find(ik, fk.outputs[k].name) < 0)
            m.outputs[static_cast<std::size_t>(maps.fkShared[k])] = copyOutput(fk, static_cast<int>(k), fkCopyMap, m);
        if (!maps.fkSwitched[k]) continue;
        ApproximationOutput copy = copyOutput(fk, static_cast<int>(k), fkCopyMap, m);
        copy.name += "@fk";
        copy.helper = true;
        m.outputs[static_cast<std::size_t>(maps.fkCopy[k])] = std::move(copy);
    }
    return maps;
}

// Each switched output a blend of its copies, read relative to their branches' parents; the weights' parameters
// start at `firstWeight`.
void makeBlends(const SwitchBranches& s, const OutputMaps& maps, int firstWeight, Approximation& m)
{
    for (const SwitchBranches::Switched& w : s.switched) {
        const int a = find(*s.ik, w.output), b = find(*s.fk, w.output);
        ConstraintBase c;
        c.kind = ConstraintKind::blend;
        c.blend = w.rule;
        if (w.weight < 0 || w.weight >= static_cast<int>(s.weights.size()))
            throw internalError(fmt::format("mergeSwitchBranches: '{}' has no weight {}", w.output, w.weight));
        c.weight = firstWeight + w.weight;
        c.ik = maps.ikCopy[static_cast<std::size_t>(a)];
        c.fk = maps.fkCopy[static_cast<std::size_t>(b)];
        if (!w.parent.empty()) {
            const int pa = find(*s.ik, w.parent), pb = find(*s.fk, w.parent);
            if (pa < 0 || pb < 0)
                throw Error(fmt::format("switch branches: the parent '{}' of '{}' is not an output of both branches",
                                        w.parent, w.output));
            c.anchor = pa;
            c.ikParent = maps.ikSwitched[static_cast<std::size_t>(pa)] ? maps.ikCopy[static_cast<std::size_t>(pa)] : pa;
            c.fkParent = maps.fkSwitched[static_cast<std::size_t>(pb)] ? maps.fkCopy[static_cast<std::size_t>(pb)]
                                                                       : maps.fkShared[static_cast<std::size_t>(pb)];
        }
        m.constraints.push_back(c);
        ApproximationOutput& out = m.outputs[static_cast<std::size_t>(a)];
        out.parent = -1;
        out.modelled = true;
        out.constraint = static_cast<int>(m.constraints.size()) - 1;
    }
}

// A branch's parameter's operators on the merged outputs, through `map` (-1: left to the other branch).
void addOperators(const ModelledParameter& p, const OperatorMap& map, std::vector<std::pair<int, Operator>>& on)
{
    for (std::size_t e = 0; e < p.outputs.size(); ++e)
        if (const int k = map(p.outputs[e]); k >= 0)
            on.emplace_back(k, p.operators[static_cast<std::size_t>(p.operatorOfOutput[e])]);
}

}  // namespace

namespace {

// The switched outputs a blend can model: modelled in both branches, under a parent that is (an unmodelled output has
// no output relative to it). The others stay the IK branch's, not modelled (--no-helpers leaves an IK leg so), and
// their switches move them on the real rig only; `unblended` gets them.
std::vector<SwitchBranches::Switched> blendable(const SwitchBranches& s,
                                                std::vector<SwitchBranches::Switched>& unblended)
{
    std::vector<SwitchBranches::Switched> out;
    std::set<std::string> left;
    for (const SwitchBranches::Switched& w : s.switched) {
        const int a = find(*s.ik, w.output), b = find(*s.fk, w.output);
        // An output missing from a branch is mergeOutputs' error to report.
        const bool modelled = a < 0 || b < 0 ||
                              (s.ik->outputs[static_cast<std::size_t>(a)].modelled &&
                               s.fk->outputs[static_cast<std::size_t>(b)].modelled && !left.contains(w.parent));
        if (modelled) out.push_back(w);
        else {
            unblended.push_back(w);
            left.insert(w.output);
        }
    }
    return out;
}

// The parameters of both branches by name (mergedOrder), each one's operators on the merged outputs. An FK branch's
// operator on an output the merge does not model (the IK branch's) makes that output one the parameter moves on the
// real rig only.
void mergeParameters(const SwitchBranches& s, const OutputMaps& maps, Approximation& m)
{
    const Approximation &ik = *s.ik, &fk = *s.fk;
    const OperatorMap ikMap = [&](int k) {
        return maps.ikSwitched[static_cast<std::size_t>(k)] ? maps.ikCopy[static_cast<std::size_t>(k)] : k;
    };
    // A shared output is the IK branch's: its operators are, not the FK branch's.
    const OperatorMap fkMap = [&](int k) {
        if (maps.fkSwitched[static_cast<std::size_t>(k)]) return maps.fkCopy[static_cast<std::size_t>(k)];
        return find(ik, fk.outputs[static_cast<std::size_t>(k)].name) >= 0 ? -1
                                                                           : maps.fkShared[static_cast<std::size_t>(k)];
    };
    const auto byName = [](const Approximation& a, const std::string& name) -> const ModelledParameter* {
        for (const ModelledParameter& p : a.parameters)
            if (p.parameter.name == name) return &p;
        return nullptr;
    };
    for (const std::string& name : mergedOrder(ik, ikMap, fk, fkMap)) {
        const ModelledParameter* a = byName(ik, name);
        const ModelledParameter* b = byName(fk, name);
        ModelledParameter p = a ? *a : *b;
        std::vector<std::pair<int, Operator>> on;
        if (a) addOperators(*a, ikMap, on);
        if (b) addOperators(*b, fkMap, on);
        std::sort(on.begin(), on.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
        p.outputs.clear();
        p.operators.clear();
        p.operatorOfOutput.clear();
        for (const auto& [k, op] : on) {
            p.outputs.push_back(k);
            p.operatorOfOutput.push_back(static_cast<int>(p.operators.size()));
            p.operators.push_back(op);
        }
        std::set<int> unmodelled;
        if (a) unmodelled.insert(a->unmodelledOutputs.begin(), a->unmodelledOutputs.end());
        if (b)
            for (const int k : b->outputs)
                if (const int shared = find(ik, fk.outputs[static_cast<std::size_t>(k)].name);
                    fkMap(k) < 0 && shared >= 0 && !m.outputs[static_cast<std::size_t>(shared)].modelled)
                    unmodelled.insert(shared);
        p.unmodelledOutputs.assign(unmodelled.begin(), unmodelled.end());
        m.parameters.push_back(std::move(p));
    }
}

}  // namespace

Approximation mergeSwitchBranches(const SwitchBranches& branches)
{
    if (!branches.ik || !branches.fk) throw internalError("mergeSwitchBranches: both branches are needed");
    std::set<std::string> weights;
    for (const RigParameter& w : branches.weights) {
        if (!w.limited || w.min < 0.0 || w.max > 1.0)
            throw Error(fmt::format("switch branches: the weight '{}' is not limited to [0, 1]", w.name));
        weights.insert(w.name);
    }
    SwitchBranches s = branches;
    std::vector<SwitchBranches::Switched> unblended;
    s.switched = blendable(branches, unblended);
    const Approximation &ik = *s.ik, &fk = *s.fk;
    Approximation m;
    m.rigFile = ik.rigFile;
    m.rigFingerprint = ik.rigFingerprint;
    m.epsilon = ik.epsilon;
    for (const HeldPlug& h : ik.held)
        if (!weights.contains(h.plug)) m.held.push_back(h);
    m.droppedOutputs = ik.droppedOutputs;
    m.training = ik.training;
    m.training.evaluations += fk.training.evaluations;
    m.training.orderEvaluations += fk.training.orderEvaluations;
    m.training.seconds += fk.training.seconds;
    const OutputMaps maps = mergeOutputs(s, m);
    mergeParameters(s, maps, m);
    // A parameter one branch discarded (an FK control with the switch at 1) is modelled if the other branch models it.
    std::set<std::string> modelled;
    for (const ModelledParameter& p : m.parameters) modelled.insert(p.parameter.name);
    for (const Approximation* a : {&ik, &fk})
        for (const DiscardedParameter& d : a->discarded)
            if (modelled.insert(d.parameter.name).second) m.discarded.push_back(d);
    const int firstWeight = static_cast<int>(m.parameters.size());
    for (std::size_t i = 0; i < s.weights.size(); ++i) {
        ModelledParameter weight;
        weight.parameter = s.weights[i];
        const auto blends = [&](const SwitchBranches::Switched& w) { return w.weight == static_cast<int>(i); };
        if (std::any_of(s.switched.begin(), s.switched.end(), blends)) weight.form = "blend weight";
        for (const SwitchBranches::Switched& w : unblended)
            if (blends(w)) weight.unmodelledOutputs.push_back(find(ik, w.output));
        std::sort(weight.unmodelledOutputs.begin(), weight.unmodelledOutputs.end());
        m.parameters.push_back(std::move(weight));
    }
    makeBlends(s, maps, firstWeight, m);
    return m;
}

}  // namespace rig
