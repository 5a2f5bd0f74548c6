// The bad-input corpus (tests/corpus/cases.yaml): every case runs a real command line (graph-eval,
// bvh2rig, rig-learn, rig-invert, rig-bench) on a hostile input and must fail cleanly: exit code 2,
// exactly one "error: ..." line on standard error (the exact text is in the manifest), nothing on standard
// output, no file created, and an existing output untouched.
// docs/robustness.md describes the corpus and how to add a case.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include "test_support.h"

namespace fs = std::filesystem;

namespace {

std::string replaceAll(std::string text, const std::string& from, const std::string& to)
{
    for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
        text.replace(at, from.size(), to);
    return text;
}

// Single quotes for the shell.
std::string shellQuote(const std::string& arg) { return "'" + replaceAll(arg, "'", "'\\''") + "'"; }

// Every file under `dir` with its content (big or unreadable files: size and time; folders as
// "<folder>"), to see that a run changed nothing.
std::map<std::string, std::string> snapshot(const fs::path& dir)
{
    std::map<std::string, std::string> files;
    for (auto it = fs::recursive_directory_iterator(dir); it != fs::recursive_directory_iterator(); ++it) {
        const auto rel = fs::relative(it->path(), dir).string();
        if (it->is_symlink() || (!it->is_regular_file() && !it->is_directory())) files[rel] = "<special>";
        else if (it->is_directory()) files[rel] = "<folder>";
        else if (it->file_size() > (1 << 20) || ::access(it->path().c_str(), R_OK) != 0)
            files[rel] =
                fmt::format("<{} bytes, {}>", it->file_size(), it->last_write_time().time_since_epoch().count());
        else files[rel] = rig::test::readFile(it->path());
    }
    return files;
}

// Inputs too big, too deep or too odd to keep as files, made in the case's scratch folder (the
// manifest's header lists the kinds).
void generate(const YAML::Node& spec, const fs::path& dir)
{
    const std::string kind = spec["kind"].as<std::string>();
    const fs::path file = dir / spec["file"].as<std::string>("");
    if (kind == "text") {
        {
            std::ofstream out(file, std::ios::binary);
            for (const auto& part : spec["parts"]) {
                const std::string text = part["text"].as<std::string>();
                for (long long i = 0, n = part["count"].as<long long>(1); i < n; ++i) out << text;
            }
        }
        if (const auto size = spec["size"]) fs::resize_file(file, size.as<std::uintmax_t>());
    } else if (kind == "bytes") {
        std::mt19937 random(spec["seed"].as<unsigned>(1));
        std::string bytes(spec["size"].as<std::size_t>(), '\0');
        for (char& c : bytes) c = static_cast<char>(random() & 0xff);
        rig::test::writeFile(file, bytes);
    } else if (kind == "include-chain") {
        const int count = spec["count"].as<int>();
        for (int i = 0; i + 1 < count; ++i)
            rig::test::writeFile(dir / fmt::format("c{}.yaml", i),
                                 fmt::format("include:\n  - {{file: c{}.yaml}}\n", i + 1));
        rig::test::writeFile(dir / fmt::format("c{}.yaml", count - 1), "nodes:\n  - {name: a, type: joint}\n");
    } else if (kind == "include-fanout") {
        const int depth = spec["depth"].as<int>();
        const int width = spec["width"].as<int>();
        for (int i = 0; i < depth; ++i) {
            std::string text = "include:\n";
            for (int w = 0; w < width; ++w) text += fmt::format("  - {{file: f{}.yaml, namespace: n{}}}\n", i + 1, w);
            rig::test::writeFile(dir / fmt::format("f{}.yaml", i), text);
        }
        const int padding = spec["leafComment"] ? spec["leafComment"].as<int>() : 0;
        rig::test::writeFile(dir / fmt::format("f{}.yaml", depth),
                             "nodes:\n  - {name: a, type: joint}\n" +
                                 (padding ? "# " + std::string(static_cast<std::size_t>(padding), 'x') + "\n" : ""));
    } else if (kind == "learn") {
        // An approximation learned now from the rig as it is (its fingerprint matches).
        std::string command = rig::test::tool("rig-learn");
        for (const auto& a : spec["args"].as<std::vector<std::string>>()) command += " " + shellQuote(a);
        const auto r = rig::test::run(command + " -o " + shellQuote(file.string()));
        INFO(r.err);
        REQUIRE(r.exitCode == 0);
    } else if (kind == "folder") fs::create_directories(file);
    else if (kind == "fifo") REQUIRE(::mkfifo(file.c_str(), 0644) == 0);
    else FAIL("unknown generator kind '" << kind << "'");
    if (const auto mode = spec["mode"])
        fs::permissions(file, static_cast<fs::perms>(std::stoi(mode.as<std::string>(), nullptr, 8)));
}

struct Case {
    std::string name;
    std::string tool;
    std::vector<std::string> args;
    std::string expectStderr;
    int expectExit = 2;
    YAML::Node generated;  // a list, or null
    std::map<std::string, std::string> existing;
    bool unprivileged = false;
};

std::vector<Case> loadCases()
{
    const YAML::Node root = YAML::LoadFile((rig::test::sourceDir() / "tests/corpus/cases.yaml").string());
    std::vector<Case> cases;
    for (const auto& c : root["cases"]) {
        Case k;
        k.name = c["name"].as<std::string>();
        k.tool = c["tool"].as<std::string>();
        k.args = c["args"].as<std::vector<std::string>>(std::vector<std::string>{});
        k.expectStderr = c["expect_stderr"].as<std::string>();
        k.expectExit = c["expect_exit"].as<int>();
        if (const auto g = c["generate"]) k.generated = g;
        if (const auto e = c["existing"]) k.existing = e.as<std::map<std::string, std::string>>();
        k.unprivileged = c["unprivileged"].as<bool>(false);
        cases.push_back(std::move(k));
    }
    return cases;
}

// Permissions do not stop root: as root, `unprivileged` cases run as user nobody (setpriv drops the
// privileges). Returns the command prefix, or nothing when the cases cannot run.
std::optional<std::string> unprivilegedPrefix()
{
    if (::geteuid() != 0) return std::string();
    if (rig::test::run("command -v setpriv").exitCode != 0) return std::nullopt;
    return std::string("setpriv --reuid=65534 --regid=65534 --clear-groups ");
}

// The file a case writes with -o directly in its scratch folder ("-o {scratch}/F": F), unless the case
// makes F itself; "" when there is none.
std::string scratchOutput(const Case& k)
{
    for (std::size_t i = 0; i + 1 < k.args.size(); ++i) {
        if (k.args[i] != "-o" && k.args[i] != "--output") continue;
        const std::string& path = k.args[i + 1];
        if (!path.starts_with("{scratch}/")) return {};
        const std::string file = path.substr(std::string_view("{scratch}/").size());
        if (file.empty() || file.find('/') != std::string::npos || k.existing.count(file)) return {};
        for (const auto& g : k.generated)
            if (g["file"].as<std::string>("") == file) return {};
        return file;
    }
    return {};
}

// Runs one case once as written and once more writing over an existing output file (graph-eval without
// -o: -o {scratch}/previous.json added; a case with -o {scratch}/F: F made first), and checks everything
// the corpus promises.
void runCase(const Case& k, int number, const std::string& prefix)
{
    for (const bool withOutput : {false, true}) {
        const bool hasOutput = std::find_if(k.args.begin(), k.args.end(), [](const std::string& a) {
                                   return a == "-o" || a == "--output" || a.starts_with("--output=");
                               }) != k.args.end();
        const std::string output = scratchOutput(k);
        if (withOutput && output.empty() && (k.tool != "graph-eval" || hasOutput)) continue;
        CAPTURE(withOutput);
        const fs::path dir = rig::test::scratchDir(fmt::format("corpus/{:03}", number));
        // The unprivileged user's own folder: writable, so that only what the case makes unreadable or
        // read-only bites.
        if (k.unprivileged) fs::permissions(dir, fs::perms::all);
        for (const auto& g : k.generated) generate(g, dir);
        for (const auto& [file, text] : k.existing) rig::test::writeFile(dir / file, text);
        std::vector<std::string> args = k.args;
        if (withOutput && !output.empty()) rig::test::writeFile(dir / output, "the previous output\n");
        else if (withOutput) {
            rig::test::writeFile(dir / "previous.json", "the previous output\n");
            // In front, where it cannot take the place of a missing flag value.
            args.insert(args.begin(), {"-o", "{scratch}/previous.json"});
        }
        std::string command = rig::test::tool(k.tool);
        for (const auto& a : args) command += " " + shellQuote(replaceAll(a, "{scratch}", dir.string()));
        const auto before = snapshot(dir);
        CAPTURE(command);
        const auto r = rig::test::run("timeout -s KILL 120 " + prefix + command);
        CHECK(r.exitCode == k.expectExit);
        CHECK(r.out.empty());
        // {bin}: the folder of the tools, which plugin-search messages name.
        const std::string bin = (rig::test::binaryDir() / "bin").string();
        CHECK(r.err == replaceAll(replaceAll(k.expectStderr, "{scratch}", dir.string()), "{bin}", bin) + "\n");
        // Nothing created (no output, no temporary file), nothing changed.
        CHECK(snapshot(dir) == before);
        // Read-only folders must not stop the scratch folder's removal next time.
        for (auto it = fs::recursive_directory_iterator(dir); it != fs::recursive_directory_iterator(); ++it)
            if (it->is_directory() && !it->is_symlink())
                fs::permissions(it->path(), fs::perms::owner_all, fs::perm_options::add);
    }
}

// The cases of one section of the manifest (the first word of their names: rig, maya, bvh, graph-eval, bvh2rig,
// approx, map, clip, rig-learn, rig-invert, rig-bench).
void runSection(const std::string& section)
{
    const auto cases = loadCases();
    const auto prefix = unprivilegedPrefix();
    int ran = 0;
    int skipped = 0;
    for (std::size_t i = 0; i < cases.size(); ++i) {
        const Case& k = cases[i];
        if (!k.name.starts_with(section + " ")) continue;
        CAPTURE(k.name);
        if (k.unprivileged && !prefix) {
            ++skipped;
            continue;
        }
        runCase(k, static_cast<int>(i), k.unprivileged ? *prefix : std::string());
        ++ran;
    }
    CHECK(ran > 0);
    if (skipped) MESSAGE(skipped << " case(s) need an unprivileged user (root without setpriv) and were not run");
}

}  // namespace

TEST_CASE("corpus: the manifest is well formed and names every corpus file")
{
    const auto cases = loadCases();
    CHECK(cases.size() >= 200);
    std::set<std::string> names;
    for (const auto& k : cases) {
        CAPTURE(k.name);
        CHECK(names.insert(k.name).second);
        CHECK(k.name.find(';') == std::string::npos);
        CHECK((k.tool == "graph-eval" || k.tool == "bvh2rig" || k.tool == "rig-learn" || k.tool == "rig-invert" ||
               k.tool == "rig-bench"));
        CHECK(k.expectExit == 2);
        CHECK(k.expectStderr.starts_with("error: "));
        CHECK(k.expectStderr.find('\n') == std::string::npos);
    }
    // Every file kept in tests/corpus is an input of some case: named by the manifest, or by a rig file of
    // the corpus (includes).
    std::string referenced = rig::test::readFile(rig::test::sourceDir() / "tests/corpus/cases.yaml");
    for (const auto& entry : fs::recursive_directory_iterator(rig::test::sourceDir() / "tests/corpus"))
        if (entry.is_regular_file() && entry.path().extension() == ".yaml")
            referenced += rig::test::readFile(entry.path());
    for (const auto& entry : fs::recursive_directory_iterator(rig::test::sourceDir() / "tests/corpus")) {
        if (!entry.is_regular_file() || entry.path().filename() == "cases.yaml") continue;
        CAPTURE(entry.path().string());
        CHECK(referenced.find(entry.path().filename().string()) != std::string::npos);
    }
}

TEST_CASE("corpus: hostile rig files fail with their exact one-line error") { runSection("rig"); }

TEST_CASE("corpus: hostile BVH files fail with their exact one-line error") { runSection("bvh"); }

TEST_CASE("corpus: hostile Maya scenes fail with their exact one-line error") { runSection("maya"); }

TEST_CASE("corpus: bad graph-eval command lines fail with their exact one-line error") { runSection("graph-eval"); }

TEST_CASE("corpus: bad bvh2rig command lines fail with their exact one-line error") { runSection("bvh2rig"); }

TEST_CASE("corpus: hostile approximation files fail with their exact one-line error") { runSection("approx"); }

TEST_CASE("corpus: hostile map files fail with their exact one-line error") { runSection("map"); }

TEST_CASE("corpus: hostile target clips fail with their exact one-line error") { runSection("clip"); }

TEST_CASE("corpus: bad rig-learn command lines fail with their exact one-line error") { runSection("rig-learn"); }

TEST_CASE("corpus: bad rig-invert command lines fail with their exact one-line error") { runSection("rig-invert"); }

TEST_CASE("corpus: bad rig-bench command lines fail with their exact one-line error") { runSection("rig-bench"); }
