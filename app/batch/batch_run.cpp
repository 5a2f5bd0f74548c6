#include "app/batch/batch_run.h"

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <thread>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include "adapter/graph_rig_function.h"
#include "adapter/retarget.h"
#include "app/batch/batch_backend.h"
#include "app/batch/batch_manifest.h"
#include "app/common/output_file.h"
#include "app/invert/contacts_run.h"
#include "core/error.h"
#include "inversion/clip/continuity.h"
#include "nodes/clips/assimp_clip.h"

namespace rig::app {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::string hostName()
{
    char name[256] = {};
    return ::gethostname(name, sizeof(name) - 1) == 0 ? std::string(name) : std::string();
}

// A clip path's status. A link loop, a link into a folder this user may not search, or any other error
// of the file system is the user's to fix, named by its path (never an exception of std::filesystem).
fs::file_status clipStatus(const fs::path& path, const std::string& shown)
{
    std::error_code ec;
    const fs::file_status status = fs::status(path, ec);
    if (ec && ec != std::errc::no_such_file_or_directory)
        throw Error(fmt::format("--clips {}: cannot read it ({}); fix or remove it, or give the clips without it",
                                shown, ec.message()));
    return status;
}

// A folder's clip files (.bvh, .json and the extensions assimp reads: isClipFile), in name order. A clip's name that is
// a broken link is an error, not a clip silently left out of the library.
std::vector<fs::path> folderClips(const fs::path& folder, const std::string& shown)
{
    std::vector<fs::path> found;
    std::error_code ec;
    fs::directory_iterator it(folder, ec);
    for (; !ec && it != fs::directory_iterator(); it.increment(ec)) {
        const fs::path& file = it->path();
        if (!isClipFile(file)) continue;
        const fs::file_status status = clipStatus(file, file.string());
        if (!fs::exists(status))
            throw Error(fmt::format("--clips {}: a link to nothing; fix or remove it, or give the clips without it",
                                    file.string()));
        if (fs::is_regular_file(status)) found.push_back(file);
    }
    if (ec)
        throw Error(
            fmt::format("--clips {}: cannot list the folder ({}); give a folder you may read", shown, ec.message()));
    if (found.empty())
        throw Error(fmt::format(
            "--clips {}: the folder holds no clip (BVH, FBX, glTF, Collada, ..., .json); give clip files or folders "
            "of them",
            shown));
    std::sort(found.begin(), found.end());
    return found;
}

// --clips: files as given (what they are is read from their content), folders as their clip files in name order; each
// path once (a file named twice, by itself and in its folder), while links of other names are clips of those names.
std::vector<fs::path> clipFiles(const std::vector<std::string>& given, const fs::path& out)
{
    std::vector<fs::path> files;
    std::set<fs::path> seen;
    const auto add = [&](const fs::path& file) {
        const fs::path path = fs::absolute(file).lexically_normal();
        if (seen.insert(path).second) files.push_back(path);
    };
    for (const std::string& g : given) {
        const fs::path p(g);
        const fs::file_status status = clipStatus(p, g);
        if (!fs::exists(status))
            throw Error(
                fmt::format("--clips {}: no such file or folder; give clip files (BVH, FBX, glTF, Collada, ..., "
                            ".json) or folders of them",
                            g));
        if (!fs::is_directory(status)) {
            add(p);
            continue;
        }
        if (std::error_code ec; fs::equivalent(p, out, ec))
            throw Error(fmt::format("--clips {}: is the output folder (--out); give the folder of the clips", g));
        for (const auto& file : folderClips(p, g)) add(file);
    }
    if (files.empty())
        throw Error("--clips: no clip given; give clip files (BVH, FBX, glTF, Collada, ..., .json) or folders of them");
    return files;
}

// Refuses an output that is an input file (by device and inode), before any work.
void checkOutputsAreNotInputs(const std::vector<std::pair<std::string, fs::path>>& inputs,
                              const std::vector<fs::path>& outputs)
{
    std::map<std::pair<dev_t, ino_t>, std::pair<std::string, fs::path>> ids;
    for (const auto& [role, file] : inputs) {
        struct stat st {};
        if (!file.empty() && ::stat(file.c_str(), &st) == 0)
            ids.emplace(std::pair(st.st_dev, st.st_ino), std::pair(role, file));
    }
    for (const fs::path& out : outputs) {
        struct stat st {};
        if (::stat(out.c_str(), &st) != 0) continue;
        if (const auto found = ids.find({st.st_dev, st.st_ino}); found != ids.end())
            throw Error(
                fmt::format("--out: {} is {} ({}); writing it would destroy an input, choose another output "
                            "folder",
                            out.string(), found->second.first, found->second.second.string()));
    }
}

// One rig-batch at a time in an output folder: an advisory lock, released when the process and the local
// tasks it started, which inherit the descriptor (runLocal), have all ended. Returns the descriptor.
int lockFolder(const fs::path& folder)
{
    const fs::path file = folder / ".rig-batch.lock";
    const int fd = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0)
        throw Error(fmt::format("--out {}: cannot write into it; give a folder you may write", folder.string()));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
        ::close(fd);
        throw Error(
            fmt::format("--out {}: another rig-batch is running on this folder; wait for it to end, or give "
                        "another folder",
                        folder.string()));
    }
    return fd;
}

// Shard files of keys no longer planned (inputs changed since): shards/KEY.shard, KEY.status.json, logs/KEY.log.
void removeUnplanned(const fs::path& folder, const std::set<std::string>& keys)
{
    for (const char* sub : {"shards", "logs"}) {
        std::error_code ec;
        for (const auto& entry : fs::directory_iterator(folder / sub, ec)) {
            const std::string name = entry.path().filename().string();
            const std::string key = name.substr(0, name.find('.'));
            if (key.size() == 16 && key.find_first_not_of("0123456789abcdef") == std::string::npos && !keys.count(key))
                fs::remove(entry.path(), ec);
        }
    }
}

std::string framesText(const BatchShard& s) { return fmt::format("{}:{}", s.firstFrame, s.lastFrame); }

bool wholeClip(const BatchManifest& manifest, const BatchShard& shard)
{
    return shard.first == 0 && shard.last == manifest.clips[static_cast<std::size_t>(shard.clip)].frames - 1;
}

// Whether a shard is done: its output matches `checksum`, and for a whole clip, the curves file its task
// wrote matches the checksum its output holds.
bool shardDone(const fs::path& folder, const BatchManifest& manifest, const BatchShard& shard,
               const std::string& checksum)
{
    std::string bytes;
    if (checksum.empty() || !readFileBytes(folder / shard.output(), bytes) || checksumText(bytes) != checksum)
        return false;
    if (!wholeClip(manifest, shard)) return true;
    const std::string curvesChecksum = shardCurvesChecksum(bytes);
    const fs::path curves = folder / (manifest.clips[static_cast<std::size_t>(shard.clip)].name + ".json");
    return !curvesChecksum.empty() && readFileBytes(curves, bytes) && checksumText(bytes) == curvesChecksum;
}

// One clip's merged curves and figures; `error` set when a shard's output cannot be used.
struct MergedClip {
    std::string curves;
    std::string curvesChecksum;
    ClipInversionSummary summary;
    double taskSeconds = 0.0;
    std::vector<double> frameNumbers;  // of the clip's frames, for the report
    int failedShard = -1;
    std::string error;
};

MergedClip mergeClip(const fs::path& folder, const BatchManifest& manifest, int firstShard, int endShard,
                     const Approximation& approximation, const Equivalences& equivalences, const RigFunction& rig)
{
    MergedClip merged;
    ClipInversionSummary& m = merged.summary;
    const int restartEvery = manifest.inputs.settings.clip.restartInterval;
    // The shifts rig-invert makes, checked on the real rig as it checks them (an instance: clips merge in parallel).
    const std::unique_ptr<RigFunction> instance = rig.instance();
    RigBinding binding(approximation, *instance);
    PoseCheck samePose(approximation, &binding);
    ChainContinuity continuity(equivalences, {}, false, &samePose);
    std::string frames;
    for (int i = firstShard; i < endShard; ++i) {
        const BatchShard& shard = manifest.shards[static_cast<std::size_t>(i)];
        const fs::path file = folder / shard.output();
        std::string bytes;
        ShardOutput out;
        // Its checksum was checked earlier in this run (found done, or just written): read, not hashed again.
        try {
            if (!readFileBytes(file, bytes))
                throw Error(fmt::format("{}: removed since its shard was done; run rig-batch again to solve it again",
                                        file.string()));
            out = parseShardOutput(bytes, file.string(), approximation.parameters.size());
            if (out.key != shard.key || out.first != shard.first || out.last != shard.last ||
                out.curvesChecksum.empty() == wholeClip(manifest, shard))
                throw Error(
                    fmt::format("{}: is not the output of shard {} (frames {}); run rig-batch again to solve "
                                "it again",
                                file.string(), i, framesText(shard)));
            for (const ContactSlide& c : out.summary.contacts)
                if (c.output >= static_cast<int>(approximation.outputs.size()))
                    throw Error(
                        fmt::format("{}: is not the output of shard {} (a contact of output {}); run "
                                    "rig-batch again to solve it again",
                                    file.string(), i, c.output));
        }
        catch (const Error& e) {
            merged.failedShard = i;
            merged.error = "error: " + oneLine(e.what());
            return merged;
        }
        if (!out.curvesChecksum.empty()) {
            // A whole clip: its task wrote the curves.
            merged.curvesChecksum = out.curvesChecksum;
            merged.frameNumbers = out.frameNumbers;
        } else {
            // The shard's first chain meets the frame before it, as rig-invert --after would shift it.
            std::vector<std::vector<double>> shifted;
            bool moved = false;
            for (std::size_t f = 0; f < out.solved.size(); ++f) {
                const int frame = shard.first + static_cast<int>(f);
                const std::span<const double> reported = continuity.next(out.solved[f], frame % restartEvery == 0);
                if (f == 0) moved = continuity.shifted();
                if (moved) shifted.emplace_back(reported.begin(), reported.end());
            }
            if (!frames.empty()) frames += ",\n";
            frames += moved ? curvesJsonFrames(approximation, out.frameNumbers, shifted) : out.curvesFrames;
            merged.frameNumbers.insert(merged.frameNumbers.end(), out.frameNumbers.begin(), out.frameNumbers.end());
        }

        // The figures as invertClip gathers them over a whole clip: sums, maxima (the first frame on a tie).
        m.merge(out.summary);
        merged.taskSeconds += out.taskSeconds;
    }
    if (merged.curvesChecksum.empty()) merged.curves = curvesJsonFile(frames);
    return merged;
}

Json clipReport(const BatchClip& clip, int shards, const MergedClip* merged, const fs::path& curves,
                const Approximation& approximation, bool asked)
{
    Json j{{"name", clip.name},
           {"file", clip.file},
           {"frames", clip.frames},
           {"shards", shards},
           {"complete", merged != nullptr}};
    if (!merged) {
        j["curves"] = nullptr;
        return j;
    }
    const ClipInversionSummary& s = merged->summary;
    const auto frameNumber = [&](int index) {
        return index >= 0 ? numberJson(merged->frameNumbers[static_cast<std::size_t>(index)]) : Json();
    };
    j["status_frames"] = statusCountsJson(s);
    j["failed_frames"] = s.failedFrames();
    j["first_failure"] = s.firstFailedFrame >= 0 ? Json{{"frame", frameNumber(s.firstFailedFrame)},
                                                        {"status", frameStatusName(s.firstFailedStatus)},
                                                        {"joint", s.firstFailedJoint},
                                                        {"left_range", rangeLeftJson(s.firstFailedRange)}}
                                                 : Json();
    j["retried_frames"] = s.retriedFrames;
    j["retries_kept"] = s.retriesKept;
    j["residual_joints"] = residualJointsJson(s);
    // What was not measured (a clip of invalid targets) is null, never 0.
    const auto measured = [&](Json value) { return s.measured() ? std::move(value) : Json(); };
    j["max_position_error_cm"] = measured(numberJson(s.maxPositionErrorCm));
    j["worst_joint"] = measured(s.worstJoint);
    j["worst_frame"] = frameNumber(s.worstFrame);
    j["mean_position_error_cm"] = measured(numberJson(s.meanPositionErrorCm));
    j["max_rotation_error_deg"] = measured(numberJson(s.maxRotationErrorDeg));
    j["worst_rotation_joint"] = measured(s.worstRotationJoint);
    j["worst_rotation_frame"] = frameNumber(s.worstRotationFrame);
    j["mean_rotation_error_deg"] = measured(numberJson(s.meanRotationErrorDeg));
    j["max_model_gap_cm"] = measured(numberJson(s.maxModelGapCm));
    j["contacts"] = contactsJson(s, approximation, merged->frameNumbers, asked);
    j["ms_per_frame"] = numberJson(s.msPerFrame);
    j["task_seconds"] = numberJson(merged->taskSeconds);
    j["curves"] = {{"file", curves.string()}, {"checksum", merged->curvesChecksum}};
    return j;
}

// rig-batch's flags and what needs no file, checked first.
void checkBatchFlags(const BatchJob& job)
{
    if (job.backend != "local" && job.backend != "slurm")
        throw Error(
            fmt::format("--backend {}: expected local (processes on this machine) or slurm (sbatch array "
                        "jobs)",
                        job.backend));
    if (job.jobs < 0)
        throw Error(
            fmt::format("--jobs {}: give 1 or more processes (local) or tasks running at once (slurm)", job.jobs));
    if (job.shardFrames < 1)
        throw Error(fmt::format("--shard-frames {}: give 1 or more frames per shard", job.shardFrames));
    if (job.retries < 0) throw Error(fmt::format("--retries {}: give 0 or more new attempts", job.retries));
    clipInversionOptions(job.settings);
    if (job.backend == "slurm" && !onPath("sbatch"))
        throw Error(
            "--backend slurm: sbatch is not on PATH; install Slurm's client (Debian: slurm-client) and "
            "configure it for the cluster, or use --backend local");
    if (job.out.empty()) throw Error("--out: give the output folder");
}

// The manifest (JSON) holds these paths: bytes that are not UTF-8 would be read back as other names.
void checkManifestPaths(const BatchInputs& inputs)
{
    for (const auto& [flag, path] : {std::pair<std::string, std::string>{"approximation", inputs.approximation},
                                     {"--rig", inputs.rig},
                                     {"--map", inputs.map},
                                     {"--contacts", inputs.contacts}})
        if (!isUtf8(path))
            throw Error(
                fmt::format("{} {}: its path is not UTF-8, which the batch's manifest (JSON) cannot hold; "
                            "rename it",
                            flag, path));
    for (const std::string& plugin : inputs.plugins)
        if (!isUtf8(plugin))
            throw Error(
                fmt::format("--plugin {}: is not UTF-8, which the batch's manifest (JSON) cannot hold; "
                            "rename it",
                            plugin));
}

// The clips into the manifest (and `inputFiles`), each path UTF-8 and each name a curves file of its own.
void addClips(const std::vector<fs::path>& files, BatchManifest& manifest,
              std::vector<std::pair<std::string, fs::path>>& inputFiles)
{
    std::map<std::string, fs::path> names;
    for (const fs::path& file : files) {
        const std::string name = file.stem().string();
        if (!isUtf8(file.string()))
            throw Error(
                fmt::format("--clips {}: its path is not UTF-8, which the batch's manifest (JSON) cannot "
                            "hold; rename it",
                            file.string()));
        if (const std::string problem = clipNameProblem(name); !problem.empty())
            throw Error(fmt::format("--clips {}: its curves would be {}.json, {}; rename the clip", file.string(), name,
                                    problem));
        if (const auto [it, added] = names.emplace(name, file); !added)
            throw Error(
                fmt::format("--clips: {} and {} would both write {}.json; rename one, or run them as two "
                            "batches",
                            it->second.string(), file.string(), name));
        manifest.clips.push_back({name, file.string(), "", 0});
        inputFiles.emplace_back("a clip", file);
    }
}

// Every clip read and matched as rig-invert would, clips in parallel (a library has thousands); the first
// clip in order with an error is the one reported. Records each clip's checksum and frame count; returns the
// clips' frame numbers.
std::vector<std::vector<double>> readClips(const InvertJob& base, const Approximation& approximation,
                                           const std::vector<fs::path>& files, BatchManifest& manifest)
{
    std::vector<std::vector<double>> frameNumbers(files.size());
    std::vector<std::string> clipErrors(files.size());
    tbb::parallel_for(std::size_t{0}, files.size(), [&](std::size_t c) {
        try {
            InvertJob one = base;
            one.clip = files[c].string();
            TargetMap map;
            const TargetClip clip = readTargets(one, approximation, &map);
            ClipTargets targets = matchClipTargets(approximation, clip);
            applyTargetWeights(targets, map, clip);
            if (!one.contacts.empty()) readContacts(one.contacts, one.contactsName, approximation, clip, targets);
            manifest.clips[c].checksum = fileChecksum(files[c], "the clip");
            manifest.clips[c].frames = static_cast<int>(clip.frameNumbers.size());
            frameNumbers[c] = clip.frameNumbers;
        }
        catch (const Error& e) {
            clipErrors[c] = e.what();
        }
    });
    for (const std::string& error : clipErrors)
        if (!error.empty()) throw Error(error);
    return frameNumbers;
}

// The batch as planned: every input read and checked, the shards, and the files the batch writes.
struct BatchPlan {
    fs::path folder;
    LoadedRig loaded;
    BatchManifest manifest;
    std::vector<fs::path> outputs;  // the manifest, the report, each clip's curves
};

// Plans the batch: nothing is written, and everything that can be refused before the work is.
BatchPlan planBatch(const BatchJob& job)
{
    BatchPlan plan;
    plan.folder = fs::absolute(job.out);
    if (std::error_code ec; fs::exists(plan.folder, ec) && !fs::is_directory(plan.folder, ec))
        throw Error(fmt::format("--out {}: is a file; give a folder (it is created when missing)", job.out));
    const std::vector<fs::path> files = clipFiles(job.clips, plan.folder);

    InvertJob base;
    static_cast<InversionInputs&>(base) = job;
    base.approximation = fs::absolute(job.approximation).string();
    base.rig = fs::absolute(job.rig).string();
    base.map = job.map.empty() ? "" : fs::absolute(job.map).string();
    base.contacts = job.contacts.empty() || job.contacts == "auto" ? job.contacts : fs::absolute(job.contacts).string();
    base.warning = job.warning;
    plan.loaded = loadRig(base);
    const Approximation& approximation = *plan.loaded.approximation;
    bindRig(base, approximation, *plan.loaded.rig);

    BatchInputs& inputs = plan.manifest.inputs;
    static_cast<InversionInputs&>(inputs) = base;
    inputs.shardFrames = job.shardFrames;
    inputs.approximationChecksum = fileChecksum(inputs.approximation, "the approximation");
    inputs.rigFingerprint = plan.loaded.rig->fingerprint();
    inputs.mapChecksum = inputs.map.empty() ? "" : fileChecksum(inputs.map, "the map");
    const bool contactsFile = !inputs.contacts.empty() && inputs.contacts != "auto";
    inputs.contactsChecksum = contactsFile ? fileChecksum(inputs.contacts, "the contacts file") : "";
    std::vector<std::pair<std::string, fs::path>> inputFiles{
        {"the approximation", inputs.approximation},
        {"the map", inputs.map},
        {"the contacts file", contactsFile ? inputs.contacts : ""}};
    for (const auto& file : plan.loaded.rig->files()) inputFiles.emplace_back("a file the rig reads", file);
    checkManifestPaths(inputs);
    addClips(files, plan.manifest, inputFiles);
    const auto frameNumbers = readClips(base, approximation, files, plan.manifest);
    plan.manifest.shards = planShards(inputs, plan.manifest.clips, frameNumbers);
    plan.outputs = {plan.folder / "manifest.json", plan.folder / "report.json"};
    for (const BatchClip& clip : plan.manifest.clips) plan.outputs.push_back(plan.folder / (clip.name + ".json"));
    checkOutputsAreNotInputs(inputFiles, plan.outputs);
    return plan;
}

// The backend's settings; Slurm is asked whether it would take such tasks before anything is written.
BackendRun backendRun(const BatchJob& job, const fs::path& folder)
{
    BackendRun run;
    run.program = job.program;
    run.folder = folder;
    run.cpusPerTask = std::max(1, job.settings.clip.solver.threads);
    run.memory = job.slurmMemory;
    run.time = job.slurmTime;
    run.sbatchArgs = job.slurmArgs;
    // The folder's own name for its jobs: what rig-batch cancels when it is stopped (and squeue shows).
    run.jobName = "rig-batch-" + checksumText(folder.string()).substr(0, 8);
    if (job.backend == "slurm") checkSlurm(run);
    return run;
}

// Resume: a shard is done when its output matches the checksum recorded for it, in its status record
// (newer: written after the output) or in the manifest of an earlier run. Writes the manifest, removes the
// shard files this plan does not hold, and returns the shards to run.
std::vector<int> resumeBatch(const fs::path& folder, BatchManifest& manifest)
{
    std::map<std::string, std::string> recorded;
    if (fs::exists(folder / "manifest.json")) try {
            for (const BatchShard& s : readManifest(folder).shards)
                if (!s.checksum.empty()) recorded[s.key] = s.checksum;
        }
        catch (const Error&) {
            // An earlier manifest that cannot be read records nothing: its shards are solved again.
        }
    std::set<std::string> keys;
    for (BatchShard& shard : manifest.shards) {
        keys.insert(shard.key);
        ShardStatus status;
        if (readShardStatus(folder / shard.status(), status) && status.key == shard.key && status.ok)
            recorded[shard.key] = status.checksum;
        if (const auto found = recorded.find(shard.key); found != recorded.end()) shard.checksum = found->second;
    }
    // Outputs checked in parallel: a library's shards and curves hold about 4 kB a frame.
    tbb::parallel_for(std::size_t{0}, manifest.shards.size(), [&](std::size_t i) {
        BatchShard& shard = manifest.shards[i];
        if (!shardDone(folder, manifest, shard, shard.checksum)) shard.checksum.clear();
    });
    std::vector<int> pending;
    for (std::size_t i = 0; i < manifest.shards.size(); ++i)
        if (manifest.shards[i].checksum.empty()) pending.push_back(static_cast<int>(i));
    writeManifest(folder, manifest);
    removeUnplanned(folder, keys);
    return pending;
}

// The figures of a batch, as its report gives them.
struct BatchFigures {
    int reused = 0;  // shards an earlier run had done
    int jobs = 0;    // processes or tasks at once; 0: every task at once (Slurm)
    int toRun = 0;
    int done = 0;
    long long framesRun = 0;
    std::map<int, std::string> errors;  // failed shards' error lines
    double planSeconds = 0.0, runSeconds = 0.0, taskSeconds = 0.0, solveSeconds = 0.0, mergeSeconds = 0.0;
    long long totalFrames = 0;
    int complete = 0;  // clips merged
};

// One round's shards, as their tasks left them: the done ones counted, the others' error lines kept. Returns
// the shards that failed.
std::vector<int> collectRound(const fs::path& folder, BatchManifest& manifest, const std::vector<int>& pending,
                              const ProcessNotes& notes, BatchFigures& figures)
{
    std::vector<int> failed;
    for (const int i : pending) {
        BatchShard& shard = manifest.shards[static_cast<std::size_t>(i)];
        ShardStatus status;
        const bool reported = readShardStatus(folder / shard.status(), status) && status.key == shard.key;
        if (reported && status.ok && shardDone(folder, manifest, shard, status.checksum)) {
            shard.checksum = status.checksum;
            figures.taskSeconds += status.seconds;
            figures.framesRun += shard.last - shard.first + 1;
            ++figures.done;
            continue;
        }
        const auto note = notes.find(i);
        if (reported && !status.ok) figures.errors[i] = status.error;
        else if (reported)
            figures.errors[i] = fmt::format(
                "error: {} (or its clip's curves): does not match the checksums its task "
                "recorded; written over since? run rig-batch again",
                (folder / shard.output()).string());
        else if (note != notes.end()) figures.errors[i] = "error: the task " + note->second;
        else figures.errors[i] = "error: the task ended without a status";
        failed.push_back(i);
    }
    for (const int i : pending)
        if (!std::count(failed.begin(), failed.end(), i)) figures.errors.erase(i);
    return failed;
}

// Runs the shards not done; failed shards again, up to --retries times. The manifest records each round.
void runShards(const BatchJob& job, BackendRun& run, const fs::path& folder, BatchManifest& manifest,
               std::vector<int> pending, BatchFigures& figures)
{
    std::error_code ec;
    figures.toRun = static_cast<int>(pending.size());
    const auto runStart = Clock::now();
    for (int round = 0; round <= job.retries && !pending.empty(); ++round) {
        std::vector<std::string> pendingKeys;
        for (const int i : pending) {
            const BatchShard& shard = manifest.shards[static_cast<std::size_t>(i)];
            fs::remove(folder / shard.status(), ec);
            pendingKeys.push_back(shard.key);
        }
        run.shards = pending;
        run.keys = pendingKeys;
        run.jobs = figures.jobs > 0 ? figures.jobs : static_cast<int>(pending.size());
        run.round = round;
        run.reported = [&](int i) {
            return fs::exists(folder / manifest.shards[static_cast<std::size_t>(i)].status(), ec);
        };
        if (job.progress)
            run.poll = [&] {
                int ended = 0;
                for (const int i : pending)
                    ended += fs::exists(folder / manifest.shards[static_cast<std::size_t>(i)].status(), ec);
                job.progress(figures.done + ended, figures.toRun);
            };
        const ProcessNotes notes = job.backend == "slurm" ? runSlurm(run) : runLocal(run);
        pending = collectRound(folder, manifest, pending, notes, figures);
        writeManifest(folder, manifest);
    }
    figures.runSeconds = figures.toRun > 0 ? secondsSince(runStart) : 0.0;
    if (job.progress) job.progress(figures.toRun, figures.toRun);
}

// One clip's merge: its shards [first, end) and what the merge gave.
struct ClipMerge {
    std::size_t first = 0, end = 0;
    std::optional<MergedClip> merged;
    std::string unwritten;  // why its curves could not be written (a full disk)
};

// Merges each clip whose shards are all done and writes its curves; a clip with a shard missing loses an
// earlier run's curves. Clips in parallel: the merge reads every shard's output again and writes every curves
// file, the most data a batch moves on one machine.
std::vector<ClipMerge> mergeClips(const BatchPlan& plan)
{
    const fs::path& folder = plan.folder;
    const BatchManifest& manifest = plan.manifest;
    const Approximation& approximation = *plan.loaded.approximation;
    const Equivalences equivalences(approximation);
    std::vector<ClipMerge> merges;
    for (std::size_t first = 0; first < manifest.shards.size();) {
        std::size_t end = first;
        while (end < manifest.shards.size() && manifest.shards[end].clip == manifest.shards[first].clip) ++end;
        merges.push_back({first, end, std::nullopt, ""});
        first = end;
    }
    tbb::parallel_for(std::size_t{0}, merges.size(), [&](std::size_t c) {
        ClipMerge& m = merges[c];
        const fs::path curves =
            folder / (manifest.clips[static_cast<std::size_t>(manifest.shards[m.first].clip)].name + ".json");
        bool ready = true;
        for (std::size_t i = m.first; i < m.end; ++i) ready = ready && !manifest.shards[i].checksum.empty();
        if (ready)
            m.merged = mergeClip(folder, manifest, static_cast<int>(m.first), static_cast<int>(m.end), approximation,
                                 equivalences, *plan.loaded.rig);
        if (m.merged && m.merged->failedShard < 0) {
            if (m.merged->curvesChecksum.empty()) try {
                    writeFileAtomically(curves, m.merged->curves);
                    m.merged->curvesChecksum = checksumText(m.merged->curves);
                    std::string().swap(m.merged->curves);
                }
                catch (const Error& e) {
                    m.unwritten = e.what();
                }
        } else {
            // No curves for a clip with a shard missing: an earlier run's file would not be this run's.
            std::error_code removed;
            fs::remove(curves, removed);
        }
    });
    return merges;
}

// Curves that could not be written: the shards stay done (the manifest records them), the clips are named.
void checkCurvesWritten(const fs::path& folder, const BatchManifest& manifest, const std::vector<ClipMerge>& merges)
{
    std::vector<std::string> unwritten;
    for (const ClipMerge& m : merges)
        if (!m.unwritten.empty())
            unwritten.push_back(fmt::format(
                "{} (shards {} to {}, frames {}:{}): {}",
                manifest.clips[static_cast<std::size_t>(manifest.shards[m.first].clip)].name, m.first, m.end - 1,
                manifest.shards[m.first].firstFrame, manifest.shards[m.end - 1].lastFrame, m.unwritten));
    if (unwritten.empty()) return;
    std::error_code ec;
    fs::remove(folder / "report.json", ec);  // an earlier run's would name curves that are not there
    throw Error(fmt::format(
        "the merge could not write the curves of {} of {} clips: {}{}; their shards are done "
        "and kept: run rig-batch again to merge them",
        unwritten.size(), merges.size(), unwritten.front(), unwritten.size() > 1 ? " (and the others')" : ""));
}

// The clips' part of the report. A clip whose merge found a shard's output unusable is not merged: that shard
// is failed (its checksum cleared for the manifest). Counts the outcome's failed clips and the figures' totals.
Json clipsReport(BatchManifest& manifest, std::vector<ClipMerge>& merges, const fs::path& folder, BatchOutcome& outcome,
                 BatchFigures& figures, const Approximation& approximation)
{
    Json clips = Json::array();
    for (ClipMerge& m : merges) {
        const BatchClip& clip = manifest.clips[static_cast<std::size_t>(manifest.shards[m.first].clip)];
        figures.totalFrames += clip.frames;
        if (m.merged && m.merged->failedShard >= 0) {
            figures.errors[m.merged->failedShard] = m.merged->error;
            manifest.shards[static_cast<std::size_t>(m.merged->failedShard)].checksum.clear();
            m.merged.reset();
        }
        if (m.merged) {
            ++figures.complete;
            figures.solveSeconds += m.merged->summary.solveSeconds;
            if (m.merged->summary.failedFrames() > 0) {
                if (outcome.failedClips++ == 0)
                    outcome.firstFailedFrames = fmt::format(
                        "{}: {}", clip.name,
                        failedFramesLine(
                            m.merged->summary,
                            m.merged->frameNumbers[static_cast<std::size_t>(m.merged->summary.firstFailedFrame)],
                            {manifest.inputs.rig, clip.file, manifest.inputs.map, manifest.inputs.take, ""}));
            }
        }
        clips.push_back(clipReport(clip, static_cast<int>(m.end - m.first), m.merged ? &*m.merged : nullptr,
                                   folder / (clip.name + ".json"), approximation, !manifest.inputs.contacts.empty()));
    }
    return clips;
}

// OUT/report.json's object; the failed shards' lines into `outcome`.
Json batchReport(const BatchJob& job, const BatchPlan& plan, Json clips, const BatchFigures& figures,
                 BatchOutcome& outcome)
{
    const BatchManifest& manifest = plan.manifest;
    const BatchInputs& inputs = manifest.inputs;
    const Approximation& approximation = *plan.loaded.approximation;
    Json failedShards = Json::array();
    for (const auto& [i, error] : figures.errors) {
        const BatchShard& shard = manifest.shards[static_cast<std::size_t>(i)];
        const std::string& clip = manifest.clips[static_cast<std::size_t>(shard.clip)].name;
        failedShards.push_back({{"shard", i}, {"clip", clip}, {"frames", framesText(shard)}, {"error", error}});
        outcome.failures.push_back(fmt::format("shard {} ({} frames {}): {}", i, clip, framesText(shard), error));
    }
    const double framesRun = static_cast<double>(figures.framesRun);
    return Json{{"format", "rig-batch report 1"},
                {"approximation", inputs.approximation},
                {"rig", inputs.rig},
                {"held", heldJson(approximation.held)},
                {"unmodelled_outputs", unmodelledOutputs(approximation)},
                {"hybrid", job.settings.hybrid},
                {"map", inputs.map.empty() ? Json() : Json(inputs.map)},
                {"backend", job.backend},
                {"jobs", figures.jobs > 0 ? Json(figures.jobs) : Json("all")},
                {"shard_frames", job.shardFrames},
                {"restart_every", job.settings.clip.restartInterval},
                {"clips", std::move(clips)},
                {"failed_shards", std::move(failedShards)},
                {"totals",
                 {{"clips", manifest.clips.size()},
                  {"clips_complete", figures.complete},
                  {"frames", figures.totalFrames},
                  {"shards", manifest.shards.size()},
                  {"shards_reused", figures.reused},
                  {"shards_run", figures.done},
                  {"shards_failed", figures.errors.size()},
                  {"frames_run", figures.framesRun},
                  {"plan_seconds", numberJson(figures.planSeconds)},
                  {"run_seconds", numberJson(figures.runSeconds)},
                  {"frames_per_second", framesRun > 0 ? numberJson(framesRun / figures.runSeconds) : Json()},
                  {"task_seconds", numberJson(figures.taskSeconds)},
                  {"solve_seconds", numberJson(figures.solveSeconds)},
                  {"merge_seconds", numberJson(figures.mergeSeconds)}}}};
}

}  // namespace

BatchOutcome runBatch(const BatchJob& job)
{
    const auto start = Clock::now();
    // Everything that can be checked before the work is, and nothing is written before that.
    checkBatchFlags(job);
    BatchPlan plan = planBatch(job);
    const fs::path& folder = plan.folder;
    BackendRun run = backendRun(job, folder);

    std::error_code ec;
    for (const char* sub : {"shards", "logs"}) fs::create_directories(folder / sub, ec);
    if (ec)
        throw Error(fmt::format("--out {}: cannot create it ({}); give a folder you may write", job.out, ec.message()));
    run.lockFd = lockFolder(folder);
    for (const fs::path& out : plan.outputs) checkOutputFile(out, "out", "--out");
    std::vector<int> pending = resumeBatch(folder, plan.manifest);

    BatchFigures figures;
    figures.reused = static_cast<int>(plan.manifest.shards.size() - pending.size());
    // --jobs by default: the cores (local), every task at once (Slurm: 0 here, the shards to run).
    figures.jobs = job.jobs > 0             ? job.jobs
                   : job.backend == "local" ? static_cast<int>(std::max(1u, std::thread::hardware_concurrency()))
                                            : 0;
    figures.planSeconds = secondsSince(start);
    runShards(job, run, folder, plan.manifest, std::move(pending), figures);

    const auto mergeStart = Clock::now();
    std::vector<ClipMerge> merges = mergeClips(plan);
    checkCurvesWritten(folder, plan.manifest, merges);
    BatchOutcome outcome;
    Json clips = clipsReport(plan.manifest, merges, folder, outcome, figures, *plan.loaded.approximation);
    writeManifest(folder, plan.manifest);
    figures.mergeSeconds = secondsSince(mergeStart);
    outcome.report = batchReport(job, plan, std::move(clips), figures, outcome);
    writeFileAtomically(folder / "report.json", jsonText(outcome.report, 2) + "\n");
    return outcome;
}

void runShard(const std::filesystem::path& folder, int index)
{
    const auto start = Clock::now();
    const BatchManifest manifest = readManifest(folder);
    if (index < 0 || static_cast<std::size_t>(index) >= manifest.shards.size())
        throw Error(fmt::format("--task {}: {} has {} shards (0 to {})", index, (folder / "manifest.json").string(),
                                manifest.shards.size(), static_cast<int>(manifest.shards.size()) - 1));
    const BatchShard& shard = manifest.shards[static_cast<std::size_t>(index)];
    const BatchInputs& in = manifest.inputs;
    const BatchClip& clip = manifest.clips[static_cast<std::size_t>(shard.clip)];
    ShardStatus status;
    status.key = shard.key;
    status.host = hostName();
    try {
        const auto changed = [](const std::string& file, const std::string& what) {
            return Error(
                fmt::format("{}: {} changed since the batch was planned; run rig-batch again to plan with "
                            "it",
                            file, what));
        };
        if (fileChecksum(in.approximation, "the approximation") != in.approximationChecksum)
            throw changed(in.approximation, "the approximation");
        if (!in.map.empty() && fileChecksum(in.map, "the map") != in.mapChecksum) throw changed(in.map, "the map");
        if (!in.contactsChecksum.empty() && fileChecksum(in.contacts, "the contacts file") != in.contactsChecksum)
            throw changed(in.contacts, "the contacts file");
        if (fileChecksum(clip.file, "the clip") != clip.checksum) throw changed(clip.file, "the clip");
        InvertJob job;
        static_cast<InversionInputs&>(job) = in;
        job.clip = clip.file;
        job.frameIndices = std::pair(shard.first, shard.last);
        job.rigLoaded = [&](const GraphRigFunction& rig) {
            if (rig.fingerprint() != in.rigFingerprint) throw changed(in.rig, "the rig (or a file it includes)");
        };
        const InvertOutcome outcome = invert(job);
        ShardOutput out;
        out.key = shard.key;
        out.first = shard.first;
        out.last = shard.last;
        const auto numbers =
            std::span(outcome.clip.frameNumbers)
                .subspan(static_cast<std::size_t>(shard.first), static_cast<std::size_t>(shard.last - shard.first + 1));
        out.frameNumbers.assign(numbers.begin(), numbers.end());
        out.solved = outcome.solved;
        if (wholeClip(manifest, shard)) {
            // Nothing to merge: the curves file as rig-invert writes it, written here rather than by the merge.
            const std::string curves =
                curvesJsonFile(curvesJsonFrames(*outcome.approximation, numbers, outcome.values));
            writeFileAtomically(folder / (clip.name + ".json"), curves);
            out.curvesChecksum = checksumText(curves);
        } else out.curvesFrames = curvesJsonFrames(*outcome.approximation, numbers, outcome.values);
        out.summary = outcome.summary;
        out.summary.perFrame.clear();
        out.taskSeconds = secondsSince(start);
        const std::string bytes = shardOutputBytes(out);
        writeFileAtomically(folder / shard.output(), bytes);
        status.ok = true;
        status.checksum = checksumText(bytes);
        status.seconds = secondsSince(start);
        writeShardStatus(folder / shard.status(), status);
    }
    catch (const std::exception& e) {
        // The status says why, for the report; the error goes on to the task's own output and exit code.
        status.ok = false;
        status.error =
            oneLine(fmt::format("{}: {}", dynamic_cast<const Error*>(&e) ? "error" : "internal error", e.what()));
        status.seconds = secondsSince(start);
        try {
            writeShardStatus(folder / shard.status(), status);
        }
        catch (const Error&) {
            // No status written: the backend reports the task's exit instead.
        }
        throw;
    }
}

}  // namespace rig::app
