#include "tools/batch_run.h"

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

#include "core/error.h"
#include "inversion/continuity.h"
#include "nodes/graph_rig_function.h"
#include "tools/batch_backend.h"
#include "tools/batch_manifest.h"
#include "tools/cli_common.h"

namespace rig::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::string hostName()
{
    char name[256] = {};
    return ::gethostname(name, sizeof(name) - 1) == 0 ? std::string(name) : std::string();
}

bool isClip(const fs::path& file) { return file.extension() == ".bvh" || file.extension() == ".json"; }

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

// A folder's .bvh and .json files, in name order. A clip's name that is a broken link is an error, not a clip
// silently left out of the library.
std::vector<fs::path> folderClips(const fs::path& folder, const std::string& shown)
{
    std::vector<fs::path> found;
    std::error_code ec;
    fs::directory_iterator it(folder, ec);
    for (; !ec && it != fs::directory_iterator(); it.increment(ec)) {
        const fs::path& file = it->path();
        if (!isClip(file)) continue;
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
            "--clips {}: the folder holds no .bvh or .json clip; give clip files or folders of them", shown));
    std::sort(found.begin(), found.end());
    return found;
}

// --clips: files as given, folders as their .bvh and .json files in name order; each path once (a file named
// twice, by itself and in its folder), while links of other names are clips of those names.
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
                fmt::format("--clips {}: no such file or folder; give clip files (.bvh, .json) or folders of "
                            "them",
                            g));
        if (!fs::is_directory(status)) {
            if (!isClip(p))
                throw Error(fmt::format("--clips {}: not a clip; give .bvh or .json files, or folders of them", g));
            add(p);
            continue;
        }
        if (std::error_code ec; fs::equivalent(p, out, ec))
            throw Error(fmt::format("--clips {}: is the output folder (--out); give the folder of the clips", g));
        for (const auto& file : folderClips(p, g)) add(file);
    }
    if (files.empty()) throw Error("--clips: no clip given; give clip files (.bvh, .json) or folders of them");
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
    ChainContinuity continuity(equivalences, {}, &samePose);
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

Json clipReport(const BatchClip& clip, int shards, const MergedClip* merged, const fs::path& curves)
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
                                                        {"joint", s.firstFailedJoint}}
                                                 : Json();
    j["retried_frames"] = s.retriedFrames;
    j["retries_kept"] = s.retriesKept;
    j["residual_joints"] = residualJointsJson(s);
    j["max_position_error_cm"] = numberJson(s.maxPositionErrorCm);
    j["worst_joint"] = s.worstJoint;
    j["worst_frame"] = frameNumber(s.worstFrame);
    j["mean_position_error_cm"] = numberJson(s.meanPositionErrorCm);
    j["max_rotation_error_deg"] = numberJson(s.maxRotationErrorDeg);
    j["worst_rotation_joint"] = s.worstRotationJoint;
    j["worst_rotation_frame"] = frameNumber(s.worstRotationFrame);
    j["mean_rotation_error_deg"] = numberJson(s.meanRotationErrorDeg);
    j["max_model_gap_cm"] = numberJson(s.maxModelGapCm);
    j["ms_per_frame"] = numberJson(s.msPerFrame);
    j["task_seconds"] = numberJson(merged->taskSeconds);
    j["curves"] = {{"file", curves.string()}, {"checksum", merged->curvesChecksum}};
    return j;
}

}  // namespace

BatchOutcome runBatch(const BatchJob& job)
{
    const auto start = Clock::now();
    // Everything that can be checked before the work is, and nothing is written before that.
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
    const fs::path folder = fs::absolute(job.out);
    if (std::error_code ec; fs::exists(folder, ec) && !fs::is_directory(folder, ec))
        throw Error(fmt::format("--out {}: is a file; give a folder (it is created when missing)", job.out));
    const std::vector<fs::path> files = clipFiles(job.clips, folder);

    InvertJob base;
    base.approximationName = fs::absolute(job.approximation).string();
    base.rig = fs::absolute(job.rig).string();
    base.map = job.map.empty() ? "" : fs::absolute(job.map).string();
    base.plugins = job.plugins;
    base.strict = job.strict;
    base.settings = job.settings;
    base.warning = job.warning;
    LoadedRig loaded = loadRig(base);
    const Approximation& approximation = *loaded.approximation;
    bindRig(base, approximation, *loaded.rig);

    BatchManifest manifest;
    BatchInputs& inputs = manifest.inputs;
    inputs.approximation = base.approximationName;
    inputs.rig = base.rig;
    inputs.map = base.map;
    inputs.plugins = job.plugins;
    inputs.strict = job.strict;
    inputs.settings = job.settings;
    inputs.shardFrames = job.shardFrames;
    inputs.approximationChecksum = fileChecksum(inputs.approximation, "the approximation");
    inputs.rigFingerprint = loaded.rig->fingerprint();
    inputs.mapChecksum = inputs.map.empty() ? "" : fileChecksum(inputs.map, "the map");
    std::vector<std::vector<double>> frameNumbers;
    std::map<std::string, fs::path> names;
    std::vector<std::pair<std::string, fs::path>> inputFiles{{"the approximation", inputs.approximation},
                                                             {"the map", inputs.map}};
    for (const auto& file : loaded.rig->files()) inputFiles.emplace_back("a file the rig reads", file);
    // The manifest (JSON) holds these paths: bytes that are not UTF-8 would be read back as other names.
    for (const auto& [flag, path] : {std::pair<std::string, std::string>{"approximation", inputs.approximation},
                                     {"--rig", inputs.rig},
                                     {"--map", inputs.map}})
        if (!isUtf8(path))
            throw Error(
                fmt::format("{} {}: its path is not UTF-8, which the batch's manifest (JSON) cannot hold; "
                            "rename it",
                            flag, path));
    for (const std::string& plugin : job.plugins)
        if (!isUtf8(plugin))
            throw Error(
                fmt::format("--plugin {}: is not UTF-8, which the batch's manifest (JSON) cannot hold; "
                            "rename it",
                            plugin));
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
    // Every clip read and matched as rig-invert would, clips in parallel (a library has thousands); the first
    // clip in order with an error is the one reported.
    frameNumbers.resize(files.size());
    std::vector<std::string> clipErrors(files.size());
    tbb::parallel_for(std::size_t{0}, files.size(), [&](std::size_t c) {
        try {
            InvertJob one = base;
            one.clip = files[c].string();
            const TargetClip clip = readTargets(one);
            matchClipTargets(approximation, clip);
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
    manifest.shards = planShards(inputs, manifest.clips, frameNumbers);
    std::vector<fs::path> outputs{folder / "manifest.json", folder / "report.json"};
    for (const BatchClip& clip : manifest.clips) outputs.push_back(folder / (clip.name + ".json"));
    checkOutputsAreNotInputs(inputFiles, outputs);

    // The backend's settings; Slurm is asked whether it would take such tasks before anything is written.
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

    std::error_code ec;
    for (const char* sub : {"shards", "logs"}) fs::create_directories(folder / sub, ec);
    if (ec)
        throw Error(fmt::format("--out {}: cannot create it ({}); give a folder you may write", job.out, ec.message()));
    run.lockFd = lockFolder(folder);
    for (const fs::path& out : outputs) checkOutputFile(out, "out", "--out");

    // Resume: a shard is done when its output matches the checksum recorded for it, in its status record
    // (newer: written after the output) or in the manifest of an earlier run.
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

    // Run what is not done; failed shards again, up to --retries times.
    const int reused = static_cast<int>(manifest.shards.size() - pending.size());
    // --jobs by default: the cores (local), every task at once (Slurm: 0 here, the shards to run).
    const int jobs = job.jobs > 0             ? job.jobs
                     : job.backend == "local" ? static_cast<int>(std::max(1u, std::thread::hardware_concurrency()))
                                              : 0;
    const int toRun = static_cast<int>(pending.size());
    int done = 0;
    long long framesRun = 0;
    std::map<int, std::string> errors;
    const auto runStart = Clock::now();
    const double planSeconds = secondsSince(start);
    double taskSeconds = 0.0;
    for (int round = 0; round <= job.retries && !pending.empty(); ++round) {
        std::vector<std::string> pendingKeys;
        for (const int i : pending) {
            const BatchShard& shard = manifest.shards[static_cast<std::size_t>(i)];
            fs::remove(folder / shard.status(), ec);
            pendingKeys.push_back(shard.key);
        }
        run.shards = pending;
        run.keys = pendingKeys;
        run.jobs = jobs > 0 ? jobs : static_cast<int>(pending.size());
        run.round = round;
        run.reported = [&](int i) {
            return fs::exists(folder / manifest.shards[static_cast<std::size_t>(i)].status(), ec);
        };
        if (job.progress)
            run.poll = [&] {
                int ended = 0;
                for (const int i : pending)
                    ended += fs::exists(folder / manifest.shards[static_cast<std::size_t>(i)].status(), ec);
                job.progress(done + ended, toRun);
            };
        const ProcessNotes notes = job.backend == "slurm" ? runSlurm(run) : runLocal(run);
        std::vector<int> failed;
        for (const int i : pending) {
            BatchShard& shard = manifest.shards[static_cast<std::size_t>(i)];
            ShardStatus status;
            const bool reported = readShardStatus(folder / shard.status(), status) && status.key == shard.key;
            if (reported && status.ok && shardDone(folder, manifest, shard, status.checksum)) {
                shard.checksum = status.checksum;
                taskSeconds += status.seconds;
                framesRun += shard.last - shard.first + 1;
                ++done;
                continue;
            }
            const auto note = notes.find(i);
            if (reported && !status.ok) errors[i] = status.error;
            else if (reported)
                errors[i] = fmt::format(
                    "error: {} (or its clip's curves): does not match the checksums its task "
                    "recorded; written over since? run rig-batch again",
                    (folder / shard.output()).string());
            else if (note != notes.end()) errors[i] = "error: the task " + note->second;
            else errors[i] = "error: the task ended without a status";
            failed.push_back(i);
        }
        for (const int i : pending)
            if (!std::count(failed.begin(), failed.end(), i)) errors.erase(i);
        pending = failed;
        writeManifest(folder, manifest);
    }
    const double runSeconds = toRun > 0 ? secondsSince(runStart) : 0.0;
    if (job.progress) job.progress(toRun, toRun);

    // Merge each clip whose shards are all done. Clips in parallel: the merge reads every shard's output again
    // and writes every curves file, the most data a batch moves on one machine.
    const auto mergeStart = Clock::now();
    const Equivalences equivalences(approximation);
    struct ClipMerge {
        std::size_t first = 0, end = 0;  // its shards
        std::optional<MergedClip> merged;
        std::string unwritten;  // why its curves could not be written (a full disk)
    };
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
                                 equivalences, *loaded.rig);
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
    // Curves that could not be written: the shards stay done (the manifest records them), the clips are named.
    std::vector<std::string> unwritten;
    for (const ClipMerge& m : merges)
        if (!m.unwritten.empty())
            unwritten.push_back(fmt::format(
                "{} (shards {} to {}, frames {}:{}): {}",
                manifest.clips[static_cast<std::size_t>(manifest.shards[m.first].clip)].name, m.first, m.end - 1,
                manifest.shards[m.first].firstFrame, manifest.shards[m.end - 1].lastFrame, m.unwritten));
    if (!unwritten.empty()) {
        fs::remove(folder / "report.json", ec);  // an earlier run's would name curves that are not there
        throw Error(fmt::format(
            "the merge could not write the curves of {} of {} clips: {}{}; their shards are done "
            "and kept: run rig-batch again to merge them",
            unwritten.size(), merges.size(), unwritten.front(), unwritten.size() > 1 ? " (and the others')" : ""));
    }
    BatchOutcome outcome;
    Json clips = Json::array();
    long long totalFrames = 0;
    double solveSeconds = 0.0;
    int complete = 0;
    for (ClipMerge& m : merges) {
        const BatchClip& clip = manifest.clips[static_cast<std::size_t>(manifest.shards[m.first].clip)];
        totalFrames += clip.frames;
        if (m.merged && m.merged->failedShard >= 0) {
            errors[m.merged->failedShard] = m.merged->error;
            manifest.shards[static_cast<std::size_t>(m.merged->failedShard)].checksum.clear();
            m.merged.reset();
        }
        if (m.merged) {
            ++complete;
            solveSeconds += m.merged->summary.solveSeconds;
            if (m.merged->summary.failedFrames() > 0) {
                if (outcome.failedClips++ == 0)
                    outcome.firstFailedFrames = fmt::format(
                        "{}: {}", clip.name,
                        failedFramesLine(
                            m.merged->summary,
                            m.merged->frameNumbers[static_cast<std::size_t>(m.merged->summary.firstFailedFrame)]));
            }
        }
        clips.push_back(clipReport(clip, static_cast<int>(m.end - m.first), m.merged ? &*m.merged : nullptr,
                                   folder / (clip.name + ".json")));
    }
    writeManifest(folder, manifest);
    const double mergeSeconds = secondsSince(mergeStart);

    Json failedShards = Json::array();
    for (const auto& [i, error] : errors) {
        const BatchShard& shard = manifest.shards[static_cast<std::size_t>(i)];
        const std::string& clip = manifest.clips[static_cast<std::size_t>(shard.clip)].name;
        failedShards.push_back({{"shard", i}, {"clip", clip}, {"frames", framesText(shard)}, {"error", error}});
        outcome.failures.push_back(fmt::format("shard {} ({} frames {}): {}", i, clip, framesText(shard), error));
    }
    outcome.report =
        Json{{"format", "rig-batch report 1"},
             {"approximation", inputs.approximation},
             {"rig", inputs.rig},
             {"held", heldJson(approximation.held)},
             {"unmodelled_outputs", unmodelledOutputs(approximation)},
             {"hybrid", job.settings.hybrid},
             {"map", inputs.map.empty() ? Json() : Json(inputs.map)},
             {"backend", job.backend},
             {"jobs", jobs > 0 ? Json(jobs) : Json("all")},
             {"shard_frames", job.shardFrames},
             {"restart_every", job.settings.clip.restartInterval},
             {"clips", std::move(clips)},
             {"failed_shards", std::move(failedShards)},
             {"totals",
              {{"clips", manifest.clips.size()},
               {"clips_complete", complete},
               {"frames", totalFrames},
               {"shards", manifest.shards.size()},
               {"shards_reused", reused},
               {"shards_run", done},
               {"shards_failed", errors.size()},
               {"frames_run", framesRun},
               {"plan_seconds", numberJson(planSeconds)},
               {"run_seconds", numberJson(runSeconds)},
               {"frames_per_second", framesRun > 0 ? numberJson(static_cast<double>(framesRun) / runSeconds) : Json()},
               {"task_seconds", numberJson(taskSeconds)},
               {"solve_seconds", numberJson(solveSeconds)},
               {"merge_seconds", numberJson(mergeSeconds)}}}};
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
        if (fileChecksum(clip.file, "the clip") != clip.checksum) throw changed(clip.file, "the clip");
        InvertJob job;
        job.approximationName = in.approximation;
        job.rig = in.rig;
        job.map = in.map;
        job.plugins = in.plugins;
        job.strict = in.strict;
        job.clip = clip.file;
        job.frameIndices = std::pair(shard.first, shard.last);
        job.settings = in.settings;
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

}  // namespace rig::cli
