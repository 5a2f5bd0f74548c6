#include "inversion/ordering.h"

#include <algorithm>
#include <map>
#include <set>

#include <Eigen/LU>
#include <fmt/format.h>

namespace rig {
namespace {

enum class Relation { firstOuter, secondOuter, commute, conflict };

// Pairwise tests with a cache; counts the rig evaluations they cost.
class PairTester {
public:
    PairTester(RigProbe& probe, const std::vector<Eigen::Matrix4d>& rest, const std::vector<Classification>& classes,
               const LearnOptions& options)
        : probe_(probe), rest_(rest), classes_(classes), options_(options)
    {
    }

    // The relation of i to j. `knowsStructure`: pairs with no output in common commute without an
    // evaluation (the talk's orderer evaluates them all the same).
    Relation test(int i, int j, bool knowsStructure)
    {
        const auto key = std::minmax(i, j);
        auto it = cache_.find(key);
        if (it == cache_.end()) it = cache_.emplace(key, compute(key.first, key.second, knowsStructure)).first;
        const Relation r = it->second;
        if (i == key.first || r == Relation::commute || r == Relation::conflict) return r;
        return r == Relation::firstOuter ? Relation::secondOuter : Relation::firstOuter;
    }

    std::uint64_t evaluations() const { return evaluations_; }

private:
    Relation compute(int i, int j, bool knowsStructure)
    {
        const Classification& ci = classes_[static_cast<std::size_t>(i)];
        const Classification& cj = classes_[static_cast<std::size_t>(j)];
        std::vector<std::pair<std::size_t, std::size_t>> common;  // entries in ci and cj
        for (std::size_t a = 0, b = 0; a < ci.model.outputs.size() && b < cj.model.outputs.size();) {
            if (ci.model.outputs[a] < cj.model.outputs[b]) ++a;
            else if (ci.model.outputs[a] > cj.model.outputs[b]) ++b;
            else common.emplace_back(a++, b++);
        }
        if (common.empty() && knowsStructure) return Relation::commute;
        ++evaluations_;
        const std::vector<Eigen::Matrix4d> both = probe_.at(ci.index, ci.orderOffset, cj.index, cj.orderOffset);
        const double tolerance = options_.epsilon * (std::abs(ci.orderOffset) + std::abs(cj.orderOffset));
        double outerI = 0.0, outerJ = 0.0;
        for (const auto& [a, b] : common) {
            const int k = ci.model.outputs[a];
            const Eigen::Matrix4d restInverse = rest_[static_cast<std::size_t>(k)].inverse();
            const Eigen::Matrix4d di = ci.orderWorlds[a] * restInverse;
            const Eigen::Matrix4d dj = cj.orderWorlds[b] * restInverse;
            const Eigen::Matrix4d& fij = both[static_cast<std::size_t>(k)];
            outerI = std::max(outerI, matrixError(fij, di * cj.orderWorlds[b], options_.frameRadius));
            outerJ = std::max(outerJ, matrixError(fij, dj * ci.orderWorlds[a], options_.frameRadius));
        }
        const bool one = outerI <= tolerance;
        const bool two = outerJ <= tolerance;
        return one && two ? Relation::commute : one ? Relation::firstOuter : two ? Relation::secondOuter : Relation::conflict;
    }

    RigProbe& probe_;
    const std::vector<Eigen::Matrix4d>& rest_;
    const std::vector<Classification>& classes_;
    const LearnOptions& options_;
    std::map<std::pair<int, int>, Relation> cache_;
    std::uint64_t evaluations_ = 0;
};

std::string conflictReason(const Classification& kept)
{
    return fmt::format("cannot be ordered with {}: neither composition order holds (the talk's tests (1) and (2) both "
                       "fail), and it has the smaller effect of the two",
                       kept.model.parameter.name);
}

// Inserts p into `sorted` by binary search (the talk's modified binary search: a commuting pair is
// passed on the right). Returns false when p was discarded.
bool insertTalk(std::vector<int>& sorted, int p, PairTester& tester, const std::vector<Classification>& classes,
                OrderResult& result, bool knowsStructure)
{
    std::size_t lo = 0, hi = sorted.size();
    while (lo < hi) {
        const std::size_t mid = (lo + hi) / 2;
        const int q = sorted[mid];
        const Relation r = tester.test(q, p, knowsStructure);
        if (r == Relation::conflict) {
            // Try discarding only one of the two: the one with the smaller effect.
            if (classes[static_cast<std::size_t>(p)].effect <= classes[static_cast<std::size_t>(q)].effect) {
                result.discards.emplace_back(p, conflictReason(classes[static_cast<std::size_t>(q)]));
                return false;
            }
            result.discards.emplace_back(q, conflictReason(classes[static_cast<std::size_t>(p)]));
            sorted.erase(sorted.begin() + static_cast<std::ptrdiff_t>(mid));
            lo = 0;
            hi = sorted.size();
            continue;
        }
        if (r == Relation::secondOuter) hi = mid;
        else lo = mid + 1;
    }
    sorted.insert(sorted.begin() + static_cast<std::ptrdiff_t>(lo), p);
    return true;
}

OrderResult orderTalk(RigProbe& probe, const std::vector<Eigen::Matrix4d>& rest, const std::vector<Classification>& classes,
                      const std::vector<int>& modelled, const LearnOptions& options)
{
    PairTester tester(probe, rest, classes, options);
    OrderResult result;
    for (std::size_t n = 0; n < modelled.size(); ++n) {
        insertTalk(result.order, modelled[n], tester, classes, result, false);
        if (options.progress) options.progress("ordering", static_cast<double>(n + 1) / static_cast<double>(modelled.size()));
    }
    result.evaluations = tester.evaluations();
    return result;
}

bool includes(const std::vector<int>& big, const std::vector<int>& small)
{
    return std::includes(big.begin(), big.end(), small.begin(), small.end());
}

// Groups parameters with the same affected outputs, orders inside groups by tests, and between groups
// tests only neighbours: for each output, the groups affecting it sorted from the widest set to the
// narrowest; a wider set that contains a narrower one is presumed outer (a parent over a child) and
// that is checked with one test, and partial overlaps are tested. Groups that share no output are never
// compared. The groups are then sorted topologically.
OrderResult orderStructured(RigProbe& probe, const std::vector<Eigen::Matrix4d>& rest,
                            const std::vector<Classification>& classes, const std::vector<int>& modelled,
                            const LearnOptions& options)
{
    PairTester tester(probe, rest, classes, options);
    OrderResult result;
    std::map<std::vector<int>, std::vector<int>> bySet;
    for (int p : modelled) bySet[classes[static_cast<std::size_t>(p)].model.outputs].push_back(p);
    struct Group {
        std::vector<int> outputs;
        std::vector<int> members;  // ordered, outermost first
    };
    std::vector<Group> groups;
    std::set<int> discarded;
    for (auto& [outputs, members] : bySet) {
        Group g{outputs, {}};
        for (int p : members)
            if (!insertTalk(g.members, p, tester, classes, result, true)) discarded.insert(p);
        if (!g.members.empty()) groups.push_back(std::move(g));
    }
    for (const auto& d : result.discards) discarded.insert(d.first);
    for (auto& g : groups)
        std::erase_if(g.members, [&](int p) { return discarded.contains(p); });
    std::erase_if(groups, [](const Group& g) { return g.members.empty(); });

    // Neighbouring groups per output, widest first.
    std::map<int, std::vector<std::size_t>> groupsOfOutput;
    for (std::size_t g = 0; g < groups.size(); ++g)
        for (int k : groups[g].outputs) groupsOfOutput[k].push_back(g);
    std::set<std::pair<std::size_t, std::size_t>> edges;  // outer group -> inner group
    std::set<std::pair<std::size_t, std::size_t>> checked;
    std::size_t done = 0;
    for (auto& [k, list] : groupsOfOutput) {
        std::sort(list.begin(), list.end(), [&](std::size_t a, std::size_t b) {
            const auto sa = groups[a].outputs.size(), sb = groups[b].outputs.size();
            return sa != sb ? sa > sb : groups[a].members.front() < groups[b].members.front();
        });
        for (std::size_t n = 1; n < list.size(); ++n) {
            const std::size_t wide = list[n - 1], narrow = list[n];
            if (!checked.insert(std::minmax(wide, narrow)).second) continue;
            const int a = groups[wide].members.back();    // innermost of the wider group
            const int b = groups[narrow].members.front();  // outermost of the narrower group
            const Relation r = tester.test(a, b, true);
            if (r == Relation::firstOuter || (r == Relation::commute && includes(groups[wide].outputs, groups[narrow].outputs)))
                edges.emplace(wide, narrow);
            else if (r == Relation::secondOuter) edges.emplace(narrow, wide);
            else if (r == Relation::conflict) {
                const bool dropA = classes[static_cast<std::size_t>(a)].effect <= classes[static_cast<std::size_t>(b)].effect;
                const int drop = dropA ? a : b;
                result.discards.emplace_back(drop, conflictReason(classes[static_cast<std::size_t>(dropA ? b : a)]));
                std::erase(groups[dropA ? wide : narrow].members, drop);
            }
        }
        if (options.progress) options.progress("ordering", static_cast<double>(++done) / static_cast<double>(groupsOfOutput.size()));
    }

    // Topological sort of the groups (Kahn), ties by the first member's rig order.
    std::vector<int> indegree(groups.size(), 0);
    std::vector<std::vector<std::size_t>> next(groups.size());
    for (const auto& [from, to] : edges) {
        next[from].push_back(to);
        ++indegree[to];
    }
    auto firstMember = [&](std::size_t g) { return groups[g].members.empty() ? -1 : groups[g].members.front(); };
    std::set<std::pair<int, std::size_t>> ready;
    for (std::size_t g = 0; g < groups.size(); ++g)
        if (indegree[g] == 0) ready.emplace(firstMember(g), g);
    std::size_t emitted = 0;
    while (!ready.empty()) {
        const std::size_t g = ready.begin()->second;
        ready.erase(ready.begin());
        ++emitted;
        result.order.insert(result.order.end(), groups[g].members.begin(), groups[g].members.end());
        for (std::size_t n : next[g])
            if (--indegree[n] == 0) ready.emplace(firstMember(n), n);
    }
    if (emitted != groups.size()) {
        // Inconsistent tests (a cycle among groups): fall back to the talk's orderer on what is left.
        std::vector<int> left;
        for (const auto& g : groups) left.insert(left.end(), g.members.begin(), g.members.end());
        std::sort(left.begin(), left.end());
        OrderResult fallback = orderTalk(probe, rest, classes, left, options);
        fallback.discards.insert(fallback.discards.begin(), result.discards.begin(), result.discards.end());
        fallback.evaluations += tester.evaluations();
        fallback.note = "the structured tests were not consistent (a cycle among groups); the talk's orderer was used";
        return fallback;
    }
    result.evaluations = tester.evaluations();
    return result;
}

}  // namespace

OrderResult orderParameters(RigProbe& probe, const std::vector<Eigen::Matrix4d>& rest,
                            const std::vector<Classification>& classes, const std::vector<int>& modelled,
                            const LearnOptions& options)
{
    return options.orderer == Orderer::talk ? orderTalk(probe, rest, classes, modelled, options)
                                            : orderStructured(probe, rest, classes, modelled, options);
}

}  // namespace rig
