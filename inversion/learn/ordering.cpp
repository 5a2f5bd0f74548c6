#include "inversion/learn/ordering.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <tuple>

#include <fmt/format.h>
#include <Eigen/LU>

namespace rig {
namespace {

enum class Relation { none, firstOuter, secondOuter, conflict };

struct Verdict {
    Relation relation = Relation::none;
    std::string detail;  // for a conflict: which outputs said what
    // Rig outputs where neither order holds, with the rig's distance from each product there (cm).
    std::vector<std::tuple<int, double, double>> neitherOutputs;
    double tolerance = 0.0;
};

// Position of output k among a classification's affected outputs (ascending), or -1.
int entryOf(const Classification& c, int k)
{
    const auto& outputs = c.model.outputs;
    const auto it = std::lower_bound(outputs.begin(), outputs.end(), k);
    return it != outputs.end() && *it == k ? static_cast<int>(it - outputs.begin()) : -1;
}

const Operator& operatorOn(const Classification& c, int entry)
{
    return c.model.operators[static_cast<std::size_t>(c.model.operatorOfOutput[static_cast<std::size_t>(entry)])];
}

// Whether the learned operators of two parameters commute on one output, at their order offsets and
// at half of them: rotations about one axis through one pivot, a translation along a rotation's own
// axis, and operators on disjoint parts of a product do. A tenth of the order tests' tolerance: pairs
// taken as commuting must not add up to an error over epsilon.
bool operatorsCommute(const Classification& p, int ep, const Classification& q, int eq, const Eigen::Matrix4d& rest,
                      const LearnOptions& options)
{
    const Operator& u = operatorOn(p, ep);
    const Operator& v = operatorOn(q, eq);
    const double a = p.orderOffset, b = q.orderOffset;
    const double tolerance = 0.1 * options.epsilon * (std::abs(a) + std::abs(b));
    for (const double scale : {1.0, 0.5}) {
        const Eigen::Matrix4d x = u.matrix(scale * a), y = v.matrix(scale * b);
        if (!(matrixError(x * y * rest, y * x * rest, options.frameRadius) <= scale * tolerance)) return false;
    }
    return true;
}

class PairTests {
public:
    PairTests(RigProbe& probe, const std::vector<Classification>& classes, const LearnOptions& options,
              const std::set<int>& distrusted, PairSamples& samples)
        : probe_(probe), classes_(classes), options_(options), distrusted_(distrusted), samples_(samples)
    {
    }

    // The talk's tests (1) and (2) for p and q on the outputs both affect (`everyPair`: on all of them,
    // after a rig evaluation even where they share none; otherwise only where their operators do not
    // commute, and without an evaluation when there is no such output). Votes that disagree (one
    // output needs p outer, another q outer) or an output where neither order holds are a conflict.
    Verdict test(int p, int q, bool everyPair)
    {
        const Classification& cp = classes_[static_cast<std::size_t>(p)];
        const Classification& cq = classes_[static_cast<std::size_t>(q)];
        const std::vector<Vote> voting = votingOutputs(cp, cq, everyPair);
        if (voting.empty() && !everyPair) return {};
        return verdictOf(cp, cq, voting, movedTogether(cp, cq, voting));
    }

    std::uint64_t evaluations() const { return evaluations_; }

private:
    using Vote = std::tuple<int, int, int>;  // output, entry in p, entry in q

    // The outputs both affect that vote: all of them with `everyPair`, else those where the operators do not
    // commute or the rig decides (distrusted outputs).
    std::vector<Vote> votingOutputs(const Classification& cp, const Classification& cq, bool everyPair) const
    {
        const auto& rest = probe_.rest();
        std::vector<Vote> voting;
        for (const int k : cp.model.outputs) {
            const int eq = entryOf(cq, k);
            if (eq < 0) continue;
            const int ep = entryOf(cp, k);
            if (everyPair || distrusted_.contains(k) ||
                !operatorsCommute(cp, ep, cq, eq, rest[static_cast<std::size_t>(k)], options_))
                voting.emplace_back(k, ep, eq);
        }
        return voting;
    }

    // The raw worlds of the pair moved together: from an earlier pass when it read these outputs
    // (and their parents) at the same offsets, else one rig evaluation.
    // (The talk's orderer evaluates every pair once, whether or not it reads an output.)
    const PairSamples::Pair& movedTogether(const Classification& cp, const Classification& cq,
                                           const std::vector<Vote>& voting)
    {
        const auto [entry, fresh] = samples_.worlds.try_emplace({cp.index, cq.index});
        auto& sample = entry->second;
        if (fresh || sample.offsets != std::pair(cp.orderOffset, cq.orderOffset))
            sample = {{cp.orderOffset, cq.orderOffset}, {}};
        const bool known = !fresh && std::all_of(voting.begin(), voting.end(), [&](const auto& v) {
            const int k = std::get<0>(v);
            const std::vector<int> inputs = probe_.frameInputs(k);
            return sample.worlds.contains(k) &&
                   std::all_of(inputs.begin(), inputs.end(), [&](int i) { return sample.worlds.contains(i); });
        });
        if (known) return sample;
        ++evaluations_;
        std::vector<double> values = probe_.defaults();
        values[static_cast<std::size_t>(cp.index)] += cp.orderOffset;
        values[static_cast<std::size_t>(cq.index)] += cq.orderOffset;
        const std::vector<Eigen::Matrix4d>& all = probe_.atValues(values);
        for (const auto& v : voting) {
            const int k = std::get<0>(v);
            sample.worlds[k] = all[static_cast<std::size_t>(k)];
            for (const int i : probe_.frameInputs(k)) sample.worlds[i] = all[static_cast<std::size_t>(i)];
        }
        return sample;
    }

    // Each voting output's vote: the pair moved together against the two products of their operators.
    Verdict verdictOf(const Classification& cp, const Classification& cq, const std::vector<Vote>& voting,
                      const PairSamples::Pair& sample) const
    {
        const auto& rest = probe_.rest();
        const double tolerance = options_.epsilon * (std::abs(cp.orderOffset) + std::abs(cq.orderOffset));
        const auto& names = probe_.rig().outputs();
        Verdict verdict;
        std::string firstAt, secondAt, neitherAt;
        double worstOne = 0.0, worstTwo = 0.0;
        for (const auto& [k, ep, eq] : voting) {
            const Eigen::Matrix4d& fa = cp.orderWorlds[static_cast<std::size_t>(ep)];
            const Eigen::Matrix4d& fb = cq.orderWorlds[static_cast<std::size_t>(eq)];
            const Eigen::Matrix4d restInverse = rest[static_cast<std::size_t>(k)].inverse();
            const Eigen::Matrix4d fab =
                probe_.inFrame(k, [&](int j) -> const Eigen::Matrix4d& { return sample.worlds.at(j); });
            const double one = matrixError(fab, fa * restInverse * fb, options_.frameRadius);
            const double two = matrixError(fab, fb * restInverse * fa, options_.frameRadius);
            const bool ok1 = one <= tolerance, ok2 = two <= tolerance;
            if (ok1 && ok2) continue;
            const std::string& name = names[static_cast<std::size_t>(k)];
            if (ok1 && firstAt.empty()) firstAt = name;
            if (ok2 && secondAt.empty()) secondAt = name;
            if (!ok1 && !ok2) {
                if (neitherAt.empty()) neitherAt = name;
                verdict.neitherOutputs.emplace_back(k, one, two);
                worstOne = std::max(worstOne, one);
                worstTwo = std::max(worstTwo, two);
            }
        }
        verdict.tolerance = tolerance;
        if (!neitherAt.empty()) {
            verdict.relation = Relation::conflict;
            verdict.detail = fmt::format("neither order holds on {} (errors {:.3g} and {:.3g} cm, tolerance {:.3g})",
                                         neitherAt, worstOne, worstTwo, tolerance);
        } else if (!firstAt.empty() && !secondAt.empty()) {
            verdict.relation = Relation::conflict;
            verdict.detail = fmt::format("the outputs disagree ({} needs one order, {} the other)", firstAt, secondAt);
        } else if (!firstAt.empty()) {
            verdict.relation = Relation::firstOuter;
        } else if (!secondAt.empty()) {
            verdict.relation = Relation::secondOuter;
        }
        return verdict;
    }

    RigProbe& probe_;
    const std::vector<Classification>& classes_;
    const LearnOptions& options_;
    const std::set<int>& distrusted_;
    PairSamples& samples_;
    std::uint64_t evaluations_ = 0;
};

const std::string& nameOf(const std::vector<Classification>& classes, int p)
{
    return classes[static_cast<std::size_t>(p)].model.parameter.name;
}

// Of two parameters, the one to discard: the smaller effect.
bool isScale(const std::vector<Classification>& classes, int p)
{
    return classes[static_cast<std::size_t>(p)].model.parameter.scale;
}

int smaller(const std::vector<Classification>& classes, int p, int q)
{
    return classes[static_cast<std::size_t>(p)].effect <= classes[static_cast<std::size_t>(q)].effect ? p : q;
}

// The pairs to test: every pair (talk), or the pairs that share an affected output (structured; the
// operator test then decides whether the rig is evaluated).
std::vector<std::pair<int, int>> candidatePairs(const std::vector<Classification>& classes,
                                                const std::vector<int>& modelled, bool everyPair)
{
    std::vector<std::pair<int, int>> pairs;
    if (everyPair) {
        for (std::size_t i = 0; i < modelled.size(); ++i)
            for (std::size_t j = i + 1; j < modelled.size(); ++j)
                pairs.emplace_back(std::min(modelled[i], modelled[j]), std::max(modelled[i], modelled[j]));
        std::sort(pairs.begin(), pairs.end());
        return pairs;
    }
    std::map<int, std::vector<int>> byOutput;
    for (const int p : modelled)
        for (const int k : classes[static_cast<std::size_t>(p)].model.outputs) byOutput[k].push_back(p);
    std::set<std::pair<int, int>> unique;
    for (const auto& [k, members] : byOutput)
        for (std::size_t i = 0; i < members.size(); ++i)
            for (std::size_t j = i + 1; j < members.size(); ++j)
                unique.emplace(std::min(members[i], members[j]), std::max(members[i], members[j]));
    return {unique.begin(), unique.end()};
}

// The parameters the pair tests leave and the order they found: next[p] holds the parameters p is outside of.
struct PairOrder {
    std::set<int> alive;
    std::map<int, std::set<int>> next;  // outer -> inner
};

// Every candidate pair tested; a pair that cannot be ordered costs the one with the smaller effect, noted in
// `result` with the outputs where neither order holds.
PairOrder testPairs(PairTests& tests, const std::vector<Classification>& classes, const std::vector<int>& modelled,
                    const LearnOptions& options, OrderResult& result)
{
    const bool everyPair = options.orderer == Orderer::talk;
    PairOrder order{{modelled.begin(), modelled.end()}, {}};
    const auto pairs = candidatePairs(classes, modelled, everyPair);
    std::size_t done = 0;
    for (const auto& [p, q] : pairs) {
        if (options.progress)
            options.progress("ordering", static_cast<double>(++done) / static_cast<double>(pairs.size()));
        if (!order.alive.contains(p) || !order.alive.contains(q)) continue;
        const Verdict v = tests.test(p, q, everyPair);
        if (v.relation == Relation::firstOuter) order.next[p].insert(q);
        if (v.relation == Relation::secondOuter) order.next[q].insert(p);
        if (v.relation != Relation::conflict) continue;
        const bool pScale = isScale(classes, p), qScale = isScale(classes, q);
        const int drop = pScale != qScale ? (pScale ? p : q) : smaller(classes, p, q), keep = drop == p ? q : p;
        if (isScale(classes, drop)) {
            // A scale channel gives way, whatever its effect, and sets no output apart (RigParameter::scale).
            result.held.emplace_back(
                drop, fmt::format("a scale channel that cannot be ordered with {}: {}; a joint target does not say how "
                                  "a control was scaled, so it is held at its rest value",
                                  nameOf(classes, keep), v.detail));
            order.alive.erase(drop);
            continue;
        }
        result.discards.emplace_back(
            drop,
            fmt::format("cannot be ordered with {}: {}; the one with the smaller effect was discarded, {} was kept",
                        nameOf(classes, keep), v.detail, nameOf(classes, keep)));
        for (const auto& [k, one, two] : v.neitherOutputs)
            result.conflictOutputs.try_emplace(
                k, fmt::format("{} and {} have neither order (the rig with both moved is {:.3g} and {:.3g} cm from "
                               "the two products of their operators, tolerance {:.3g} cm)",
                               nameOf(classes, p), nameOf(classes, q), one, two, v.tolerance));
        order.alive.erase(drop);
    }
    return order;
}

// Topological order (Kahn) of the parameters alive, ties by the widest reach first, then by name: the order
// does not depend on how the parameters were listed. Returns each parameter's predecessors left unplaced:
// all zero when the order is complete, otherwise the parameters left all lie on or after a cycle.
std::map<int, int> topologicalOrder(const PairOrder& order, const std::vector<Classification>& classes,
                                    std::vector<int>& sorted)
{
    auto key = [&](int p) {
        const Classification& c = classes[static_cast<std::size_t>(p)];
        return std::tuple(-c.reach, c.model.parameter.name, p);
    };
    std::map<int, int> indegree;
    for (const int p : order.alive) indegree[p] = 0;
    for (const auto& [from, tos] : order.next)
        if (order.alive.contains(from))
            for (const int to : tos)
                if (order.alive.contains(to)) ++indegree[to];
    std::set<std::tuple<int, std::string, int>> ready;
    for (const auto& [p, d] : indegree)
        if (d == 0) ready.insert(key(p));
    sorted.clear();
    while (!ready.empty()) {
        const int p = std::get<2>(*ready.begin());
        ready.erase(ready.begin());
        sorted.push_back(p);
        if (const auto inner = order.next.find(p); inner != order.next.end())
            for (const int q : inner->second)
                if (order.alive.contains(q) && --indegree[q] == 0) ready.insert(key(q));
    }
    return indegree;
}

// A cycle among the parameters left unplaced, outermost last: every one of them has a predecessor left, so
// walking back along them closes one.
std::vector<int> cycleLeft(const PairOrder& order, const std::map<int, int>& indegree)
{
    std::vector<int> walk;
    std::map<int, std::size_t> seenAt;
    int p = -1;
    for (const auto& [q, d] : indegree)
        if (d > 0) {
            p = q;
            break;
        }
    while (!seenAt.contains(p)) {
        seenAt[p] = walk.size();
        walk.push_back(p);
        for (const auto& [from, tos] : order.next)
            if (order.alive.contains(from) && indegree.at(from) > 0 && tos.contains(p)) {
                p = from;
                break;
            }
    }
    return {walk.begin() + static_cast<std::ptrdiff_t>(seenAt[p]), walk.end()};
}

// A cycle costs its member with the smallest effect.
void discardFromCycle(const std::vector<int>& cycle, const std::vector<Classification>& classes, PairOrder& order,
                      OrderResult& result)
{
    int drop = cycle.front();
    for (const int q : cycle) drop = smaller(classes, drop, q);
    std::string chain;
    for (auto it = cycle.rbegin(); it != cycle.rend(); ++it) chain += nameOf(classes, *it) + " before ";
    chain += nameOf(classes, cycle.back());
    result.discards.emplace_back(drop,
                                 fmt::format("its order tests form a cycle ({}); the one with the smallest effect "
                                             "was discarded",
                                             chain));
    order.alive.erase(drop);
}

}  // namespace

OrderResult orderParameters(RigProbe& probe, const std::vector<Classification>& classes,
                            const std::vector<int>& modelled, const LearnOptions& options, PairSamples& samples,
                            const std::set<int>& distrusted)
{
    PairTests tests(probe, classes, options, distrusted, samples);
    OrderResult result;
    PairOrder order = testPairs(tests, classes, modelled, options, result);
    while (true) {
        const std::map<int, int> indegree = topologicalOrder(order, classes, result.order);
        if (result.order.size() == order.alive.size()) break;
        discardFromCycle(cycleLeft(order, indegree), classes, order, result);
    }
    result.evaluations = tests.evaluations();
    return result;
}

}  // namespace rig
