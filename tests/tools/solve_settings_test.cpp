// The solve settings' table (app/common/solve_settings.h) against everything made from it: every row is a rig-invert
// flag, a rig-batch flag, a manifest field and a Python keyword (the module's signature and riginv.pyi), each with the
// table's default; non-default settings round-trip through the manifest; a bad value of each kind is the table's one
// line with exit code 2 in both command lines and in a manifest.
#include <doctest/doctest.h>

#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "app/batch/batch_manifest.h"
#include "app/common/solve_settings.h"
#include "test_support.h"

using namespace rig;
namespace fs = std::filesystem;
using Json = nlohmann::json;
using app::SettingKind;

namespace {

const fs::path armClip = "tests/corpus/clips/arm.json";

// The arm's approximation (shoulder and elbow), learned once.
fs::path armApproximation()
{
    static const fs::path file = [] {
        // Per process: CTest runs this file's cases side by side, each learning its own.
        const fs::path out = test::scratchDir(fmt::format("solve_settings_arm.{}", ::getpid())) / "arm.approx.yaml";
        const auto r =
            test::run(fmt::format("{} rigs/examples/arm.yaml --params 'shoulder.rotate?' 'elbow.rotate?' -o {}",
                                  test::tool("rig-learn"), out.string()));
        INFO(r.err);
        REQUIRE(r.exitCode == 0);
        return out;
    }();
    return file;
}

std::string batchInputs(const fs::path& out)
{
    return fmt::format("{} {} --rig rigs/examples/arm.yaml --clips {} --out {} --jobs 1 -q", test::tool("rig-batch"),
                       armApproximation().string(), armClip.string(), out.string());
}

// The line of `help` that lists `flag`, "" when none does.
std::string helpLine(const std::string& help, const std::string& flag)
{
    std::size_t at = 0;
    while ((at = help.find(flag + " ", at)) != std::string::npos) {
        const std::size_t start = help.rfind('\n', at) + 1;
        // The flag itself, not a mention of it in another flag's help.
        if (help.find_first_not_of(' ', start) == at) return help.substr(start, help.find('\n', at) - start);
        at += flag.size();
    }
    return "";
}

// What a command line's --help shows of a row: a count or a choice ends its help with its default in `defaults`;
// a flag, off by default, shows none.
void checkHelp(const std::string& tool, const app::SolveSettings& defaults)
{
    const auto r = test::run(test::tool(tool) + " --help");
    REQUIRE(r.exitCode == 0);
    for (const app::SolveSetting& s : app::solveSettings()) {
        const std::string line = helpLine(r.out, app::settingName(s, app::Spelling::flag));
        CAPTURE(tool);
        CAPTURE(s.name);
        REQUIRE_FALSE(line.empty());
        if (s.kind == SettingKind::flag) CHECK(line.find("(default") == std::string::npos);
        else CHECK(line.ends_with(fmt::format("(default {})", app::settingText(s, s.get(defaults)))));
    }
}

// A value of a row as the manifest holds it.
Json manifestValue(const app::SolveSetting& s, int value)
{
    if (s.kind == SettingKind::count) return value;
    if (s.kind == SettingKind::flag) return value != 0;
    return app::settingText(s, value);
}

// A value of a row as Python writes it: 1, False, 'analytic' (repr), or "analytic" in the stub.
std::string pythonValue(const app::SolveSetting& s, int value, char quote)
{
    if (s.kind == SettingKind::count) return std::to_string(value);
    if (s.kind == SettingKind::flag) return value ? "True" : "False";
    return fmt::format("{}{}{}", quote, app::settingText(s, value), quote);
}

// Every row set to a value other than its default in `defaults` (--hybrid with --polish is refused: the hybrid
// switch is left off).
app::SolveSettings nonDefault(const app::SolveSettings& defaults)
{
    app::SolveSettings out = defaults;
    for (const app::SolveSetting& s : app::solveSettings()) {
        const int value = s.get(defaults);
        if (s.name == "hybrid") continue;
        s.set(out, s.kind == SettingKind::count ? value + 2 : value == 0 ? 1 : 0);
    }
    return out;
}

std::string flagsOf(const app::SolveSettings& settings)
{
    std::string out;
    for (const app::SolveSetting& s : app::solveSettings()) {
        const int value = s.get(settings);
        const std::string flag = app::settingName(s, app::Spelling::flag);
        if (s.kind != SettingKind::flag) out += fmt::format(" {} {}", flag, app::settingText(s, value));
        else if (value) out += fmt::format(" {}", flag);
    }
    return out;
}

}  // namespace

TEST_CASE("solve settings: every row is a flag of rig-invert and rig-batch, with the table's default in its help")
{
    CHECK(app::solveSettings().size() == 9);
    for (const app::SolveSetting& s : app::solveSettings()) {
        CAPTURE(s.name);
        // A flag turns something on: off by default, wherever it lands.
        if (s.kind == SettingKind::flag) CHECK(s.get(app::SolveSettings{}) == 0);
    }
    checkHelp("rig-invert", app::SolveSettings{});
    checkHelp("rig-batch", app::concurrentSolveDefaults());
}

TEST_CASE("solve settings: every row is a field of rig-batch's manifest, written with the defaults and read back")
{
    const fs::path out = test::scratchDir("solve_settings_manifest_defaults") / "out";
    test::run(batchInputs(out));  // the arm's frames may miss (exit code 3): the manifest is written first
    const Json manifest = Json::parse(test::readFile(out / "manifest.json"));
    const Json& settings = manifest.at("settings");
    const app::SolveSettings defaults = app::concurrentSolveDefaults();
    CHECK(settings.size() == app::solveSettingCount);
    for (const app::SolveSetting& s : app::solveSettings()) {
        CAPTURE(s.name);
        CHECK(settings.at(app::settingName(s, app::Spelling::key)) == manifestValue(s, s.get(defaults)));
    }
}

TEST_CASE("solve settings: non-default settings round-trip through the manifest, from rig-batch's flags and in code")
{
    const app::SolveSettings defaults = app::concurrentSolveDefaults();
    const app::SolveSettings changed = nonDefault(defaults);
    app::SolveSettings hybrid = defaults;
    hybrid.hybrid = true;
    for (const app::SolveSettings& settings : {changed, hybrid}) {
        const std::string flags = flagsOf(settings);
        CAPTURE(flags);
        // In code: written and read back.
        const fs::path folder = test::scratchDir("solve_settings_round_trip");
        app::BatchManifest written;
        written.inputs.settings = settings;
        app::writeManifest(folder, written);
        const app::SolveSettings read = app::readManifest(folder).inputs.settings;
        // Through rig-batch: its flags into the manifest.
        const fs::path out = folder / "out";
        test::run(batchInputs(out) + flags);
        const Json fields = Json::parse(test::readFile(out / "manifest.json")).at("settings");
        for (const app::SolveSetting& s : app::solveSettings()) {
            CAPTURE(s.name);
            CHECK(s.get(read) == s.get(settings));
            CHECK(fields.at(app::settingName(s, app::Spelling::key)) == manifestValue(s, s.get(settings)));
        }
    }
}

TEST_CASE("solve settings: every row is a keyword of Approximation.invert and of riginv.pyi with the table's default")
{
    const app::SolveSettings defaults = app::concurrentSolveDefaults();
    const std::string stub = test::readFile(test::sourceDir() / "python/riginv.pyi");
    const std::string invert = stub.substr(stub.find("def invert("), stub.find("-> Tuple[") - stub.find("def invert("));
    const fs::path module = test::binaryDir() / "python";
    const bool built = fs::exists(module / "riginv.pyi");
    // pybind11's signature line: "invert(self: riginv.Approximation, ..., threads: object = 1, ...) -> tuple".
    const auto signature = test::run(fmt::format(
        "PYTHONPATH={} /usr/bin/python3 -c 'import riginv; print(riginv.Approximation.invert.__doc__.splitlines()[0])'",
        module.string()));
    if (built) REQUIRE(signature.exitCode == 0);
    else MESSAGE("the Python module is not built (RIG_PYTHON=OFF): only riginv.pyi is checked");
    for (const app::SolveSetting& s : app::solveSettings()) {
        const std::string key = app::settingName(s, app::Spelling::key);
        const int value = s.get(defaults);
        const std::string_view type = s.kind == SettingKind::count  ? "int"
                                      : s.kind == SettingKind::flag ? "bool"
                                                                    : "str";
        CAPTURE(key);
        CHECK(invert.find(fmt::format("        {}: {} = {},\n", key, type, pythonValue(s, value, '"'))) !=
              std::string::npos);
        if (built)
            CHECK(signature.out.find(fmt::format(" {}: object = {}", key, pythonValue(s, value, '\''))) !=
                  std::string::npos);
    }
}

TEST_CASE("solve settings: a bad value of each kind is the table's one line and exit code 2, in both command lines")
{
    const fs::path dir = test::scratchDir("solve_settings_bad_values");
    const struct {
        std::string flags;
        std::string error;
    } cases[] = {
        {"--threads -1", "--threads -1: not a thread count; give a whole number from 0 (all cores) to 1024"},
        {"--threads many", "--threads many: not a thread count; give a whole number from 0 (all cores) to 1024"},
        {"--polish 1.5", "--polish 1.5: give 0 (the approximation only) or more real-rig corrections per frame"},
        {"--restart-every 0", "--restart-every 0: give 1 or more frames between warm-start restarts (default 120)"},
        {"--restart-every 99999999999",
         "--restart-every 99999999999: give 1 or more frames between warm-start restarts (default 120)"},
        {"--jacobian exact", "--jacobian exact: expected analytic or fd"},
        {"--hybrid --polish 2",
         "--hybrid with --polish 2: choose one; the hybrid solve fits what the approximation does not model on the "
         "real rig itself"},
    };
    for (const auto& c : cases) {
        CAPTURE(c.flags);
        const auto invert = test::run(fmt::format("{} {} --rig rigs/examples/arm.yaml --clip {} -o {} {}",
                                                  test::tool("rig-invert"), armApproximation().string(),
                                                  armClip.string(), (dir / "curves.json").string(), c.flags));
        CHECK(invert.exitCode == 2);
        CHECK(invert.err == "error: " + c.error + "\n");
        const auto batch = test::run(batchInputs(dir / "out") + " " + c.flags);
        CHECK(batch.exitCode == 2);
        CHECK(batch.err == "error: " + c.error + "\n");
        CHECK_FALSE(fs::exists(dir / "curves.json"));
        CHECK_FALSE(fs::exists(dir / "out"));
    }
}

TEST_CASE("solve settings: a manifest's bad setting is the table's line, naming the manifest, and exit code 2")
{
    const fs::path out = test::scratchDir("solve_settings_bad_manifest") / "out";
    test::run(batchInputs(out));
    const std::string manifest = (out / "manifest.json").string();
    const Json good = Json::parse(test::readFile(manifest));
    const std::string remove = "; remove it and run rig-batch again";
    const struct {
        const char* key;
        Json value;
        std::string error;
    } cases[] = {
        {"polish", -1,
         "(settings: polish -1: give 0 (the approximation only) or more real-rig corrections per frame)" + remove},
        {"threads", 2000,
         "(settings: threads 2000: not a thread count; give a whole number from 0 (all cores) to 1024)" + remove},
        {"jacobian", "exact", "(settings: jacobian exact: expected analytic or fd)" + remove},
        {"hybrid", "yes", "('hybrid' is not what rig-batch writes)" + remove},
        {"restart_every", nullptr, "('restart_every' is not what rig-batch writes)" + remove},
    };
    for (const auto& c : cases) {
        CAPTURE(c.key);
        Json edited = good;
        edited["settings"][c.key] = c.value;
        test::writeFile(manifest, edited.dump(2));
        const auto r = test::run(fmt::format("{} --out {} --task 0", test::tool("rig-batch"), out.string()));
        CHECK(r.exitCode == 2);
        CHECK(r.err == fmt::format("error: {}: not a rig-batch manifest {}\n", manifest, c.error));
    }
    Json hybrid = good;
    hybrid["settings"]["hybrid"] = true;
    hybrid["settings"]["polish"] = 1;
    test::writeFile(manifest, hybrid.dump(2));
    const auto r = test::run(fmt::format("{} --out {} --task 0", test::tool("rig-batch"), out.string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err == fmt::format("error: {}: not a rig-batch manifest (settings: hybrid with polish 1: choose one; the "
                               "hybrid solve fits what the approximation does not model on the real rig itself){}\n",
                               manifest, remove));
}
