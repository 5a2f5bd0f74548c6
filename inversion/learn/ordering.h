#pragma once
// Composition order (section 4 of the talk), right by construction (DESIGN: commuting is not an order).
// For parameters i and j, with F(ij) the rig with both moved, test (1) "i outer": F(ij) = D_i F(j), and
// test (2) "j outer": F(ij) = D_j F(i), on an output both affect (in its learning frame). Both hold:
// they commute there; one holds: that order; neither: they cannot be ordered there.
//
// A pair that commutes constrains nothing, and commutation is not transitive: the order is a
// topological order of the precedence graph whose edges are the non-commuting pairs' verdicts. A pair
// ordered both ways (on two outputs), a pair with neither order, or a cycle of the graph costs one
// parameter, the one with the smaller effect (a scale channel before any other: OrderResult::held); the others
// keep their edges. Internal to the learner.

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "inversion/learn/classifier.h"
#include "inversion/learn/learn_options.h"

namespace rig {

struct OrderResult {
    std::vector<int> order;                             // indices into the classifications, outermost first
    std::vector<std::pair<int, std::string>> discards;  // classification index, reason
    // Scale channels (RigParameter::scale) that gave way in a pair with neither order, whatever their effect, with
    // no output set apart for it: the learner holds them at rest from then on. Classification index, reason.
    std::vector<std::pair<int, std::string>> held;
    // Rig outputs where a pair had neither order, each with the first such pair and its errors (for the
    // reason an output is set apart, learner.h's UnmodelledOutput).
    std::map<int, std::string> conflictOutputs;
    std::uint64_t evaluations = 0;  // pairs the rig was evaluated for
};

// Raw rig worlds of pairs of parameters moved together at their order offsets, kept across learning
// passes: only the outputs a test read and their parents (a crowd must not keep every joint of every
// pair). Keyed by the pair's rig indices.
struct PairSamples {
    struct Pair {
        std::pair<double, double> offsets;
        std::map<int, Eigen::Matrix4d> worlds;  // rig output -> raw world
    };
    std::map<std::pair<int, int>, Pair> worlds;
};

// `modelled` lists the indices (into `classes`) of the parameters to order.
//   talk:       every pair is tested on the rig (the reference: the talk knows no structure).
//   structured: only pairs that share an output where their learned operators do not commute (decided
//               from the operators, without a rig evaluation), and every pair sharing an output of
//               `distrusted` (rig outputs where that decision failed the validation: the rig decides there).
OrderResult orderParameters(RigProbe& probe, const std::vector<Classification>& classes,
                            const std::vector<int>& modelled, const LearnOptions& options, PairSamples& samples,
                            const std::set<int>& distrusted = {});

}  // namespace rig
