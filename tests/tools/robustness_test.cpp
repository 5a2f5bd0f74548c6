// Robustness of the command lines beyond the corpus (docs/robustness.md): numbers that are not finite
// in the output, outputs that survive a killed run, temporary files a killed run leaves, and inputs at
// the limits (which must still work).
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include <csignal>

#include <fmt/format.h>
#include <unistd.h>

#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "nodes/clips/bvh.h"
#include "test_support.h"

namespace fs = std::filesystem;
using rig::test::run;

namespace {

std::string graphEval(const std::string& args) { return fmt::format("{} {}", rig::test::tool("graph-eval"), args); }

std::string quote(const fs::path& p) { return fmt::format("'{}'", p.string()); }

std::set<std::string> filesIn(const fs::path& dir)
{
    std::set<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir)) names.insert(entry.path().filename().string());
    return names;
}

// A zero-scaled joint (a common way to hide one) has no inverse: its worldInverseMatrix is NaN, and so is
// everything computed from it: a joint translated by it is NaN there; a healthy joint beside it is not.
const std::string degenerateRig = R"(nodes:
  - {name: hidden, type: joint, scale: [0, 0, 0]}
  - {name: d, type: decomposeMatrix}
  - {name: follower, type: joint}
  - {name: healthy, type: joint, translate: [1, 2, 3]}
connections:
  - hidden.worldInverseMatrix -> d.inputMatrix
  - d.outputTranslate -> follower.translate
)";

// `length` joints in a chain, each rotated by a time curve: every frame recomputes the whole chain.
std::string chainRig(int length)
{
    std::string text =
        "nodes:\n  - {name: time1, type: time}\n"
        "  - {name: anim, type: animCurveTA, keys: [[1, 0], [100, 90]], tangents: linear, "
        "postInfinity: cycle}\n";
    std::string connections = "connections:\n  - time1.outTime -> anim.input\n";
    for (int j = 0; j < length; ++j) {
        text += fmt::format("  - {{name: j{}, type: joint, translate: [1, 0, 0]{}}}\n", j,
                            j ? fmt::format(", parent: j{}", j - 1) : "");
        connections += fmt::format("  - anim.output -> j{}.rotateZ\n", j);
    }
    return text + connections;
}

}  // namespace

TEST_CASE("graph-eval prints numbers that are not finite as null (JSON) or an empty field (CSV, table)")
{
    const auto dir = rig::test::scratchDir("robustness-null");
    const auto rig = rig::test::writeFile(dir / "degenerate.yaml", degenerateRig);
    const std::string gets =
        " --get hidden.worldInverseMatrix --get d.outputTranslate --get follower.worldMatrix"
        " --get healthy.translateX";
    const auto json = run(graphEval(quote(rig) + gets));
    CHECK(json.exitCode == 0);
    CHECK(json.err.empty());
    CHECK(json.out ==
          "[\n  {\"frame\": 0,\n"
          "   \"hidden.worldInverseMatrix\": [[null, null, null, null], [null, null, null, null], "
          "[null, null, null, null], [null, null, null, null]],\n"
          "   \"d.outputTranslate\": [null, null, null],\n"
          "   \"follower.worldMatrix\": [[1, 0, 0, null], [0, 1, 0, null], [0, 0, 1, null], [0, 0, 0, null]],\n"
          "   \"healthy.translateX\": 1}\n]\n");
    const auto csv = run(graphEval(quote(rig) + " --get d.outputTranslate --get healthy.translateX --format csv"));
    CHECK(csv.exitCode == 0);
    CHECK(csv.out == "frame,d.outputTranslateX,d.outputTranslateY,d.outputTranslateZ,healthy.translateX\n0,,,,1\n");
    const auto table = run(graphEval(quote(rig) + " --get d.outputTranslateX --get healthy.translateX --format table"));
    CHECK(table.exitCode == 0);
    CHECK(table.out ==
          "frame  d.outputTranslateX  healthy.translateX\n    0                                       1\n");
    // Every output of the rig, in parallel and in checked mode (NaN compares equal to itself bit for bit).
    for (const char* flags : {"", " --threads 2", " --check", " --dot"}) {
        CAPTURE(flags);
        const auto all = run(graphEval(quote(rig) + flags));
        CHECK(all.exitCode == 0);
        CHECK(all.err.empty());
    }
}

TEST_CASE("a graph-eval killed part-way leaves the existing output untouched and no temporary file")
{
    const auto dir = rig::test::scratchDir("robustness-kill");
    const auto rig = rig::test::writeFile(dir / "chain.yaml", chainRig(400));
    const auto out = rig::test::writeFile(dir / "out.json", "the output of an earlier run\n");
    // 400 joints over a million frames: minutes of work, killed after one second.
    const auto r = run("timeout -s KILL 1 " +
                       graphEval(quote(rig) + " --frames 1:1000000 --get j399.worldMatrix -o " + quote(out)));
    CHECK(r.exitCode == 128 + 9);  // timeout's code for a command killed by SIGKILL
    CHECK(rig::test::readFile(out) == "the output of an earlier run\n");
    CHECK(filesIn(dir) == std::set<std::string>{"chain.yaml", "out.json"});
}

TEST_CASE("temporary files of killed writers are removed by the next write of the same file")
{
    const auto dir = rig::test::scratchDir("robustness-stale");
    // A process that has ended: its pid names a temporary file no one is writing.
    const auto ended = run("sh -c 'echo $$'");
    const int deadPid = std::stoi(ended.out);
    REQUIRE(::kill(deadPid, 0) != 0);
    const std::string stale = fmt::format(".out.json.{}.Ab12Cd.tmp", deadPid);
    const std::string alive = fmt::format(".out.json.{}.Ef34Gh.tmp", ::getpid());  // a writer still running
    const std::string other = fmt::format(".other.json.{}.Ij56Kl.tmp", deadPid);   // another output's
    for (const auto& name : {stale, alive, other}) rig::test::writeFile(dir / name, "partial");
    const auto r = run(graphEval("rigs/examples/arm.yaml --get elbow.rotateZ -o " + quote(dir / "out.json")));
    CHECK(r.exitCode == 0);
    CHECK(filesIn(dir) == std::set<std::string>{alive, other, "out.json"});
    CHECK(rig::test::readFile(dir / "out.json").starts_with("[\n  {\"frame\": 0,"));
}

TEST_CASE("inputs at the limits still load: 64 nested includes, BVH joints 256 deep, 500-character joint names")
{
    const auto dir = rig::test::scratchDir("robustness-limits");
    // main.yaml -> c1.yaml -> ... -> c64.yaml: 64 includes deep.
    rig::test::writeFile(dir / "main.yaml", "include:\n  - {file: c1.yaml, namespace: n}\n");
    for (int i = 1; i < 64; ++i)
        rig::test::writeFile(dir / fmt::format("c{}.yaml", i),
                             fmt::format("include:\n  - {{file: c{}.yaml}}\n", i + 1));
    rig::test::writeFile(dir / "c64.yaml", "nodes:\n  - {name: a, type: joint}\n");
    const auto g = rig::loadGraphFile(dir / "main.yaml", rig::makeBuiltinRegistry());
    CHECK(g->findNode("n:a") >= 0);

    std::string deep = "HIERARCHY\nROOT j0\n{\n  OFFSET 0 0 0\n  CHANNELS 1 Zrotation\n";
    for (int i = 1; i < rig::bvhMaxDepth; ++i)
        deep += fmt::format("JOINT j{}\n{{\n  OFFSET 0 1 0\n  CHANNELS 1 Zrotation\n", i);
    for (int i = 0; i < rig::bvhMaxDepth; ++i) deep += "}\n";
    deep += "MOTION\nFrames: 1\nFrame Time: 0.04\n";
    for (int i = 0; i < rig::bvhMaxDepth; ++i) deep += "1 ";
    const auto clip = rig::parseBvh(deep + "\n", "deep.bvh");
    CHECK(clip.joints.size() == static_cast<std::size_t>(rig::bvhMaxDepth));
    CHECK(clip.joints.back().depth == rig::bvhMaxDepth - 1);

    // bvh2rig turns the longest joint name the reader takes, with the longest prefix, into a rig that loads.
    const std::string name(static_cast<std::size_t>(rig::bvhMaxNameLength), 'a');
    const auto bvh = rig::test::writeFile(
        dir / "long.bvh",
        fmt::format("HIERARCHY\nROOT {}\n{{\n  OFFSET 0 0 0\n  CHANNELS 4 Xrotation Yrotation Xrotation "
                    "Zposition\n  End Site\n  {{\n    OFFSET 0 1 0\n  }}\n}}\nROOT {}\n{{\n  OFFSET 0 0 0\n"
                    "  CHANNELS 1 Xrotation\n}}\nMOTION\nFrames: 1\nFrame Time: 0.04\n0 0 0 0 0\n",
                    name, name));
    const auto r = run(fmt::format("{} {} -o {} --with-motion --prefix {}", rig::test::tool("bvh2rig"), quote(bvh),
                                   quote(dir / "long.yaml"), std::string(100, 'p')));
    CHECK(r.exitCode == 0);
    CHECK(r.err.empty());
    CHECK(run(graphEval(quote(dir / "long.yaml") + " --get '*.worldMatrix'")).exitCode == 0);
}
