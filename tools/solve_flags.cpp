#include "tools/solve_flags.h"

#include "tools/cli_common.h"

namespace rig::cli {

void addSolveFlags(CLI::App& app, app::InvertSettings& s, const std::string& threadsHelp)
{
    app.add_option("--threads", s.threads, threadsHelp + "; results do not depend on it")->check(threadCount());
    app.add_option("--jacobian", s.jacobian, "analytic (default) or fd (finite differences, in parallel)");
    app.add_flag("--no-partition", s.noPartition, "Solve all parameters as one dense problem");
    app.add_flag("--block-by-block", s.blockByBlock,
                 "Solve the partition's blocks one after another, each outer block held (faster, a worse optimum "
                 "on unreachable targets)");
    app.add_option("--polish", s.polish, "Real-rig corrections per frame (0: approximation only)");
    app.add_option("--restart-every", s.restartEvery,
                   "Frames between warm-start restarts (chunks of a clip then match one run)");
    app.add_flag("--rest-starts", s.restStarts,
                 "Restart frames start from the rest values instead of the approximation's initial guess");
    app.add_flag("--hybrid", s.hybrid,
                 "Fit the outputs the approximation does not model (an IK leg) by Gauss-Newton on the real rig, "
                 "after the approximation's solve");
}

}  // namespace rig::cli
