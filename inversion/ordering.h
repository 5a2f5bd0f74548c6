#pragma once
// Composition order (section 4 of the talk). For parameters i and j, with F(ij) the rig with both
// moved, test (1) "i outer": F(ij) = D_i F(j), and test (2) "j outer": F(ij) = D_j F(i), on the
// outputs both affect. Both hold: they commute; one holds: that order; neither: they cannot be
// ordered, and the one with the smaller effect is discarded (then, if still needed, the other).
// Internal to the learner.

#include <cstdint>
#include <string>
#include <vector>

#include "inversion/classifier.h"
#include "inversion/learner.h"

namespace rig {

struct OrderResult {
    std::vector<int> order;                             // indices into the classifications, outermost first
    std::vector<std::pair<int, std::string>> discards;  // classification index, reason
    std::uint64_t evaluations = 0;
    std::string note;                                   // e.g. a fallback taken
};

// `modelled` lists the indices (into `classes`) of the parameters to order, in rig order.
// `rest` holds the outputs' rest world matrices.
OrderResult orderParameters(RigProbe& probe, const std::vector<Eigen::Matrix4d>& rest,
                            const std::vector<Classification>& classes, const std::vector<int>& modelled,
                            const LearnOptions& options);

}  // namespace rig
