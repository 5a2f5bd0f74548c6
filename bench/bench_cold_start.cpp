#include "bench/bench_cold_start.h"

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "inversion/solve/solver.h"

namespace rig::bench {

Json coldStartJson(const Approximation& approximation, int poses)
{
    const Solver solver(approximation, SolverOptions{});
    const double scale = solver.options().rotationScaleCm;
    constexpr double recovered = 1e-4;  // cm
    const auto reached = [&](const SolveSummary& s) {
        return s.maxPositionErrorCm <= recovered &&
               scale * s.maxRotationErrorDeg * std::numbers::pi / 180.0 <= recovered;
    };
    std::mt19937 rng(20261125);
    int fromGuess = 0, fromRest = 0;
    double guessSeconds = 0.0, solveSeconds = 0.0;
    std::vector<double> known(approximation.parameters.size()), values;
    std::vector<Eigen::Matrix4d> worlds;
    std::vector<JointTarget> targets(approximation.outputs.size());
    for (int pose = 0; pose < poses; ++pose) {
        for (std::size_t p = 0; p < known.size(); ++p) {
            const RigParameter& parameter = approximation.parameters[p].parameter;
            known[p] = std::uniform_real_distribution<double>(parameter.min, parameter.max)(rng);
        }
        approximation.evaluate(known, worlds);
        for (std::size_t k = 0; k < targets.size(); ++k) targets[k] = {true, worlds[k], 1.0, 1.0};
        values = approximation.defaults();
        const double start = threadCpuSeconds();
        solver.initialGuess(targets, values);
        const double guessed = threadCpuSeconds();
        fromGuess += reached(solver.solve(targets, values));
        solveSeconds += threadCpuSeconds() - guessed;
        guessSeconds += guessed - start;
        values = approximation.defaults();
        fromRest += reached(solver.solve(targets, values));
    }
    const double n = std::max(poses, 1);
    return Json{{"poses", poses},
                {"recovered_from_guess", fromGuess},
                {"recovered_from_rest", fromRest},
                {"rate_from_guess", fromGuess / n},
                {"rate_from_rest", fromRest / n},
                {"guess_ms", 1000.0 * guessSeconds / n},
                {"solve_after_guess_ms", 1000.0 * solveSeconds / n},
                {"note",
                 "random poses within the limits, targets on every output at the approximation's worlds; "
                 "recovered: every joint within 1e-4 cm; 1 thread, CPU time"}};
}

}  // namespace rig::bench
