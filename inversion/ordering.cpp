#include "inversion/ordering.h"

#include <algorithm>
#include <map>
#include <set>

#include <Eigen/LU>
#include <fmt/format.h>

namespace rig {
namespace {

enum class Relation { firstOuter, secondOuter, commute, conflict };

struct Verdict {
    Relation relation = Relation::commute;
    std::string detail;  // for a conflict: which outputs said what
};

// The talk's tests (1) and (2) for two sets of moved parameters A and B, decided by voting over the
// outputs both affect: an output where both orders hold says nothing (they commute there); one where
// only (1) holds votes "A outer", only (2) "B outer", neither "neither". Unanimous votes decide; votes
// that disagree (a "neither" disagrees with both orders), or only "neither", are a conflict: on some
// output the order chosen would be wrong.
// The world matrices are those of the common outputs, in the order of `common`.
Verdict vote(const std::vector<int>& common, const std::vector<Eigen::Matrix4d>& rest, const std::vector<Eigen::Matrix4d>& fa,
             const std::vector<Eigen::Matrix4d>& fb, const std::vector<Eigen::Matrix4d>& fab, double tolerance,
             const std::vector<std::string>& outputNames, double frameRadius)
{
    int first = 0, second = 0, neither = 0;
    std::string firstAt, secondAt, neitherAt;
    double worstOne = 0.0, worstTwo = 0.0;
    for (std::size_t i = 0; i < common.size(); ++i) {
        const auto u = static_cast<std::size_t>(common[i]);
        const Eigen::Matrix4d restInverse = rest[i].inverse();
        const double one = matrixError(fab[i], fa[i] * restInverse * fb[i], frameRadius);
        const double two = matrixError(fab[i], fb[i] * restInverse * fa[i], frameRadius);
        const bool ok1 = one <= tolerance, ok2 = two <= tolerance;
        if (ok1 && ok2) continue;
        if (ok1) {
            if (first++ == 0) firstAt = outputNames[u];
        }
        else if (ok2) {
            if (second++ == 0) secondAt = outputNames[u];
        }
        else if (neither++ == 0) {
            neitherAt = outputNames[u];
            worstOne = one;
            worstTwo = two;
        }
    }
    if (neither > 0)
        return {Relation::conflict,
                fmt::format("neither composition order holds on {} (the talk's tests (1) and (2) miss by {:.3g} and {:.3g} cm){}",
                            neitherAt, worstOne, worstTwo,
                            first + second > 0 ? fmt::format(", though one does on {}", first > 0 ? firstAt : secondAt) : "")};
    if (first > 0 && second > 0)
        return {Relation::conflict, fmt::format("the outputs disagree ({} needs one order, {} the other)", firstAt, secondAt)};
    if (first > 0) return {Relation::firstOuter, {}};
    if (second > 0) return {Relation::secondOuter, {}};
    return {Relation::commute, {}};
}

// Pairwise and group tests with caches; counts the rig evaluations they cost.
class Tester {
public:
    Tester(RigProbe& probe, const std::vector<Eigen::Matrix4d>& rest, const std::vector<Classification>& classes,
           const LearnOptions& options)
        : probe_(probe), rest_(rest), classes_(classes), options_(options)
    {
    }

    // The relation of i to j. `knowsStructure`: pairs with no output in common commute without an
    // evaluation (the talk's orderer evaluates them all the same).
    Verdict test(int i, int j, bool knowsStructure)
    {
        const auto key = std::minmax(i, j);
        auto it = pairs_.find(key);
        if (it == pairs_.end()) {
            const std::vector<int> common = commonOutputs({key.first}, {key.second});
            Verdict v;
            if (!common.empty() || !knowsStructure) v = compare({key.first}, {key.second}, common);
            it = pairs_.emplace(key, v).first;
        }
        Verdict v = it->second;
        if (i != key.first) v.relation = flipped(v.relation);
        return v;
    }

    // Every parameter of `a` moved together against every parameter of `b` moved together, on the
    // outputs both sets affect.
    Verdict testGroups(const std::vector<int>& a, const std::vector<int>& b)
    {
        return compare(a, b, commonOutputs(a, b));
    }

    std::uint64_t evaluations() const { return evaluations_; }

    static Relation flipped(Relation r)
    {
        return r == Relation::firstOuter ? Relation::secondOuter : r == Relation::secondOuter ? Relation::firstOuter : r;
    }

private:
    std::vector<int> outputsOf(const std::vector<int>& members) const
    {
        std::set<int> outputs;
        for (int p : members)
            for (int k : classes_[static_cast<std::size_t>(p)].model.outputs) outputs.insert(k);
        return {outputs.begin(), outputs.end()};
    }

    std::vector<int> commonOutputs(const std::vector<int>& a, const std::vector<int>& b) const
    {
        const std::vector<int> oa = outputsOf(a), ob = outputsOf(b);
        std::vector<int> common;
        std::set_intersection(oa.begin(), oa.end(), ob.begin(), ob.end(), std::back_inserter(common));
        return common;
    }

    std::vector<double> valuesWith(const std::vector<int>& moved) const
    {
        std::vector<double> values = probe_.defaults();
        for (int p : moved) {
            const Classification& c = classes_[static_cast<std::size_t>(p)];
            values[static_cast<std::size_t>(c.index)] += c.orderOffset;
        }
        return values;
    }

    // F with these parameters at their order offsets, kept for the outputs they affect only: a crowd's
    // thousands of group tests must not each keep every joint. One parameter alone was sampled there
    // while classifying: its worlds are rebuilt without an evaluation.
    struct Moved {
        std::vector<int> outputs;  // ascending
        std::vector<Eigen::Matrix4d> worlds;

        const Eigen::Matrix4d& at(int k) const
        {
            const auto it = std::lower_bound(outputs.begin(), outputs.end(), k);
            return worlds[static_cast<std::size_t>(it - outputs.begin())];
        }
    };

    const Moved& worldsOf(const std::vector<int>& members)
    {
        auto it = moved_.find(members);
        if (it != moved_.end()) return it->second;
        Moved m;
        if (members.size() == 1) {
            // Classification lists a parameter's outputs in ascending order, with their worlds.
            const Classification& c = classes_[static_cast<std::size_t>(members.front())];
            m.outputs = c.model.outputs;
            m.worlds = c.orderWorlds;
        }
        else {
            m.outputs = outputsOf(members);
            ++evaluations_;
            const std::vector<Eigen::Matrix4d>& worlds = probe_.atValues(valuesWith(members));
            for (int k : m.outputs) m.worlds.push_back(worlds[static_cast<std::size_t>(k)]);
        }
        return moved_.emplace(members, std::move(m)).first->second;
    }

    Verdict compare(const std::vector<int>& a, const std::vector<int>& b, const std::vector<int>& common)
    {
        // References stay valid: std::map does not move its elements when it grows.
        const Moved& ma = worldsOf(a);
        const Moved& mb = worldsOf(b);
        std::vector<int> both = a;
        both.insert(both.end(), b.begin(), b.end());
        ++evaluations_;
        const std::vector<Eigen::Matrix4d>& all = probe_.atValues(valuesWith(both));
        std::vector<Eigen::Matrix4d> rest, fa, fb, fab;
        for (int k : common) {
            rest.push_back(rest_[static_cast<std::size_t>(k)]);
            fa.push_back(ma.at(k));
            fb.push_back(mb.at(k));
            fab.push_back(all[static_cast<std::size_t>(k)]);
        }
        double offsets = 0.0;
        for (int p : both) offsets += std::abs(classes_[static_cast<std::size_t>(p)].orderOffset);
        return vote(common, rest, fa, fb, fab, options_.epsilon * offsets, probe_.rig().outputs(), options_.frameRadius);
    }

    RigProbe& probe_;
    const std::vector<Eigen::Matrix4d>& rest_;
    const std::vector<Classification>& classes_;
    const LearnOptions& options_;
    std::map<std::pair<int, int>, Verdict> pairs_;
    std::map<std::vector<int>, Moved> moved_;
    std::uint64_t evaluations_ = 0;
};

const std::string& nameOf(const std::vector<Classification>& classes, int p)
{
    return classes[static_cast<std::size_t>(p)].model.parameter.name;
}

// A pair that cannot be ordered loses only one of its two parameters (the talk discards both): the
// one with the smaller effect. The other stays, and is judged again by its own later tests.
int resolveConflict(int p, int q, const Verdict& verdict, const std::vector<Classification>& classes, OrderResult& result)
{
    const bool dropP = classes[static_cast<std::size_t>(p)].effect <= classes[static_cast<std::size_t>(q)].effect;
    const int drop = dropP ? p : q, keep = dropP ? q : p;
    result.discards.emplace_back(
        drop, fmt::format("cannot be ordered with {}: {}; the one with the smaller effect was discarded, {} was kept",
                          nameOf(classes, keep), verdict.detail, nameOf(classes, keep)));
    return drop;
}

// Inserts p into `sorted` by binary search (the talk's modified binary search: a commuting pair is
// passed on the right). Returns false when p was discarded.
bool insertTalk(std::vector<int>& sorted, int p, Tester& tester, const std::vector<Classification>& classes,
                OrderResult& result, bool knowsStructure)
{
    std::size_t lo = 0, hi = sorted.size();
    while (lo < hi) {
        const std::size_t mid = (lo + hi) / 2;
        const int q = sorted[mid];
        const Verdict v = tester.test(q, p, knowsStructure);
        if (v.relation == Relation::conflict) {
            if (resolveConflict(p, q, v, classes, result) == p) return false;
            sorted.erase(sorted.begin() + static_cast<std::ptrdiff_t>(mid));
            lo = 0;
            hi = sorted.size();
            continue;
        }
        if (v.relation == Relation::secondOuter) hi = mid;
        else lo = mid + 1;
    }
    sorted.insert(sorted.begin() + static_cast<std::ptrdiff_t>(lo), p);
    return true;
}

OrderResult orderTalk(RigProbe& probe, const std::vector<Eigen::Matrix4d>& rest, const std::vector<Classification>& classes,
                      const std::vector<int>& modelled, const LearnOptions& options)
{
    Tester tester(probe, rest, classes, options);
    OrderResult result;
    for (std::size_t n = 0; n < modelled.size(); ++n) {
        insertTalk(result.order, modelled[n], tester, classes, result, false);
        if (options.progress) options.progress("ordering", static_cast<double>(n + 1) / static_cast<double>(modelled.size()));
    }
    result.evaluations = tester.evaluations();
    return result;
}

// The structure-aware orderer. Parameters with the same affected outputs form a group, ordered inside
// by the talk's insertion. Between groups only neighbours are compared: for each output, the groups
// affecting it sorted from the widest set to the narrowest (a parent before its children). A pair of
// neighbouring groups is tested as a whole, every member of each moved at once, with one evaluation;
// only when that test does not give a clear order are its member pairs tested one by one (which finds
// the pair that conflicts). Groups that share no output are never compared. The parameters are then
// sorted topologically, ties by the widest set first.
OrderResult orderStructured(RigProbe& probe, const std::vector<Eigen::Matrix4d>& rest,
                            const std::vector<Classification>& classes, const std::vector<int>& modelled,
                            const LearnOptions& options)
{
    Tester tester(probe, rest, classes, options);
    OrderResult result;
    std::set<int> discarded;
    auto outputsOf = [&](int p) -> const std::vector<int>& { return classes[static_cast<std::size_t>(p)].model.outputs; };

    std::map<std::vector<int>, std::vector<int>> bySet;
    for (int p : modelled) bySet[outputsOf(p)].push_back(p);
    struct Group {
        std::vector<int> outputs;
        std::vector<int> members;  // ordered, outermost first
    };
    std::vector<Group> groups;
    for (auto& [outputs, members] : bySet) {
        Group g{outputs, {}};
        for (int p : members)
            if (!insertTalk(g.members, p, tester, classes, result, true)) discarded.insert(p);
        groups.push_back(std::move(g));
    }
    auto prune = [&] {
        for (const auto& d : result.discards) discarded.insert(d.first);
        for (auto& g : groups) std::erase_if(g.members, [&](int p) { return discarded.contains(p); });
    };
    prune();
    // The order groups are listed in along every output: widest set first, then rig order.
    auto before = [&](std::size_t a, std::size_t b) {
        const auto sa = groups[a].outputs.size(), sb = groups[b].outputs.size();
        return sa != sb ? sa > sb : groups[a].outputs < groups[b].outputs;
    };

    std::set<std::pair<std::size_t, std::size_t>> neighbours;  // (outer candidate, inner candidate)
    std::map<int, std::vector<std::size_t>> groupsOfOutput;
    for (std::size_t g = 0; g < groups.size(); ++g)
        for (int k : groups[g].outputs) groupsOfOutput[k].push_back(g);
    for (auto& [k, list] : groupsOfOutput) {
        std::sort(list.begin(), list.end(), before);
        for (std::size_t n = 1; n < list.size(); ++n) neighbours.emplace(list[n - 1], list[n]);
    }

    std::set<std::pair<int, int>> edges;  // outer parameter -> inner parameter
    std::size_t done = 0;
    for (const auto& [wide, narrow] : neighbours) {
        if (options.progress) options.progress("ordering", static_cast<double>(++done) / static_cast<double>(neighbours.size()));
        prune();
        const std::vector<int> w = groups[wide].members, n = groups[narrow].members;
        if (w.empty() || n.empty()) continue;
        const Verdict whole = tester.testGroups(w, n);
        if (whole.relation != Relation::conflict) {
            const bool narrowOuter = whole.relation == Relation::secondOuter;
            for (int a : w)
                for (int b : n) edges.insert(narrowOuter ? std::pair(b, a) : std::pair(a, b));
            continue;
        }
        // No clear order as a whole: find which members conflict and how the others are ordered.
        for (int a : w) {
            if (discarded.contains(a)) continue;
            for (int b : n) {
                if (discarded.contains(b)) continue;
                const Verdict v = tester.test(a, b, true);
                if (v.relation == Relation::firstOuter) edges.emplace(a, b);
                else if (v.relation == Relation::secondOuter) edges.emplace(b, a);
                else if (v.relation == Relation::conflict) {
                    discarded.insert(resolveConflict(a, b, v, classes, result));
                    if (discarded.contains(a)) break;
                }
            }
        }
        prune();
    }
    prune();

    // Topological sort of the parameters (Kahn): the groups' inner orders as chains, and the edges.
    std::map<int, std::pair<std::size_t, std::size_t>> rank;  // parameter -> (group rank, position)
    std::vector<std::size_t> byRank(groups.size());
    for (std::size_t g = 0; g < groups.size(); ++g) byRank[g] = g;
    std::sort(byRank.begin(), byRank.end(), before);
    for (std::size_t r = 0; r < byRank.size(); ++r) {
        const Group& g = groups[byRank[r]];
        for (std::size_t m = 0; m < g.members.size(); ++m) {
            rank[g.members[m]] = {r, m};
            if (m > 0) edges.emplace(g.members[m - 1], g.members[m]);
        }
    }
    std::map<int, int> indegree;
    std::map<int, std::vector<int>> next;
    for (const auto& [p, r] : rank) indegree[p] = 0;
    for (const auto& [from, to] : edges) {
        if (!rank.contains(from) || !rank.contains(to)) continue;  // discarded since
        next[from].push_back(to);
        ++indegree[to];
    }
    std::set<std::pair<std::pair<std::size_t, std::size_t>, int>> ready;
    for (const auto& [p, d] : indegree)
        if (d == 0) ready.emplace(rank[p], p);
    while (!ready.empty()) {
        const int p = ready.begin()->second;
        ready.erase(ready.begin());
        result.order.push_back(p);
        for (int q : next[p])
            if (--indegree[q] == 0) ready.emplace(rank[q], q);
    }
    if (result.order.size() != rank.size()) {
        // Inconsistent tests (a cycle): fall back to the talk's orderer on what is left.
        std::vector<int> left;
        for (const auto& [p, r] : rank) left.push_back(p);
        OrderResult fallback = orderTalk(probe, rest, classes, left, options);
        fallback.discards.insert(fallback.discards.begin(), result.discards.begin(), result.discards.end());
        fallback.evaluations += tester.evaluations();
        fallback.note = "the structured tests were not consistent (a cycle); the talk's orderer was used";
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
