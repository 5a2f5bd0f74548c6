#include "inversion/solve/switch_hold.h"

#include <set>
#include <utility>

namespace rig {

namespace {

// Whether parameter p moves a joint (an output not a helper) when the blends of `weight` read only one branch (`ik`:
// the IK branch, as at weight 1): what moves an output follows its frame inputs, a blend's other branch cut off.
bool movesJointAtBranch(const Approximation& a, int p, int weight, bool ik)
{
    std::vector<std::vector<int>> children(a.outputs.size());
    for (std::size_t k = 0; k < a.outputs.size(); ++k) {
        std::vector<int> inputs = a.frameInputs(static_cast<int>(k));
        if (const int c = a.outputs[k].constraint; c >= 0) {
            const ConstraintBase& b = a.constraints[static_cast<std::size_t>(c)];
            if (b.kind == ConstraintKind::blend && b.weight == weight)
                inputs =
                    ik ? std::vector<int>{b.anchor, b.ik, b.ikParent} : std::vector<int>{b.anchor, b.fk, b.fkParent};
        }
        for (const int i : inputs)
            if (i >= 0) children[static_cast<std::size_t>(i)].push_back(static_cast<int>(k));
    }
    std::vector<char> seen(a.outputs.size(), 0);
    std::vector<int> stack(a.parameters[static_cast<std::size_t>(p)].outputs);
    while (!stack.empty()) {
        const std::size_t k = static_cast<std::size_t>(stack.back());
        stack.pop_back();
        if (seen[k]) continue;
        seen[k] = 1;
        if (!a.outputs[k].helper) return true;
        stack.insert(stack.end(), children[k].begin(), children[k].end());
    }
    return false;
}

}  // namespace

std::vector<SwitchHold> switchHolds(const Approximation& approximation)
{
    std::vector<SwitchHold> holds;
    std::set<int> weights;
    for (const ConstraintBase& c : approximation.constraints)
        if (c.kind == ConstraintKind::blend) weights.insert(c.weight);
    const std::vector<std::vector<int>> reach = approximation.reach();
    for (const int w : weights) {
        SwitchHold hold{w, {}, {}, reach[static_cast<std::size_t>(w)]};
        for (std::size_t p = 0; p < approximation.parameters.size(); ++p) {
            const int q = static_cast<int>(p);
            if (q == w) continue;
            const bool atIk = movesJointAtBranch(approximation, q, w, true);
            const bool atFk = movesJointAtBranch(approximation, q, w, false);
            if (atFk && !atIk) hold.fk.push_back(q);
            if (atIk && !atFk) hold.ik.push_back(q);
        }
        if (!hold.fk.empty() || !hold.ik.empty()) holds.push_back(std::move(hold));
    }
    return holds;
}

}  // namespace rig
