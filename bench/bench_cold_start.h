#pragma once
// rig-bench's cold-start row: random in-range poses of an approximation, each solved from the rest values
// with Solver::initialGuess and without, as rig-invert's restart frames are (docs/solver.md, Cold starts).

#include "bench/bench_common.h"
#include "inversion/model/approximation.h"

namespace rig::bench {

// `poses` random poses (uniform within each parameter's limits, a fixed seed), targets on every output at
// the approximation's own worlds (reachable exactly). JSON: poses, recovered_from_guess, recovered_from_rest
// (every joint within 1e-4 cm, rotations through the solver's rotationScaleCm), their rates, and the CPU
// time of one guess and of one solve from it, ms.
Json coldStartJson(const Approximation& approximation, int poses);

}  // namespace rig::bench
