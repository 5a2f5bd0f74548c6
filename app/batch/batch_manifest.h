#pragma once
// rig-batch's files in its output folder (docs/cluster.md): the manifest of a motion library's shards,
// each shard's output and its status record.
//
// A shard is a range of one clip's frames that starts at one of rig-invert's restart frames and holds a
// whole number of restart intervals (the clip's last shard may hold fewer), so that its warm-start chains
// are whole and it solves no lead-in frame. A shard is identified by its key, a checksum of everything its
// output depends on (the approximation's, the map's and the clip's bytes, the rig's fingerprint, the solve
// settings but the thread count, the clip's name and frames); its files are shards/KEY.shard (the output) and
// shards/KEY.status.json (written by the task after the output: the output's checksum, or the task's error
// line). The manifest records, per shard, the checksum of its output once a run has seen its status: a shard
// is done when its output exists and matches that checksum.

#include <filesystem>
#include <string>
#include <vector>

#include "app/common/value_output.h"
#include "app/invert/invert_run.h"
#include "inversion/clip/clip_inversion.h"

namespace rig::app {

// What every shard of a batch shares: the inversion's inputs (absolute file names; settings.clip.solver.threads: per
// shard), the shard size and the inputs' checksums.
struct BatchInputs : InversionInputs {
    int shardFrames = 0;  // as asked; shards hold ceil(shardFrames / restartEvery) restart intervals
    // Checksums of the inputs when the batch was planned: a task refuses inputs that changed since.
    std::string approximationChecksum;
    std::string rigFingerprint;
    std::string mapChecksum;       // "" for none
    std::string contactsChecksum;  // of a contacts file; "" for none or auto
};

struct BatchClip {
    std::string name;      // the curves' file is NAME.json in the output folder
    std::string file;      // absolute
    std::string checksum;  // of its bytes
    int frames = 0;
};

struct BatchShard {
    int clip = 0;   // index into BatchManifest::clips
    int first = 0;  // clip frame indices (0-based, inclusive)
    int last = 0;
    double firstFrame = 0.0;  // the clip's numbers for them, for messages
    double lastFrame = 0.0;
    std::string key;
    std::string checksum;  // of its output, once a run saw it done; "" until then

    std::filesystem::path output() const { return std::filesystem::path("shards") / (key + ".shard"); }
    std::filesystem::path status() const { return std::filesystem::path("shards") / (key + ".status.json"); }
};

struct BatchManifest {
    BatchInputs inputs;
    std::vector<BatchClip> clips;
    std::vector<BatchShard> shards;
};

// Whether `text` is valid UTF-8, which JSON (the manifest) can hold as it is.
bool isUtf8(std::string_view text);
// What keeps `name` from naming a clip's curves file, NAME.json in the output folder, as a clause ("which
// rig-batch writes for the batch"); "" when nothing does. Checked when planning and when a manifest is read,
// so that no task writes outside the output folder or over the batch's own files.
std::string clipNameProblem(const std::string& name);

// A regular file's bytes; false when it cannot be read.
bool readFileBytes(const std::filesystem::path& file, std::string& bytes);
// A checksum of bytes as 16 hex digits, as the manifest records them: FNV-1a 64 over 8-byte words (the bytes
// past the last whole word one by one), six times quicker than over bytes on shard outputs of tens of
// megabytes. Each step is a bijection of the state, so any one changed word changes it.
std::string checksumText(std::string_view bytes);
// The same of a file's bytes. Throws rig::Error naming `role` when it cannot be read.
std::string fileChecksum(const std::filesystem::path& file, const std::string& role);

// The frame ranges [first, last] of a clip of `frames` frames: ceil(shardFrames / restartEvery) restart
// intervals each, the last one what remains.
std::vector<std::pair<int, int>> shardRanges(int frames, int shardFrames, int restartEvery);

// The shards of `clips` (BatchShard::checksum empty), keyed by the inputs.
std::vector<BatchShard> planShards(const BatchInputs& inputs, const std::vector<BatchClip>& clips,
                                   const std::vector<std::vector<double>>& frameNumbers);

// folder/manifest.json. readManifest throws rig::Error (a file that is not a manifest).
Json manifestJson(const BatchManifest& manifest);
BatchManifest readManifest(const std::filesystem::path& folder);
void writeManifest(const std::filesystem::path& folder, const BatchManifest& manifest);

// What a task writes after its shard: done (the output's checksum) or failed (its error line).
struct ShardStatus {
    std::string key;
    bool ok = false;
    std::string checksum;  // of the output
    std::string error;     // one line, "error: ..."
    double seconds = 0.0;  // the task's wall time, from its start to its output written
    std::string host;
};
void writeShardStatus(const std::filesystem::path& file, const ShardStatus& status);
// False when the file is missing or is not a status record.
bool readShardStatus(const std::filesystem::path& file, ShardStatus& status);

// A shard's output: the values as solved (before the continuity shifts, which the merge applies), the
// curves' frames as this shard alone reports them (graph-eval's JSON layout, frames joined by ",\n", no
// brackets: what the merge keeps where its shift leaves the shard's values as they are), and its summary.
// A shard of a whole clip needs no merge: its task writes the clip's curves file itself, and its output
// holds that file's checksum instead of the frames (most clips of a library are one shard: the merge then
// moves no curves).
struct ShardOutput {
    std::string key;
    int first = 0;
    int last = 0;
    std::vector<double> frameNumbers;         // per frame
    std::vector<std::vector<double>> solved;  // [frame][parameter], internal units
    std::string curvesFrames;                 // empty for a whole clip
    std::string curvesChecksum;               // a whole clip's curves file; empty otherwise
    ClipInversionSummary summary;             // perFrame left empty; frame indices are the clip's
    double taskSeconds = 0.0;                 // the task's wall time up to the output
};
// The file: one line of JSON (the summary, and the sizes of what follows), then the frame numbers and the
// solved values as raw doubles in this machine's byte order (exact, and read back with one copy), then the
// curves' frames as text.
std::string shardOutputBytes(const ShardOutput& output);
// Throws rig::Error naming `file` when the bytes are not a shard output for `parameters` parameters.
ShardOutput parseShardOutput(const std::string& bytes, const std::string& file, std::size_t parameters);
// The checksum of the curves file a whole clip's shard wrote, from its output's first line; "" for a shard
// of part of a clip, or bytes that are not a shard output.
std::string shardCurvesChecksum(const std::string& bytes);

}  // namespace rig::app
