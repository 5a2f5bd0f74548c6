#pragma once
// rig-batch's work (docs/cluster.md): a motion library inverted as shards on a backend, then merged into
// one curves file per clip, equal byte for byte to rig-invert's for the whole clip, and a library report.
//
// Shards are solved apart, without the chunk before them; each writes its values as solved. The merge
// replays the warm-start chains' continuity shifts over the clip (ChainContinuity, as invertClip reports
// them), so a shard's first chain gets the shift rig-invert --after would give it. Where that shift
// changes nothing (most shards), the merge keeps the curves text the shard wrote; elsewhere it writes the
// shard's frames again from the shifted values.

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "app/common/value_output.h"
#include "app/invert/invert_run.h"

namespace rig::app {

// A batch: the inversion's inputs (settings.clip.solver.threads: per shard, one unless set), the clips and where they
// run.
struct BatchJob : InversionInputs {
    BatchJob() { settings = concurrentSolveDefaults(); }
    std::vector<std::string> clips;  // clip files (any format readTargetClip reads) and folders of them
    std::string out;                 // the output folder
    std::string backend = "local";   // or "slurm"
    int jobs = 0;                    // processes (local) or tasks running at once (slurm); 0: the default
    int shardFrames = 4800;
    int retries = 1;  // new attempts of failed shards
    // Slurm's per-task resources and options (sbatch --mem, --time, and more as given).
    std::string slurmMemory;
    std::string slurmTime;
    std::vector<std::string> slurmArgs;
    std::filesystem::path program;  // rig-batch itself, which the backends start per shard
    // Called as shards end with the shards done and the shards to run; may be empty.
    std::function<void(int done, int total)> progress;
    // Called with a warning line (the rig changed since learning); may be empty.
    std::function<void(const std::string& warning)> warning;
};

struct BatchOutcome {
    Json report;                        // as written to OUT/report.json
    std::vector<std::string> failures;  // one line per failed shard
    // Clips with a frame that is not an answer on the real rig (frameStatusFails), and the first one's line.
    int failedClips = 0;
    std::string firstFailedFrames;
};

// Checks everything (every clip read and matched against the approximation) before writing anything,
// plans the shards, runs those not done, merges each clip whose shards are all done, writes the report.
// Throws rig::Error with one line for bad input (nothing written), or when the backend cannot run.
BatchOutcome runBatch(const BatchJob& job);

// Shard `index` of folder/manifest.json, what each backend task runs: inverts its frames and writes its
// output and status record. Throws rig::Error with one line (after writing it as the status).
void runShard(const std::filesystem::path& folder, int index);

}  // namespace rig::app
