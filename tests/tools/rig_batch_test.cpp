// rig-batch end to end on the local backend (the Slurm backend: tests/tools/rig_batch_slurm_test.sh): the
// merged curves equal rig-invert's on the whole clip byte for byte with 1 and 2 processes, shards shifted
// in the merge included; a second run skips finished shards and solves a corrupted one again; an
// interrupted batch loses nothing finished; a failing shard is reported with its error line and exit code 3;
// bad input is one line, exit code 2 and nothing written.
#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <unistd.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "learned_fixtures.h"
#include "test_support.h"

using namespace rig;
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

const fs::path cmuTurn = "/usr/share/assimp/models/BVH/01_03.bvh";

bool clipsInstalled()
{
    if (fs::exists(test::cmuClip) && fs::exists(cmuTurn)) return true;
    MESSAGE("[skipped] " << test::cmuClip << " and " << cmuTurn
                         << " are not installed (Debian package assimp-testmodels)");
    return false;
}

// `source` with only its first `frames` motion lines.
void cutBvh(const fs::path& source, int frames, const fs::path& out)
{
    std::ifstream in(source);
    std::ofstream o(out);
    std::string line;
    bool motion = false;
    int written = 0;
    while (std::getline(in, line)) {
        if (line.starts_with("Frames:")) line = fmt::format("Frames: {}", frames);
        else if (motion && written++ >= frames) continue;
        motion = motion || line.starts_with("Frame Time:");
        o << line << "\n";
    }
}

// Two clips in `folder`: 01_01's first 600 frames (a walk) and 01_03's first 720 (it turns round: shards
// from frame 481 on are shifted by whole turns in the merge).
fs::path libraryFolder(const fs::path& folder)
{
    fs::create_directories(folder);
    cutBvh(test::cmuClip, 600, folder / "walk.bvh");
    cutBvh(cmuTurn, 720, folder / "turn.bvh");
    return folder;
}

std::string inputs()
{
    return fmt::format("{} --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml",
                       test::bipedApproximation().string());
}

test::CommandResult rigBatch(const std::string& args) { return test::run(test::tool("rig-batch") + " " + args); }

// rig-invert on the whole clip, curves and report into `folder`.
void invertWhole(const fs::path& clip, const fs::path& folder)
{
    const auto r = test::run(fmt::format("{} {} --clip {} -o {} --report-json {} -q", test::tool("rig-invert"),
                                         inputs(), clip.string(), (folder / (clip.stem().string() + ".json")).string(),
                                         (folder / (clip.stem().string() + ".report.json")).string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
}

Json readJson(const fs::path& file) { return Json::parse(test::readFile(file)); }

}  // namespace

TEST_CASE(
    "rig-batch: a library on 1 and 2 local processes gives rig-invert's curves byte for byte and its figures, "
    "merged or written by a shard of a whole clip")
{
    if (!clipsInstalled()) return;
    const auto dir = test::scratchDir("rig_batch_local");
    const auto clips = libraryFolder(dir / "clips");
    for (const auto* name : {"walk.bvh", "turn.bvh"}) invertWhole(clips / name, dir);
    for (const int jobs : {1, 2}) {
        CAPTURE(jobs);
        const auto out = dir / fmt::format("out{}", jobs);
        const auto r = rigBatch(fmt::format("{} --clips {} --out {} --jobs {} --shard-frames 240", inputs(),
                                            clips.string(), out.string(), jobs));
        INFO(r.err);
        REQUIRE(r.exitCode == 0);
        CHECK(r.err.empty());
        CHECK(r.out.find("rig-batch: 2 clips, 6 shards (0 done before, 6 run on local, 0 failed)") !=
              std::string::npos);
        // The table says what its worst errors count, beside its failed frames.
        CHECK(r.out.find("\nworst cm, worst deg: the real rig's largest errors over a clip's frames, best fits "
                         "(least-squares answers) included;\nfailed: frames of any other status (docs/rig-invert.md); "
                         "the joints: residual_joints in report.json\n") != std::string::npos);
        const Json report = readJson(out / "report.json");
        CHECK(report["totals"]["shards_run"] == 6);
        CHECK(report["totals"]["frames_run"] == 1320);
        CHECK(report["totals"]["frames_per_second"].get<double>() > 0.0);
        CHECK(report["failed_shards"].empty());
        REQUIRE(report["clips"].size() == 2);
        for (const Json& clip : report["clips"]) {
            const std::string name = clip["name"];
            CAPTURE(name);
            CHECK(test::readFile(out / (name + ".json")) == test::readFile(dir / (name + ".json")));
            CHECK(clip["curves"]["file"] == (out / (name + ".json")).string());
            // Counts as one run makes them; errors measured by each shard on its own values (the same poses
            // where the merge shifted a shard: equal up to rounding).
            const Json whole = readJson(dir / (name + ".report.json"));
            for (const char* key :
                 {"frames", "status_frames", "failed_frames", "first_failure", "retried_frames", "retries_kept",
                  "worst_joint", "worst_frame", "worst_rotation_joint", "worst_rotation_frame"})
                CHECK(clip[key] == whole[key]);
            CHECK(clip["mean_position_error_cm"].get<double>() ==
                  doctest::Approx(whole["mean_position_error_cm"].get<double>()).epsilon(1e-9));
            CHECK(clip["max_position_error_cm"].get<double>() ==
                  doctest::Approx(whole["max_position_error_cm"].get<double>()).epsilon(1e-9));
            CHECK(clip["max_rotation_error_deg"].get<double>() ==
                  doctest::Approx(whole["max_rotation_error_deg"].get<double>()).epsilon(1e-9));
            // The residual joints joined over the shards: one run's, joint by joint, each one's worst position and
            // rotation apart.
            REQUIRE(clip["residual_joints"].size() == whole["residual_joints"].size());
            auto joint = clip["residual_joints"].begin();
            for (auto expected = whole["residual_joints"].begin(); expected != whole["residual_joints"].end();
                 ++expected, ++joint) {
                CHECK(joint.key() == expected.key());
                CHECK(joint.value()["frames"] == expected.value()["frames"]);
                for (const char* figure : {"worst_position_error_cm", "worst_rotation_error_deg"})
                    CHECK(joint.value()[figure].get<double>() ==
                          doctest::Approx(expected.value()[figure].get<double>()).epsilon(1e-9));
            }
            CHECK(clip["ms_per_frame"].get<double>() > 0.0);
        }
    }
    // One shard per clip (the default size): each task writes its clip's curves, nothing is merged. A curves
    // file removed since is a shard to solve again.
    const auto out = dir / "whole";
    const std::string whole = fmt::format("{} --clips {} --out {} -q", inputs(), clips.string(), out.string());
    auto r = rigBatch(whole);
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK(readJson(out / "report.json")["totals"]["shards"] == 2);
    fs::remove(out / "walk.json");
    r = rigBatch(whole);
    REQUIRE(r.exitCode == 0);
    CHECK(readJson(out / "report.json")["totals"]["shards_run"] == 1);
    for (const char* name : {"walk.json", "turn.json"}) CHECK(test::readFile(out / name) == test::readFile(dir / name));

    // turn's last shard (frames 481 to 720) alone is whole turns away from one run: the merge shifted it.
    r = test::run(fmt::format("{} {} --clip {} --frames 481:720 -o {} -q", test::tool("rig-invert"), inputs(),
                              (clips / "turn.bvh").string(), (dir / "alone.json").string()));
    REQUIRE(r.exitCode == 0);
    const Json alone = readJson(dir / "alone.json"), oneRun = readJson(dir / "turn.json");
    CHECK(alone != Json(oneRun.begin() + 480, oneRun.end()));
}

TEST_CASE(
    "rig-batch: a second run skips finished shards, solves a corrupted one again, and loses nothing to an "
    "interrupted run")
{
    if (!clipsInstalled()) return;
    const auto dir = test::scratchDir("rig_batch_resume");
    const auto clips = libraryFolder(dir / "clips");
    for (const auto* name : {"walk.bvh", "turn.bvh"}) invertWhole(clips / name, dir);
    const auto out = dir / "out";
    const std::string library = fmt::format("{} --clips {} --out {} -q", inputs(), clips.string(), out.string());
    const std::string args = library + " --shard-frames 120";
    const auto totals = [&] { return readJson(out / "report.json")["totals"]; };
    const auto sameCurves = [&] {
        for (const char* name : {"walk.json", "turn.json"})
            CHECK(test::readFile(out / name) == test::readFile(dir / name));
    };

    // Interrupted (the driver and its workers killed, as by Ctrl-C; a background job of sh ignores SIGINT, so
    // SIGTERM) once the first shard is done.
    const auto killed = test::run(fmt::format(
        "setsid {} {} --jobs 1 & p=$!; for i in $(seq 600); do ls {}/*.status.json >/dev/null 2>&1 && break; "
        "sleep 0.05; done; kill -TERM -$p; wait $p; echo $?",
        test::tool("rig-batch"), args, (out / "shards").string()));
    CHECK(killed.out == "143\n");
    CHECK_FALSE(fs::exists(out / "walk.json"));
    CHECK_FALSE(fs::exists(out / "report.json"));
    auto r = rigBatch(args);
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK(totals()["shards_reused"].get<int>() >= 1);
    CHECK(totals()["shards_reused"].get<int>() + totals()["shards_run"].get<int>() == 11);
    sameCurves();

    // Everything done: nothing is solved again.
    r = rigBatch(args);
    REQUIRE(r.exitCode == 0);
    CHECK(totals()["shards_reused"] == 11);
    CHECK(totals()["shards_run"] == 0);
    sameCurves();

    // A shard's output changed after it was done: its checksum no longer matches the manifest's.
    const Json manifest = readJson(out / "manifest.json");
    const std::string key = manifest["shards"][7]["key"];
    CHECK(manifest["shards"][7]["checksum"].is_string());
    const fs::path shard = out / "shards" / (key + ".shard");
    {
        std::fstream f(shard, std::ios::in | std::ios::out | std::ios::binary);
        f.seekp(200);
        f.put('#');
    }
    r = rigBatch(args);
    REQUIRE(r.exitCode == 0);
    CHECK(totals()["shards_reused"] == 10);
    CHECK(totals()["shards_run"] == 1);
    sameCurves();

    // Without the manifest's record (a driver killed before it wrote one), the tasks' status records keep
    // what finished.
    fs::remove(out / "manifest.json");
    r = rigBatch(args);
    REQUIRE(r.exitCode == 0);
    CHECK(totals()["shards_reused"] == 11);

    // Longer shards: the old files go, and only walk's last shard (frames 481 to 600 either way) is kept.
    r = rigBatch(library + " --shard-frames 240");
    REQUIRE(r.exitCode == 0);
    CHECK(totals()["shards_reused"] == 1);
    CHECK(totals()["shards_run"] == 5);
    CHECK_FALSE(fs::exists(shard));
    sameCurves();
}

TEST_CASE("rig-batch: --contacts auto gives rig-invert's curves and contacts, a contact spanning shards joined")
{
    if (!clipsInstalled()) return;
    const auto dir = test::scratchDir("rig_batch_contacts");
    fs::create_directories(dir / "clips");
    cutBvh(test::cmuClip, 600, dir / "clips" / "walk.bvh");
    auto r = test::run(fmt::format("{} {} --clip {} --contacts auto -o {} --report-json {} -q",
                                   test::tool("rig-invert"), inputs(), (dir / "clips" / "walk.bvh").string(),
                                   (dir / "walk.json").string(), (dir / "walk.report.json").string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    // Shards of 120 frames: contacts cross their boundaries.
    r = rigBatch(fmt::format("{} --clips {} --out {} --jobs 2 --shard-frames 120 --contacts auto -q", inputs(),
                             (dir / "clips").string(), (dir / "out").string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK(test::readFile(dir / "out" / "walk.json") == test::readFile(dir / "walk.json"));
    const Json whole = readJson(dir / "walk.report.json")["contacts"];
    const Json merged = readJson(dir / "out" / "report.json")["clips"][0]["contacts"];
    REQUIRE(whole["count"].get<int>() >= 2);
    CHECK(merged["count"] == whole["count"]);
    CHECK(merged["multiplier_updates"] == whole["multiplier_updates"]);
    REQUIRE(merged["per_contact"].size() == whole["per_contact"].size());
    bool spans = false;
    for (std::size_t i = 0; i < whole["per_contact"].size(); ++i) {
        const Json& a = merged["per_contact"][i];
        const Json& b = whole["per_contact"][i];
        CHECK(a["joint"] == b["joint"]);
        CHECK(a["first_frame"] == b["first_frame"]);
        CHECK(a["last_frame"] == b["last_frame"]);
        CHECK(a["slide_cm"].get<double>() == doctest::Approx(b["slide_cm"].get<double>()).epsilon(1e-6));
        spans = spans || (b["first_frame"].get<int>() - 1) / 120 != (b["last_frame"].get<int>() - 1) / 120;
    }
    CHECK(spans);
    CHECK(merged["max_slide_cm"].get<double>() < 0.01);
}

TEST_CASE("rig-batch: a shard that fails is listed with its error line, exit code 3, and solved by the next run")
{
    if (!clipsInstalled()) return;
    const auto dir = test::scratchDir("rig_batch_failing");
    const auto clips = libraryFolder(dir / "clips");
    invertWhole(clips / "walk.bvh", dir);
    const auto out = dir / "out";
    const std::string args = fmt::format("{} --clips {} --out {} --shard-frames 240 --jobs 2 --retries 0 -q", inputs(),
                                         clips.string(), out.string());
    REQUIRE(rigBatch(args).exitCode == 0);
    // Shard 4 (walk, frames 241 to 480) cannot write its output: a folder is in its place.
    const std::string key = readJson(out / "manifest.json")["shards"][4]["key"];
    const fs::path shard = out / "shards" / (key + ".shard");
    fs::remove(shard);
    fs::create_directory(shard);
    auto r = rigBatch(args);
    CHECK(r.exitCode == 3);
    CHECK(r.out.empty());
    CHECK(r.err == fmt::format("error: 1 of 6 shards failed (shard 4 (walk frames 241:480): error: {}: is a folder; "
                               "give a file name, e.g. -o {}/out.json); their clips have no curves; run rig-batch "
                               "again to retry them (finished shards are kept)\n",
                               shard.string(), shard.string()));
    const Json report = readJson(out / "report.json");
    REQUIRE(report["failed_shards"].size() == 1);
    CHECK(report["failed_shards"][0]["shard"] == 4);
    CHECK(report["failed_shards"][0]["clip"] == "walk");
    CHECK(report["failed_shards"][0]["frames"] == "241:480");
    CHECK(report["failed_shards"][0]["error"].get<std::string>().starts_with("error: " + shard.string()));
    CHECK(report["totals"]["shards_failed"] == 1);
    // The failing clip has no curves; the other one is whole.
    CHECK(report["clips"][1]["name"] == "walk");
    CHECK(report["clips"][1]["complete"] == false);
    CHECK(report["clips"][1]["curves"].is_null());
    CHECK_FALSE(fs::exists(out / "walk.json"));
    CHECK(report["clips"][0]["complete"] == true);
    CHECK(fs::exists(out / "turn.json"));
    // The task's own output names the error too.
    CHECK(test::readFile(out / "logs" / (key + ".log")).starts_with("error: " + shard.string()));

    fs::remove(shard);
    r = rigBatch(args);
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK(readJson(out / "report.json")["totals"]["shards_run"] == 1);
    CHECK(test::readFile(out / "walk.json") == test::readFile(dir / "walk.json"));
}

TEST_CASE("rig-batch: bad input is one error line and exit code 2, and writes nothing")
{
    if (!clipsInstalled()) return;
    const auto dir = test::scratchDir("rig_batch_bad_input");
    const auto clips = libraryFolder(dir / "clips");
    const auto out = dir / "out";
    fs::create_directories(dir / "empty");
    fs::create_directories(dir / "named");
    fs::copy_file(clips / "walk.bvh", dir / "named" / "report.bvh");
    fs::create_directories(dir / "other");
    fs::copy_file(clips / "walk.bvh", dir / "other" / "turn.bvh");
    test::writeFile(dir / "file", "not a folder\n");
    const std::string library = fmt::format("{} --clips {}", inputs(), clips.string());
    const struct {
        std::string args;
        std::string error;  // the start of the line
    } cases[] = {
        {fmt::format("{} --clips {}/missing.bvh --out {}", inputs(), dir.string(), out.string()),
         fmt::format("error: --clips {}/missing.bvh: no such file or folder", dir.string())},
        {fmt::format("{} --out {} --backend pbs", library, out.string()),
         "error: --backend pbs: expected local (processes on this machine) or slurm"},
        {fmt::format("{} --out {} --jobs 0", library, out.string()), "error: --jobs 0: give 1 or more processes"},
        {fmt::format("{} --out {} --jobs -2", library, out.string()), "error: --jobs -2: give 1 or more processes"},
        {fmt::format("{} --out {} --jobs many", library, out.string()),
         "error: --jobs: 'many' is not a whole number in range"},
        {fmt::format("{} --out {} --shard-frames 0", library, out.string()),
         "error: --shard-frames 0: give 1 or more frames per shard"},
        {fmt::format("{} --out {} --retries -1", library, out.string()), "error: --retries -1: give 0 or more"},
        {fmt::format("{} --out {} --restart-every 0", library, out.string()), "error: --restart-every 0: give 1 or"},
        {fmt::format("{} --clips {}/empty --out {}", inputs(), dir.string(), out.string()),
         fmt::format("error: --clips {}/empty: the folder holds no clip (BVH, FBX, glTF, Collada, ..., .json)",
                     dir.string())},
        // A file given by name is read by its content: this one is no clip of any format.
        {fmt::format("{} --clips {}/file --out {}", inputs(), dir.string(), out.string()),
         fmt::format("error: {}/file: assimp cannot read it: No suitable reader found", fs::absolute(dir).string())},
        {fmt::format("{} --clips {}/named --out {}", inputs(), dir.string(), out.string()),
         fmt::format("error: --clips {}/named/report.bvh: its curves would be report.json", dir.string())},
        {fmt::format("{} {}/other --out {}", library, dir.string(), out.string()),
         fmt::format("error: --clips: {}/turn.bvh and {}/other/turn.bvh would both write turn.json", clips.string(),
                     dir.string())},
        {fmt::format("{} --out {}/file", library, dir.string()),
         fmt::format("error: --out {}/file: is a file; give a folder", dir.string())},
        {fmt::format("{} --rig rigs/biped.yaml --clips {} --out {}", (dir / "missing.yaml").string(), clips.string(),
                     out.string()),
         fmt::format("error: {}/missing.yaml", dir.string())},
        {fmt::format("{} --rig rigs/biped.yaml --out {}", test::bipedApproximation().string(), out.string()),
         "error: --clips: give clip files"},
        {fmt::format("PATH=/nonexistent {} {} --out {} --backend slurm", test::tool("rig-batch"), library,
                     out.string()),
         "error: --backend slurm: sbatch is not on PATH"},
        {fmt::format("--out {} --task 3", out.string()),
         fmt::format("error: {}/manifest.json: cannot read it", out.string())},
    };
    for (const auto& c : cases) {
        CAPTURE(c.args);
        const auto r = c.args.starts_with("PATH=") ? test::run(c.args) : rigBatch(c.args);
        CHECK(r.exitCode == 2);
        CHECK(r.out.empty());
        CHECK(r.err.starts_with(c.error));
        CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
        CHECK_FALSE(fs::exists(out));
    }
}

TEST_CASE("rig-batch: shard sizes and restart intervals near INT_MAX make whole shards, rig-invert's curves")
{
    if (!clipsInstalled()) return;
    const auto dir = test::scratchDir("rig_batch_int_max");
    fs::create_directories(dir / "clips");
    cutBvh(test::cmuClip, 60, dir / "clips" / "walk.bvh");
    // Each once rounded a shard's size past INT_MAX: a crash, or shards without end until memory ran out.
    const struct {
        std::string flags;
        std::string restart;  // rig-invert's, for the same curves
    } cases[] = {{"--shard-frames 2147483529", ""},
                 {"--restart-every 2147478849", "--restart-every 2147478849"},
                 {"--restart-every 2147483647", "--restart-every 2147483647"},
                 {"--shard-frames 2147483647 --restart-every 2147483646", "--restart-every 2147483646"}};
    for (const auto& c : cases) {
        CAPTURE(c.flags);
        const auto out = dir / "out";
        fs::remove_all(out);
        const auto r = rigBatch(
            fmt::format("{} --clips {} --out {} -q {}", inputs(), (dir / "clips").string(), out.string(), c.flags));
        INFO(r.err);
        REQUIRE(r.exitCode == 0);
        CHECK(readJson(out / "report.json")["totals"]["shards"] == 1);
        const auto whole =
            test::run(fmt::format("{} {} --clip {} -o {} -q {}", test::tool("rig-invert"), inputs(),
                                  (dir / "clips" / "walk.bvh").string(), (dir / "walk.json").string(), c.restart));
        REQUIRE(whole.exitCode == 0);
        CHECK(test::readFile(out / "walk.json") == test::readFile(dir / "walk.json"));
    }
}

TEST_CASE("rig-batch: a link loop, a link to nothing or into a folder it may not read in --clips is one line naming it")
{
    if (!clipsInstalled()) return;
    const auto dir = test::scratchDir("rig_batch_links");
    fs::create_directories(dir / "clips");
    cutBvh(test::cmuClip, 60, dir / "clips" / "walk.bvh");
    const auto out = dir / "out";
    const auto expectError = [&](const std::string& prefix, const fs::path& clips, const std::string& error) {
        const auto r = test::run(fmt::format("{}{} {} --clips {} --out {}", prefix, test::tool("rig-batch"), inputs(),
                                             clips.string(), out.string()));
        CHECK(r.exitCode == 2);
        CHECK(r.out.empty());
        CHECK(r.err == error + "\n");
        CHECK_FALSE(fs::exists(out));
    };
    const fs::path loop = dir / "clips" / "loop.bvh";
    fs::create_symlink("loop.bvh", loop);
    const std::string loopError = fmt::format(
        "error: --clips {}: cannot read it (Too many levels of symbolic links); fix or remove it, or give the "
        "clips without it",
        loop.string());
    expectError("", dir / "clips", loopError);
    expectError("", loop, loopError);
    fs::remove(loop);
    const fs::path dangling = dir / "clips" / "gone.bvh";
    fs::create_symlink("missing.bvh", dangling);
    expectError("", dir / "clips",
                fmt::format("error: --clips {}: a link to nothing; fix or remove it, or give the clips without it",
                            dangling.string()));
    fs::remove(dangling);

    // Permissions bind root only through setpriv: as root, run as user nobody.
    std::string prefix;
    if (::geteuid() == 0) {
        if (test::run("command -v setpriv").exitCode != 0) {
            MESSAGE("[skipped] the unreadable-folder cases: root without setpriv");
            return;
        }
        prefix = "setpriv --reuid=65534 --regid=65534 --clear-groups ";
    }
    fs::create_directories(dir / "locked");
    fs::copy_file(dir / "clips" / "walk.bvh", dir / "locked" / "run.bvh");
    fs::permissions(dir / "locked", fs::perms::none);
    const fs::path inside = dir / "clips" / "run.bvh";
    fs::create_symlink(dir / "locked" / "run.bvh", inside);
    expectError(prefix, dir / "clips",
                fmt::format("error: --clips {}: cannot read it (Permission denied); fix or remove it, or give the "
                            "clips without it",
                            inside.string()));
    fs::remove(inside);
    fs::create_symlink(dir / "locked", dir / "linked");
    expectError(prefix, dir / "linked",
                fmt::format("error: --clips {}: cannot list the folder (Permission denied); give a folder you may read",
                            (dir / "linked").string()));
    fs::permissions(dir / "locked", fs::perms::owner_all);
}

TEST_CASE(
    "rig-batch: stopped by SIGTERM or killed by SIGKILL, its local tasks die with it and hold the folder's lock until "
    "they are gone, and no orphan writes over the next run")
{
    if (!clipsInstalled()) return;
    const auto dir = test::scratchDir("rig_batch_stopped");
    const auto clips = dir / "clips";
    fs::create_directories(clips);
    cutBvh(test::cmuClip, 600, clips / "walk.bvh");
    cutBvh(cmuTurn, 600, clips / "turn.bvh");
    for (const auto* name : {"walk.bvh", "turn.bvh"}) invertWhole(clips / name, dir);
    const auto out = dir / "out";
    const std::string library = fmt::format("{} --clips {} --out {} -q", inputs(), clips.string(), out.string());
    // The tasks' processes (--tas[k]: not the shell that runs the pattern). Scripts in ( ): test::run's
    // redirections apply to the whole of them.
    const std::string tasks = fmt::format("pgrep -f -- '--out {} --tas[k]'", out.string());
    for (const std::string signal : {"TERM", "KILL"}) {
        CAPTURE(signal);
        fs::remove_all(out);
        // Slow tasks (finite differences, polished on the real rig: seconds each), stopped while they run: the
        // script prints whether the first task holds the lock file open, rig-batch's exit code, and "gone" once
        // no task is left (within 2 s).
        const auto r = test::run(
            fmt::format("({} {} --jacobian fd --polish 5 --shard-frames 600 --jobs 2 & p=$!; "
                        "for i in $(seq 600); do t=$({} | head -1); [ -n \"$t\" ] && break; sleep 0.05; done; "
                        "ls -l /proc/$t/fd | grep -c -- '-> {}/.rig-batch.lock$'; kill -{} $p; wait $p; echo $?; "
                        "for i in $(seq 40); do {} >/dev/null || break; sleep 0.05; done; {} || echo gone)",
                        test::tool("rig-batch"), library, tasks, out.string(), signal, tasks, tasks));
        CHECK(r.out == fmt::format("1\n{}\ngone\n", signal == "TERM" ? 143 : 137));
        // The next run, with other settings (the old tasks' curves would differ): its curves stay its own.
        const auto next = rigBatch(library);
        INFO(next.err);
        REQUIRE(next.exitCode == 0);
        std::this_thread::sleep_for(std::chrono::seconds(3));  // longer than an old task had left to run
        CHECK(test::run(tasks).out.empty());
        for (const char* name : {"walk.json", "turn.json"})
            CHECK(test::readFile(out / name) == test::readFile(dir / name));
    }
}

TEST_CASE("rig-batch: stopped by SIGTERM while Slurm runs its tasks, it cancels its jobs with scancel")
{
    if (!clipsInstalled()) return;
    const auto dir = test::scratchDir("rig_batch_scancel");
    fs::create_directories(dir / "clips");
    cutBvh(test::cmuClip, 60, dir / "clips" / "walk.bvh");
    // A stand-in for Slurm's client: sbatch takes the job (its id, then waiting as sbatch --wait does) and
    // records its arguments; scancel records its arguments.
    const auto bin = dir / "bin";
    fs::create_directories(bin);
    test::writeFile(bin / "sbatch", fmt::format("#!/bin/sh\n"
                                                "case \"$*\" in *--test-only*) exit 0;; esac\n"
                                                "echo \"$*\" >{0}/sbatch.args\n"
                                                "echo $$ >{0}/sbatch.pid\n"
                                                "echo 4242\n"
                                                "exec sleep 600\n",
                                                dir.string()));
    test::writeFile(bin / "scancel", fmt::format("#!/bin/sh\necho \"$*\" >>{}/scancel.args\n", dir.string()));
    fs::permissions(bin / "sbatch", fs::perms::owner_all);
    fs::permissions(bin / "scancel", fs::perms::owner_all);
    const auto out = dir / "out";
    const auto r = test::run(
        fmt::format("(PATH={}:$PATH {} {} --clips {} --out {} --backend slurm -q & p=$!; "
                    "for i in $(seq 600); do grep -qs 4242 {}/slurm/round-0-0.sbatch.log && break; sleep 0.05; done; "
                    "kill -TERM $p; wait $p; echo $?; s=$(cat {}/sbatch.pid); "
                    "for i in $(seq 40); do kill -0 $s 2>/dev/null || break; sleep 0.05; done; "
                    "kill -0 $s 2>/dev/null || echo stopped)",
                    bin.string(), test::tool("rig-batch"), inputs(), (dir / "clips").string(), out.string(),
                    out.string(), dir.string()));
    CHECK(r.out == "143\nstopped\n");
    const std::string submitted = test::readFile(dir / "sbatch.args");
    const auto name = submitted.find("--job-name=rig-batch-");
    REQUIRE(name != std::string::npos);
    const std::string job = submitted.substr(name + 11, 18);  // rig-batch- and 8 hex digits
    CHECK(job.find_first_not_of("0123456789abcdef", 10) == std::string::npos);
    const std::string user = test::run("id -un").out;  // with its newline
    CHECK(test::readFile(dir / "scancel.args") == fmt::format("--name={} --user={}", job, user));
}

namespace {

// batch_manifest.h's checksumText: FNV-1a 64 over 8-byte words, then the bytes left one by one.
std::string checksumText(const std::string& bytes)
{
    std::uint64_t hash = 0xcbf29ce484222325ull;
    std::size_t i = 0;
    for (std::uint64_t word = 0; i + sizeof(word) <= bytes.size(); i += sizeof(word)) {
        std::memcpy(&word, bytes.data() + i, sizeof(word));
        hash = (hash ^ word) * 0x100000001b3ull;
    }
    for (; i < bytes.size(); ++i) hash = (hash ^ static_cast<unsigned char>(bytes[i])) * 0x100000001b3ull;
    return fmt::format("{:016x}", hash);
}

}  // namespace

TEST_CASE("rig-batch: clip names that cannot round-trip or name a file are refused when planning, and 240 bytes work")
{
    if (!clipsInstalled()) return;
    const auto dir = test::scratchDir("rig_batch_names");
    const auto out = dir / "out";
    const auto refused = [&](const fs::path& clips, const std::string& error) {
        const auto r = rigBatch(fmt::format("{} --clips {} --out {}", inputs(), clips.string(), out.string()));
        CHECK(r.exitCode == 2);
        CHECK(r.err == error + "\n");
        CHECK_FALSE(fs::exists(out));
    };
    // Bytes that are not UTF-8: the manifest (JSON) would hold U+FFFD instead, and every task would fail.
    fs::create_directories(dir / "latin1");
    cutBvh(test::cmuClip, 60, dir / "latin1" / "caf\xe9.bvh");
    refused(dir / "latin1",
            fmt::format("error: --clips {}/latin1/caf\\xe9.bvh: its path is not UTF-8, which the batch's manifest "
                        "(JSON) cannot hold; rename it",
                        dir.string()));
    // 251 bytes and .json: over the 255 a file name may have.
    fs::create_directories(dir / "long");
    const std::string tooLong(251, 'w');
    cutBvh(test::cmuClip, 60, dir / "long" / (tooLong + ".bvh"));
    refused(dir / "long" / (tooLong + ".bvh"),
            fmt::format("error: --clips {}/long/{}.bvh: its curves would be {}.json, a name of 256 bytes, longer than "
                        "the 255 file systems take; rename the clip",
                        dir.string(), tooLong, tooLong));
    // 240 bytes: a legal name whose temporary file (".NAME.json.PID.XXXXXX.tmp") is not, cut to fit, in
    // rig-batch's task and in rig-invert -o alike.
    const std::string stem(240, 'w');
    const fs::path clip = dir / "long" / (stem + ".bvh");
    cutBvh(test::cmuClip, 60, clip);
    auto r = rigBatch(fmt::format("{} --clips {} --out {} -q", inputs(), clip.string(), out.string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    r = test::run(fmt::format("{} {} --clip {} -o {} -q", test::tool("rig-invert"), inputs(), clip.string(),
                              (dir / (stem + ".json")).string()));
    REQUIRE(r.exitCode == 0);
    CHECK(test::readFile(out / (stem + ".json")) == test::readFile(dir / (stem + ".json")));
    for (const auto& entry : fs::directory_iterator(dir)) CHECK_FALSE(entry.path().extension() == ".tmp");

    // A manifest edited to name a clip ../x: its task would write x.json beside --out.
    Json manifest = readJson(out / "manifest.json");
    manifest["clips"][0]["name"] = "../x";
    test::writeFile(out / "manifest.json", manifest.dump(2));
    r = rigBatch(fmt::format("--out {} --task 0", out.string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err == fmt::format("error: {}/manifest.json: not a rig-batch manifest (clip 0's curves would be ../x.json, "
                               "which is not a file name in the output folder); remove it and run rig-batch again\n",
                               out.string()));
    CHECK_FALSE(fs::exists(dir / "x.json"));
}

TEST_CASE(
    "rig-batch: the merge checks every shard header field before it trusts it, and names the clip and shards "
    "whose curves a full disk refused")
{
    if (!clipsInstalled()) return;
    const auto dir = test::scratchDir("rig_batch_headers");
    fs::create_directories(dir / "clips");
    cutBvh(test::cmuClip, 240, dir / "clips" / "walk.bvh");
    const auto out = dir / "out";
    const std::string args =
        fmt::format("{} --clips {} --out {} --shard-frames 120 -q", inputs(), (dir / "clips").string(), out.string());
    REQUIRE(rigBatch(args).exitCode == 0);
    const std::string curves = test::readFile(out / "walk.json");
    const Json manifest = readJson(out / "manifest.json");
    const std::string key = manifest["shards"][1]["key"];
    const fs::path shard = out / "shards" / (key + ".shard");
    const std::string original = test::readFile(shard);
    const std::size_t newline = original.find('\n');
    const Json header = Json::parse(original.substr(0, newline));

    // Each edit with the checksums recomputed (in the manifest and the status record), as a tool would: the
    // merge refuses the shard (exit code 3, its error line), where some edits used to crash it.
    const struct {
        const char* field;
        Json value;
        std::string why;
    } edits[] = {
        {"worst_frame", 100000, "a frame index outside 120 to 239"},
        {"worst_rotation_frame", -7, "a frame index outside 120 to 239"},
        {"first_failure", Json::array({100000, 2, "Hips", Json::array()}), "a frame index outside 120 to 239"},
        {"frames", 1, "1 frames counted in frames 120 to 239"},
        {"status_frames", Json::array({1000, 0, 0, 0, 0, 0}), "a count of frames outside 0 to 120"},
        {"status_frames", Json::array({1, 0, 0, 0, 0, 0}), "frame statuses for 1 of 120 frames"},
        {"residual_joints", Json::array({Json::array({"Hips", -1, "0.5", "2", "0.5"})}),
         "joint Hips missed on -1 of 120 frames"},
        {"bytes", Json::array({header["bytes"][0], header["bytes"][1], header["bytes"][2], 18446744073709551615ull}),
         "its sizes are not those of 120 frames of 79 parameters"},
        {"first", -5, "frames -5 to 239"},
    };
    for (const auto& edit : edits) {
        CAPTURE(edit.field);
        Json edited = header;
        edited[edit.field] = edit.value;
        const std::string bytes = edited.dump() + original.substr(newline);
        test::writeFile(shard, bytes);
        Json m = manifest;
        m["shards"][1]["checksum"] = checksumText(bytes);
        test::writeFile(out / "manifest.json", m.dump(2));
        Json status = readJson(out / "shards" / (key + ".status.json"));
        status["checksum"] = checksumText(bytes);
        test::writeFile(out / "shards" / (key + ".status.json"), status.dump(2));
        const auto r = rigBatch(args);
        CHECK(r.exitCode == 3);
        CHECK(r.err == fmt::format("error: 1 of 2 shards failed (shard 1 (walk frames 121:240): error: {}: not a "
                                   "rig-batch shard output ({}); remove it and run rig-batch again); their clips have "
                                   "no curves; run rig-batch again to retry them (finished shards are kept)\n",
                                   shard.string(), edit.why));
        CHECK_FALSE(fs::exists(out / "walk.json"));
    }
    fs::remove(shard);
    REQUIRE(rigBatch(args).exitCode == 0);
    CHECK(test::readFile(out / "walk.json") == curves);

    // A full disk (a file size limit here: writes fail as they would) while the merge writes the curves: one
    // line naming the clip and its shards, which stay done for the next run.
    fs::remove(out / "walk.json");
    const auto r = test::run(fmt::format("(trap '' XFSZ; ulimit -f 100; {} {})", test::tool("rig-batch"), args));
    CHECK(r.exitCode == 2);
    CHECK(r.err == fmt::format("error: the merge could not write the curves of 1 of 1 clips: walk (shards 0 to 1, "
                               "frames 1:240): {}/walk.json: writing failed (File too large); check the free space "
                               "and the folder's permissions; their shards are done and kept: run rig-batch again "
                               "to merge them\n",
                               out.string()));
    CHECK_FALSE(fs::exists(out / "report.json"));
    const auto again = rigBatch(args);
    REQUIRE(again.exitCode == 0);
    CHECK(readJson(out / "report.json")["totals"]["shards_reused"] == 2);
    CHECK(test::readFile(out / "walk.json") == curves);
}
