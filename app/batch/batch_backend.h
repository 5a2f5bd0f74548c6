#pragma once
// Where rig-batch runs its shards (docs/cluster.md). Each shard is one process, `rig-batch --out FOLDER
// --task K` (K: the shard's index in FOLDER/manifest.json), which writes the shard's output and status
// record (batch_manifest.h). The local backend runs up to N of them at once on this machine; the Slurm
// backend submits sbatch array jobs, one task per shard, and waits for them with `sbatch --wait`.

#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace rig::app {

struct BackendRun {
    std::filesystem::path program;  // rig-batch, absolute
    std::filesystem::path folder;   // the batch's output folder, absolute
    std::vector<int> shards;        // manifest indices
    std::vector<std::string> keys;  // per entry of `shards`: its key (names its log)
    int jobs = 1;                   // processes at once (local); array tasks running at once (Slurm: %M)
    int round = 0;                  // 0, then 1, 2, ... for retries: names the Slurm files
    // Local only: the folder's lock (an open descriptor holding flock), which every task inherits open, so
    // that the lock is held until the last task of this run is gone (-1: none).
    int lockFd = -1;
    // Slurm only: the jobs' name (sbatch --job-name), by which they are cancelled when rig-batch is stopped.
    std::string jobName = "rig-batch";
    // Slurm only: per task resources (sbatch --cpus-per-task, --mem, --time; "" leaves Slurm's default) and
    // more sbatch options as given (--partition=..., --account=...).
    int cpusPerTask = 1;
    std::string memory;
    std::string time;
    std::vector<std::string> sbatchArgs;
    // Called as processes end, and every half second while Slurm runs the tasks; may be empty.
    std::function<void()> poll;
    // Whether a shard's task has written its status record. sbatch --wait looks at its job at 2, 10, 42 s
    // ... after submitting it: the Slurm backend stops waiting as soon as every task of an array has
    // reported (stopping sbatch --wait leaves the job to end on its own).
    std::function<bool(int shard)> reported;
};

// What the backend saw of each shard's process, for shards whose task wrote no status record: an exit
// code, a signal, the log to read. Throws rig::Error when the work cannot be started (no process, sbatch
// refused the job).
using ProcessNotes = std::map<int, std::string>;
ProcessNotes runLocal(const BackendRun& run);
ProcessNotes runSlurm(const BackendRun& run);

// rig-batch's tasks end with it. Called by the driver before any other thread starts: SIGINT, SIGTERM and
// SIGHUP are then blocked in every thread and taken by a thread of their own, which stops the backends' work
// and exits with 128 + the signal. The local tasks run in a process group of their own, which is sent
// SIGTERM; the exit waits until runLocal has seen the last of them end (SIGKILL after 10 s). The Slurm jobs
// are cancelled (scancel --name). Tasks started by runLocal also die when rig-batch is killed outright
// (SIGKILL, or a crash): see dieWithDriver.
void stopTasksOnSignals();

// Called first by a task (`rig-batch --task K`): a task started by runLocal asks the kernel for SIGKILL when
// the rig-batch that started it dies (PR_SET_PDEATHSIG), and ends at once if it already has. Nothing for a
// task started otherwise (by Slurm, or by hand).
void dieWithDriver();

// Asks sbatch whether it would take a task of `run` (sbatch --test-only: the controller answers, nothing is
// submitted). Throws rig::Error with sbatch's reason when it would not.
void checkSlurm(const BackendRun& run);

// Whether `program` is found on PATH (the Slurm backend needs sbatch).
bool onPath(const std::string& program);

// A word for sh, in single quotes.
std::string shellQuote(const std::string& word);

// Slurm's default MaxArraySize is 1001: array indices 0 to 1000. Larger batches are several arrays.
inline constexpr int slurmArrayTasks = 1000;

}  // namespace rig::app
