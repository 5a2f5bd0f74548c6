// libFuzzer target: approximation files from arbitrary bytes. approximationFromYaml must either return an
// approximation or throw rig::Error (one line, file:line:col: field: problem); what loads must
// write back with approximationToYaml and read back to the same text, evaluate at its defaults and limits,
// and go through a few solver iterations toward one of its own poses. Anything else (another exception,
// a crash, a sanitizer report, a timeout, memory past the limit) is a bug. scripts/fuzz.sh runs it;
// docs/robustness.md.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "inversion/model/approximation_io.h"
#include "inversion/solve/solver.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    rig::Approximation approximation;
    try {
        approximation = rig::approximationFromYaml(text, "fuzz.yaml");
    }
    catch (const rig::Error&) {
        return 0;
    }
    // Whatever the loader accepts, the writer writes and the loader reads back bit for bit.
    const std::string written = rig::approximationToYaml(approximation);
    if (rig::approximationToYaml(rig::approximationFromYaml(written, "fuzz.yaml")) != written) __builtin_trap();

    std::vector<Eigen::Matrix4d> worlds;
    std::vector<double> values = approximation.defaults();
    approximation.evaluate(values, worlds);
    for (std::size_t i = 0; i < values.size(); ++i) values[i] = approximation.parameters[i].parameter.min;
    approximation.evaluate(values, worlds);
    for (std::size_t i = 0; i < values.size(); ++i) values[i] = approximation.parameters[i].parameter.max;
    approximation.evaluate(values, worlds);
    if (approximation.parameters.empty()) return 0;

    // From the defaults toward the pose at the upper limits: a few iterations, serially.
    rig::SolverOptions options;
    options.threads = 1;
    options.maxIterations = 8;
    const rig::Solver solver(approximation, options);
    std::vector<rig::JointTarget> targets(approximation.outputs.size());
    for (std::size_t k = 0; k < targets.size(); ++k) {
        targets[k].active = true;
        targets[k].world = worlds[k];
    }
    values = approximation.defaults();
    (void)solver.solve(targets, values);
    return 0;
}
