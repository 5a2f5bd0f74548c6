#include "app/batch/batch_manifest.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <fstream>

#include <fmt/format.h>

#include "app/common/output_file.h"
#include "app/common/solve_settings.h"
#include "core/error.h"

namespace rig::app {
namespace {

constexpr std::string_view manifestFormat = "rig-batch manifest 3";
// 3: contacts; 4: residual cm and deg apart; 5: a model mismatch's parameter outside its learned range
constexpr std::string_view shardFormat = "rig-batch shard 5";
constexpr std::size_t shardFigures = 8;  // the summary's figures held as raw doubles (shardOutputBytes)

// The settings' table (app/common/solve_settings.h) as fields: a count as a number, a flag as a bool, a choice as its
// word.
Json settingsJson(const SolveSettings& settings)
{
    Json out = Json::object();
    for (const SolveSetting& s : solveSettings()) {
        const int value = s.get(settings);
        const std::string key = settingName(s, Spelling::key);
        if (s.kind == SettingKind::count) out[key] = value;
        else if (s.kind == SettingKind::flag) out[key] = value != 0;
        else out[key] = settingText(s, value);
    }
    return out;
}

// A manifest's field; a missing or mistyped one is the file's mistake.
template <class T>
T field(const Json& object, const char* name, const std::string& file)
{
    const auto found = object.find(name);
    if (found == object.end())
        throw Error(
            fmt::format("{}: not a rig-batch manifest (no '{}'); remove it and run rig-batch again", file, name));
    try {
        return found->get<T>();
    }
    catch (const Json::exception&) {
        throw Error(
            fmt::format("{}: not a rig-batch manifest ('{}' is not what rig-batch writes); remove it and run "
                        "rig-batch again",
                        file, name));
    }
}

// settingsJson read back, every field checked by the table (a value rig-batch would not write: the file's mistake).
SolveSettings readSettings(const Json& settings, const std::string& file)
{
    const auto bad = [&](const Error& e) {
        return Error(fmt::format("{}: not a rig-batch manifest (settings: {}); remove it and run rig-batch again", file,
                                 e.what()));
    };
    SolveSettings out;
    for (const SolveSetting& s : solveSettings()) {
        const std::string key = settingName(s, Spelling::key);
        if (s.kind == SettingKind::count) s.set(out, field<int>(settings, key.c_str(), file));
        else if (s.kind == SettingKind::flag) s.set(out, field<bool>(settings, key.c_str(), file));
        else {
            const std::string word = field<std::string>(settings, key.c_str(), file);
            try {
                s.set(out, parseSetting(s, word, Spelling::key));
            }
            catch (const Error& e) {
                throw bad(e);
            }
        }
    }
    try {
        checkSettings(out, Spelling::key);
    }
    catch (const Error& e) {
        throw bad(e);
    }
    return out;
}

// A first failure's parameter outside its learned range: [] for none, else its fields, numbers as text that strtod
// reads back exactly (the contacts' way).
Json rangeLeftFields(const RangeLeft& r)
{
    if (!r.found()) return Json::array();
    return {r.parameter,
            r.angular,
            fmt::format("{}", r.learnedMin),
            fmt::format("{}", r.learnedMax),
            fmt::format("{}", r.low),
            fmt::format("{}", r.high)};
}

// A shard output's contacts (shardOutputBytes), each within its frames.
template <class Bad>
void readContactSlides(const Json& j, ShardOutput& o, const Bad& bad)
{
    ClipInversionSummary& s = o.summary;
    s.multiplierUpdates = j.at("multiplier_updates").get<int>();
    for (const Json& c : j.at("contacts")) {
        ContactSlide& slide = s.contacts.emplace_back();
        slide.output = c.at(0).get<int>();
        slide.first = c.at(1).get<int>();
        slide.last = c.at(2).get<int>();
        slide.measuredFrom = c.at(3).get<int>();
        const Json& positions = c.at(4);
        const int frames = std::min(slide.last, o.last) - slide.measuredFrom + 1;
        if (slide.output < 0 || slide.first > slide.last || slide.measuredFrom < std::max(slide.first, o.first) ||
            frames < 1 || positions.size() != 3 * static_cast<std::size_t>(frames))
            throw bad(fmt::format("a contact over frames {} to {} measured from {} is not within frames {} to {}",
                                  slide.first, slide.last, slide.measuredFrom, o.first, o.last));
        for (std::size_t f = 0; f < positions.size(); f += 3) {
            Eigen::Vector3d p;
            for (std::size_t i = 0; i < 3; ++i)
                p[i] = std::strtod(positions.at(f + i).get<std::string>().c_str(), nullptr);
            slide.add(p);
        }
    }
}

const char* byteOrder() { return std::endian::native == std::endian::little ? "little" : "big"; }

// What in a shard output's summary is not what its task could have written for its frames ("" when nothing
// is): the merge adds the counts and reads the clip's frames at the indices, so none is taken on trust.
std::string summaryProblem(const ShardOutput& o)
{
    const ClipInversionSummary& s = o.summary;
    const int frames = o.last - o.first + 1;
    const auto count = [&](int n) { return n >= 0 && n <= frames; };
    const auto frame = [&](int index) { return index == -1 || (index >= o.first && index <= o.last); };
    if (s.frames != frames) return fmt::format("{} frames counted in frames {} to {}", s.frames, o.first, o.last);
    long long statuses = 0;
    for (const int n : s.statusFrames) {
        if (!count(n)) return fmt::format("a count of frames outside 0 to {}", frames);
        statuses += n;
    }
    if (statuses != frames) return fmt::format("frame statuses for {} of {} frames", statuses, frames);
    if (!count(s.retriedFrames) || !count(s.retriesKept))
        return fmt::format("a count of frames outside 0 to {}", frames);
    for (const auto& joint : s.residualJoints)
        if (!count(joint.frames))
            return fmt::format("joint {} missed on {} of {} frames", joint.name, joint.frames, frames);
    if (!frame(s.worstFrame) || !frame(s.worstRotationFrame) || !frame(s.firstFailedFrame))
        return fmt::format("a frame index outside {} to {}", o.first, o.last);
    if (s.jointFrames < 0 || s.realRigEvaluations < 0) return "a negative count";
    if (!o.curvesChecksum.empty() &&
        (o.curvesChecksum.size() != 16 || o.curvesChecksum.find_first_not_of("0123456789abcdef") != std::string::npos))
        return "its curves file's checksum is not 16 hex digits";
    return "";
}

}  // namespace

bool isUtf8(std::string_view text)
{
    try {
        (void)Json(text).dump();  // nlohmann checks UTF-8 as it writes a string
        return true;
    }
    catch (const Json::type_error&) {
        return false;
    }
}

std::string clipNameProblem(const std::string& name)
{
    // Linux's file systems take names of 255 bytes (NAME_MAX); ".json" follows the clip's name.
    constexpr std::size_t longest = 255 - 5;
    if (name.empty() || name == "." || name == ".." || name.find_first_of(std::string("/\0", 2)) != std::string::npos)
        return "which is not a file name in the output folder";
    if (name == "report" || name == "manifest") return "which rig-batch writes for the batch";
    if (!isUtf8(name)) return "which is not UTF-8 (the manifest, JSON, cannot hold it)";
    if (name.size() > longest)
        return fmt::format("a name of {} bytes, longer than the 255 file systems take", name.size() + 5);
    return "";
}

bool readFileBytes(const std::filesystem::path& file, std::string& bytes)
{
    std::error_code ec;
    const auto size = std::filesystem::file_size(file, ec);
    if (ec || !std::filesystem::is_regular_file(file, ec)) return false;
    std::ifstream in(file, std::ios::binary);
    bytes.resize(size);
    // One read of the whole file: shard outputs are tens of megabytes.
    return in.read(bytes.data(), static_cast<std::streamsize>(size)) && in.peek() == std::ifstream::traits_type::eof();
}

std::string checksumText(std::string_view bytes)
{
    constexpr std::uint64_t prime = 0x100000001b3ull;
    std::uint64_t hash = 0xcbf29ce484222325ull;
    std::size_t i = 0;
    for (std::uint64_t word = 0; i + sizeof(word) <= bytes.size(); i += sizeof(word)) {
        std::memcpy(&word, bytes.data() + i, sizeof(word));
        hash = (hash ^ word) * prime;
    }
    for (; i < bytes.size(); ++i) hash = (hash ^ static_cast<unsigned char>(bytes[i])) * prime;
    return fmt::format("{:016x}", hash);
}

std::string fileChecksum(const std::filesystem::path& file, const std::string& role)
{
    std::string bytes;
    if (!readFileBytes(file, bytes))
        throw Error(
            fmt::format("{}: cannot read {}; check that it exists and is a readable file", file.string(), role));
    return checksumText(bytes);
}

std::vector<std::pair<int, int>> shardRanges(int frames, int shardFrames, int restartEvery)
{
    // In 64 bits: both flags may be near INT_MAX, and their rounded sum and the next shard's start beyond it.
    const long long interval = restartEvery;
    const long long size = (shardFrames + interval - 1) / interval * interval;
    std::vector<std::pair<int, int>> out;
    for (long long first = 0; first < frames; first += size)
        out.emplace_back(static_cast<int>(first), static_cast<int>(std::min<long long>(first + size, frames) - 1));
    return out;
}

std::vector<BatchShard> planShards(const BatchInputs& inputs, const std::vector<BatchClip>& clips,
                                   const std::vector<std::vector<double>>& frameNumbers)
{
    // The thread count changes no value (docs/rig-invert.md), so it is not part of a shard's key.
    Json settings = settingsJson(inputs.settings);
    settings.erase("threads");
    const std::string shared = jsonText(Json{{"format", shardFormat},
                                             {"approximation", inputs.approximationChecksum},
                                             {"rig", inputs.rigFingerprint},
                                             {"map", inputs.mapChecksum},
                                             {"contacts", inputs.contacts == "auto" ? "auto" : inputs.contactsChecksum},
                                             {"plugins", inputs.plugins},
                                             {"take", inputs.take},
                                             {"settings", settings}});
    std::vector<BatchShard> out;
    for (std::size_t c = 0; c < clips.size(); ++c)
        for (const auto& [first, last] :
             shardRanges(clips[c].frames, inputs.shardFrames, inputs.settings.clip.restartInterval)) {
            BatchShard shard;
            shard.clip = static_cast<int>(c);
            shard.first = first;
            shard.last = last;
            shard.firstFrame = frameNumbers[c][static_cast<std::size_t>(first)];
            shard.lastFrame = frameNumbers[c][static_cast<std::size_t>(last)];
            // The clip's name too: two clips of the same bytes are two shards, each with its own files.
            shard.key =
                checksumText(fmt::format("{}\n{}\n{}\n{}:{}", shared, clips[c].name, clips[c].checksum, first, last));
            out.push_back(std::move(shard));
        }
    return out;
}

Json manifestJson(const BatchManifest& m)
{
    const BatchInputs& in = m.inputs;
    Json clips = Json::array();
    for (const BatchClip& c : m.clips)
        clips.push_back({{"name", c.name}, {"file", c.file}, {"checksum", c.checksum}, {"frames", c.frames}});
    Json shards = Json::array();
    for (const BatchShard& s : m.shards)
        shards.push_back({{"clip", s.clip},
                          {"first", s.first},
                          {"last", s.last},
                          {"first_frame", numberJson(s.firstFrame)},
                          {"last_frame", numberJson(s.lastFrame)},
                          {"key", s.key},
                          {"output", s.output().string()},
                          {"checksum", s.checksum.empty() ? Json() : Json(s.checksum)}});
    return Json{{"format", manifestFormat},
                {"approximation", in.approximation},
                {"approximation_checksum", in.approximationChecksum},
                {"rig", in.rig},
                {"rig_fingerprint", in.rigFingerprint},
                {"map", in.map.empty() ? Json() : Json(in.map)},
                {"map_checksum", in.mapChecksum.empty() ? Json() : Json(in.mapChecksum)},
                {"contacts", in.contacts.empty() ? Json() : Json(in.contacts)},
                {"contacts_checksum", in.contactsChecksum.empty() ? Json() : Json(in.contactsChecksum)},
                {"plugins", in.plugins},
                {"strict", in.strict},
                {"take", in.take},
                {"settings", settingsJson(in.settings)},
                {"shard_frames", in.shardFrames},
                {"clips", std::move(clips)},
                {"shards", std::move(shards)}};
}

BatchManifest readManifest(const std::filesystem::path& folder)
{
    const std::string file = (folder / "manifest.json").string();
    std::ifstream in(file);
    if (!in)
        throw Error(fmt::format("{}: cannot read it; run rig-batch with the library's inputs to plan the batch", file));
    Json j;
    try {
        j = Json::parse(in);
    }
    catch (const Json::exception& e) {
        throw Error(
            fmt::format("{}: not a rig-batch manifest ({}); remove it and run rig-batch again", file, e.what()));
    }
    if (!j.is_object() || j.value("format", "") != manifestFormat)
        throw Error(
            fmt::format("{}: not a rig-batch manifest (format '{}' expected); remove it and run rig-batch "
                        "again",
                        file, manifestFormat));
    BatchManifest m;
    BatchInputs& inputs = m.inputs;
    inputs.approximation = field<std::string>(j, "approximation", file);
    inputs.approximationChecksum = field<std::string>(j, "approximation_checksum", file);
    inputs.rig = field<std::string>(j, "rig", file);
    inputs.rigFingerprint = field<std::string>(j, "rig_fingerprint", file);
    const Json map = field<Json>(j, "map", file);
    inputs.map = map.is_string() ? map.get<std::string>() : "";
    const Json mapChecksum = field<Json>(j, "map_checksum", file);
    inputs.mapChecksum = mapChecksum.is_string() ? mapChecksum.get<std::string>() : "";
    const Json contacts = field<Json>(j, "contacts", file);
    inputs.contacts = contacts.is_string() ? contacts.get<std::string>() : "";
    const Json contactsChecksum = field<Json>(j, "contacts_checksum", file);
    inputs.contactsChecksum = contactsChecksum.is_string() ? contactsChecksum.get<std::string>() : "";
    inputs.plugins = field<std::vector<std::string>>(j, "plugins", file);
    inputs.strict = field<bool>(j, "strict", file);
    inputs.take = field<std::string>(j, "take", file);
    inputs.settings = readSettings(field<Json>(j, "settings", file), file);
    inputs.shardFrames = field<int>(j, "shard_frames", file);
    for (const Json& c : field<Json>(j, "clips", file)) {
        m.clips.push_back({field<std::string>(c, "name", file), field<std::string>(c, "file", file),
                           field<std::string>(c, "checksum", file), field<int>(c, "frames", file)});
        // A task writes NAME.json: a name such as ../x would write outside the output folder.
        if (const std::string problem = clipNameProblem(m.clips.back().name); !problem.empty())
            throw Error(
                fmt::format("{}: not a rig-batch manifest (clip {}'s curves would be {}.json, {}); remove it and "
                            "run rig-batch again",
                            file, m.clips.size() - 1, m.clips.back().name, problem));
    }
    for (const Json& s : field<Json>(j, "shards", file)) {
        BatchShard shard;
        shard.clip = field<int>(s, "clip", file);
        shard.first = field<int>(s, "first", file);
        shard.last = field<int>(s, "last", file);
        shard.firstFrame = field<double>(s, "first_frame", file);
        shard.lastFrame = field<double>(s, "last_frame", file);
        shard.key = field<std::string>(s, "key", file);
        const Json checksum = field<Json>(s, "checksum", file);
        shard.checksum = checksum.is_string() ? checksum.get<std::string>() : "";
        if (shard.clip < 0 || static_cast<std::size_t>(shard.clip) >= m.clips.size() || shard.first < 0 ||
            shard.first > shard.last || shard.last >= m.clips[static_cast<std::size_t>(shard.clip)].frames ||
            shard.key.size() != 16 || shard.key.find_first_not_of("0123456789abcdef") != std::string::npos)
            throw Error(
                fmt::format("{}: not a rig-batch manifest (shard {} is out of its clip); remove it and run "
                            "rig-batch again",
                            file, m.shards.size()));
        m.shards.push_back(std::move(shard));
    }
    return m;
}

void writeManifest(const std::filesystem::path& folder, const BatchManifest& manifest)
{
    writeFileAtomically(folder / "manifest.json", jsonText(manifestJson(manifest), 2) + "\n");
}

void writeShardStatus(const std::filesystem::path& file, const ShardStatus& s)
{
    const Json j{{"key", s.key},
                 {"ok", s.ok},
                 {"checksum", s.ok ? Json(s.checksum) : Json()},
                 {"error", s.ok ? Json() : Json(s.error)},
                 {"seconds", s.seconds},
                 {"host", s.host}};
    writeFileAtomically(file, jsonText(j, 2) + "\n");
}

bool readShardStatus(const std::filesystem::path& file, ShardStatus& status)
{
    std::ifstream in(file);
    if (!in) return false;
    try {
        const Json j = Json::parse(in);
        status.key = j.at("key").get<std::string>();
        status.ok = j.at("ok").get<bool>();
        status.checksum = status.ok ? j.at("checksum").get<std::string>() : "";
        status.error = status.ok ? "" : j.at("error").get<std::string>();
        status.seconds = j.at("seconds").get<double>();
        status.host = j.at("host").get<std::string>();
        return true;
    }
    catch (const Json::exception&) {
        return false;
    }
}

std::string shardOutputBytes(const ShardOutput& o)
{
    std::vector<double> solved;
    for (const auto& row : o.solved) solved.insert(solved.end(), row.begin(), row.end());
    const ClipInversionSummary& s = o.summary;
    // Residual errors may be NaN or infinite, which JSON cannot hold: as text that strtod reads back exactly.
    Json residual = Json::array();
    for (const auto& joint : s.residualJoints)
        residual.push_back({joint.name, joint.frames, fmt::format("{}", joint.worstPositionErrorCm),
                            fmt::format("{}", joint.worstRotationErrorDeg),
                            fmt::format("{}", joint.worstScaledErrorCm)});
    const std::string_view numbers(reinterpret_cast<const char*>(o.frameNumbers.data()),
                                   o.frameNumbers.size() * sizeof(double));
    const std::string_view values(reinterpret_cast<const char*>(solved.data()), solved.size() * sizeof(double));
    // Errors may be NaN or infinite, which JSON cannot hold: as raw doubles too.
    const std::array<double, shardFigures> figures{s.maxPositionErrorCm, s.maxRotationErrorDeg, s.solveSeconds,
                                                   o.taskSeconds,        s.meanPositionErrorCm, s.meanRotationErrorDeg,
                                                   s.maxModelGapCm,      s.solveCpuSeconds};
    const std::string_view figureBytes(reinterpret_cast<const char*>(figures.data()), sizeof(figures));
    Json statuses = Json::array();
    for (const int n : s.statusFrames) statuses.push_back(n);
    // Each contact's positions as text that strtod reads back exactly (a NaN too): the merge joins a contact that
    // spans shards into one run's slide.
    Json contacts = Json::array();
    for (const ContactSlide& c : s.contacts) {
        Json positions = Json::array();
        for (const Eigen::Vector3d& p : c.positions)
            for (int i = 0; i < 3; ++i) positions.push_back(fmt::format("{}", p[i]));
        contacts.push_back({c.output, c.first, c.last, c.measuredFrom, std::move(positions)});
    }
    const Json header{{"format", shardFormat},
                      {"byte_order", byteOrder()},
                      {"key", o.key},
                      {"first", o.first},
                      {"last", o.last},
                      {"frames", s.frames},
                      {"status_frames", std::move(statuses)},
                      {"first_failure",
                       {s.firstFailedFrame, static_cast<int>(s.firstFailedStatus), s.firstFailedJoint,
                        rangeLeftFields(s.firstFailedRange)}},
                      {"retried_frames", s.retriedFrames},
                      {"retries_kept", s.retriesKept},
                      {"residual_joints", std::move(residual)},
                      {"worst_joint", s.worstJoint},
                      {"worst_frame", s.worstFrame},
                      {"worst_rotation_joint", s.worstRotationJoint},
                      {"worst_rotation_frame", s.worstRotationFrame},
                      {"joint_frames", s.jointFrames},
                      {"real_rig_evaluations", s.realRigEvaluations},
                      {"contacts", std::move(contacts)},
                      {"multiplier_updates", s.multiplierUpdates},
                      {"curves_file_checksum", o.curvesChecksum},
                      {"bytes", {figureBytes.size(), numbers.size(), values.size(), o.curvesFrames.size()}}};
    std::string out = header.dump(-1, ' ', false, Json::error_handler_t::replace) + "\n";
    out.reserve(out.size() + figureBytes.size() + numbers.size() + values.size() + o.curvesFrames.size());
    return out.append(figureBytes).append(numbers).append(values).append(o.curvesFrames);
}

ShardOutput parseShardOutput(const std::string& bytes, const std::string& file, std::size_t parameters)
{
    const auto bad = [&](std::string_view why) {
        return Error(
            fmt::format("{}: not a rig-batch shard output ({}); remove it and run rig-batch again", file, why));
    };
    const std::size_t newline = bytes.find('\n');
    if (newline == std::string::npos) throw bad("no header line");
    ShardOutput o;
    try {
        const Json j = Json::parse(std::string_view(bytes).substr(0, newline));
        if (j.value("format", "") != shardFormat) throw bad(fmt::format("format '{}' expected", shardFormat));
        if (j.at("byte_order") != byteOrder()) throw bad("written on a machine of the other byte order");
        o.key = j.at("key").get<std::string>();
        o.first = j.at("first").get<int>();
        o.last = j.at("last").get<int>();
        if (o.first < 0 || o.last < o.first) throw bad(fmt::format("frames {} to {}", o.first, o.last));
        const auto sizes = j.at("bytes").get<std::array<std::size_t, 4>>();
        // Sizes and counts in 64 bits, each within the file before they are added: no sum wraps round.
        const std::size_t frames = static_cast<std::size_t>(o.last) - static_cast<std::size_t>(o.first) + 1;
        const std::size_t rest = bytes.size() - newline - 1;
        if (frames > rest / sizeof(double) || (parameters > 0 && frames > rest / sizeof(double) / parameters) ||
            std::any_of(sizes.begin(), sizes.end(), [&](std::size_t size) { return size > rest; }) ||
            sizes[0] != shardFigures * sizeof(double) || sizes[1] != frames * sizeof(double) ||
            sizes[2] != frames * parameters * sizeof(double) || sizes[0] + sizes[1] + sizes[2] + sizes[3] != rest)
            throw bad(fmt::format("its sizes are not those of {} frames of {} parameters", frames, parameters));
        const char* at = bytes.data() + newline + 1;
        std::array<double, shardFigures> figures{};
        std::memcpy(figures.data(), at, sizes[0]);
        at += sizes[0];
        o.frameNumbers.resize(frames);
        std::memcpy(o.frameNumbers.data(), at, sizes[1]);
        at += sizes[1];
        for (std::size_t f = 0; f < frames; ++f, at += parameters * sizeof(double)) {
            std::vector<double>& row = o.solved.emplace_back(parameters);
            std::memcpy(row.data(), at, parameters * sizeof(double));
        }
        o.curvesFrames.assign(at, sizes[3]);
        o.curvesChecksum = j.at("curves_file_checksum").get<std::string>();
        ClipInversionSummary& s = o.summary;
        s.maxPositionErrorCm = figures[0];
        s.maxRotationErrorDeg = figures[1];
        s.solveSeconds = figures[2];
        o.taskSeconds = figures[3];
        s.meanPositionErrorCm = figures[4];
        s.meanRotationErrorDeg = figures[5];
        s.maxModelGapCm = figures[6];
        s.solveCpuSeconds = figures[7];
        s.frames = j.at("frames").get<int>();
        s.statusFrames = j.at("status_frames").get<std::array<int, frameStatusCount>>();
        const Json& failure = j.at("first_failure");
        s.firstFailedFrame = failure.at(0).get<int>();
        const int status = failure.at(1).get<int>();
        if (status < 0 || status >= frameStatusCount) throw bad(fmt::format("no frame status {}", status));
        s.firstFailedStatus = static_cast<FrameStatus>(status);
        s.firstFailedJoint = failure.at(2).get<std::string>();
        s.retriedFrames = j.at("retried_frames").get<int>();
        s.retriesKept = j.at("retries_kept").get<int>();
        const auto figure = [](const Json& text) { return std::strtod(text.get<std::string>().c_str(), nullptr); };
        if (const Json& range = failure.at(3); !range.empty())
            s.firstFailedRange = {range.at(0).get<std::string>(),
                                  range.at(1).get<bool>(),
                                  figure(range.at(2)),
                                  figure(range.at(3)),
                                  figure(range.at(4)),
                                  figure(range.at(5))};
        for (const Json& joint : j.at("residual_joints"))
            s.residualJoints.push_back({joint.at(0).get<std::string>(), joint.at(1).get<int>(), figure(joint.at(2)),
                                        figure(joint.at(3)), figure(joint.at(4))});
        s.worstJoint = j.at("worst_joint").get<std::string>();
        s.worstFrame = j.at("worst_frame").get<int>();
        s.worstRotationJoint = j.at("worst_rotation_joint").get<std::string>();
        s.worstRotationFrame = j.at("worst_rotation_frame").get<int>();
        s.jointFrames = j.at("joint_frames").get<long long>();
        s.realRigEvaluations = j.at("real_rig_evaluations").get<long long>();
        readContactSlides(j, o, bad);
    }
    catch (const Json::exception& e) {
        throw bad(e.what());
    }
    if (const std::string problem = summaryProblem(o); !problem.empty()) throw bad(problem);
    return o;
}

std::string shardCurvesChecksum(const std::string& bytes)
{
    const std::size_t newline = bytes.find('\n');
    if (newline == std::string::npos) return "";
    const Json j = Json::parse(std::string_view(bytes).substr(0, newline), nullptr, false);
    return j.is_object() && j.value("curves_file_checksum", Json()).is_string()
               ? j["curves_file_checksum"].get<std::string>()
               : "";
}

}  // namespace rig::app
