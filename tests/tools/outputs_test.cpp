// Outputs that destroy nothing (issue: special files, inputs overwritten, curves and report out of
// step), through the built command lines: devices and FIFOs are written through, a symbolic link's
// target is replaced and the link kept, a read-only file is refused and an existing file keeps its
// mode; an output that names an input or another output is refused before any work; rig-invert's
// report names the curves it belongs to; a real rig that evaluates to NaN is a miss with exit code 3.
#include <doctest/doctest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "adapter/graph_rig_function.h"
#include "test_support.h"

using rig::test::run;
namespace fs = std::filesystem;

namespace {

const std::string arm = "rigs/examples/arm.yaml";

std::string graphEval(const std::string& args) { return fmt::format("{} {}", rig::test::tool("graph-eval"), args); }

fs::file_type typeOf(const fs::path& p) { return fs::symlink_status(p).type(); }

std::string armTable()
{
    const auto r = run(graphEval(arm + " --get '*.rotateZ' --format csv"));
    REQUIRE(r.exitCode == 0);
    return r.out;
}

}  // namespace

TEST_CASE("outputs: a device and a FIFO are written through, never replaced by a file")
{
    const auto dir = rig::test::scratchDir("outputs-special");
    const std::string expected = armTable();

    const fs::path fifo = dir / "fifo";
    REQUIRE(::mkfifo(fifo.c_str(), 0644) == 0);
    std::string received;
    std::thread reader([&] {
        std::ifstream in(fifo);
        received.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    });
    const auto r = run(graphEval(fmt::format("{} --get '*.rotateZ' --format csv -o '{}'", arm, fifo.string())));
    reader.join();
    CHECK(r.exitCode == 0);
    CHECK(typeOf(fifo) == fs::file_type::fifo);
    CHECK(received == expected);

    // A device node of our own (the system's /dev/null is not put at risk): root only.
    const fs::path null = dir / "null";
    if (::mknod(null.c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0) {
        MESSAGE("not root: the device case runs on /dev/null's twin only where mknod is allowed");
        return;
    }
    const auto d = run(graphEval(fmt::format("{} -o '{}'", arm, null.string())));
    CHECK(d.exitCode == 0);
    CHECK(typeOf(null) == fs::file_type::character);
}

TEST_CASE(
    "outputs: a symbolic link's file is replaced and the link kept, a read-only file is refused, the mode is kept")
{
    const auto dir = rig::test::scratchDir("outputs-files");
    const std::string expected = armTable();
    const fs::path target = rig::test::writeFile(dir / "target.csv", "keep\n");
    fs::create_symlink("target.csv", dir / "link.csv");
    auto r = run(graphEval(fmt::format("{} --get '*.rotateZ' --format csv -o '{}'", arm, (dir / "link.csv").string())));
    CHECK(r.exitCode == 0);
    CHECK(typeOf(dir / "link.csv") == fs::file_type::symlink);
    CHECK(rig::test::readFile(target) == expected);

    ::chmod(target.c_str(), 0444);
    r = run(graphEval(fmt::format("{} -o '{}'", arm, target.string())));
    CHECK(r.exitCode == 2);
    CHECK(r.err ==
          fmt::format("error: {}: is read-only; it is not replaced (make it writable, or choose another file)\n",
                      target.string()));
    CHECK(rig::test::readFile(target) == expected);

    ::chmod(target.c_str(), 0640);
    r = run(graphEval(fmt::format("{} -o '{}'", arm, target.string())));
    CHECK(r.exitCode == 0);
    struct stat st {};
    REQUIRE(::stat(target.c_str(), &st) == 0);
    CHECK((st.st_mode & 07777) == 0640);
}

TEST_CASE("outputs: an output that is an input or another output is refused before any work, by identity")
{
    const auto dir = rig::test::scratchDir("outputs-inputs");
    const fs::path rigFile = dir / "r.yaml";
    fs::copy_file(rig::test::sourceDir() / arm, rigFile);
    const std::string rigText = rig::test::readFile(rigFile);
    fs::create_symlink("r.yaml", dir / "alias.yaml");

    auto r = run(fmt::format("{} '{}' --params 'shoulder.rotate?' -o '{}'", rig::test::tool("rig-learn"),
                             rigFile.string(), (dir / "alias.yaml").string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err == fmt::format("error: -o {}: is the rig file ({}); writing it would destroy an input, choose another "
                               "output file\n",
                               (dir / "alias.yaml").string(), rigFile.string()));
    CHECK(rig::test::readFile(rigFile) == rigText);

    r = run(graphEval(fmt::format("'{}' -o '{}/./r.yaml'", rigFile.string(), dir.string())));
    CHECK(r.exitCode == 2);
    CHECK(r.err.find("is the rig file") != std::string::npos);

    // An included file is an input too.
    rig::test::writeFile(dir / "top.yaml", "include:\n  - {file: r.yaml, namespace: a}\n");
    r = run(graphEval(fmt::format("'{}' -o '{}'", (dir / "top.yaml").string(), rigFile.string())));
    CHECK(r.exitCode == 2);
    CHECK(r.err.find("is a file the rig reads") != std::string::npos);
    CHECK(rig::test::readFile(rigFile) == rigText);

    const fs::path clip = dir / "c.bvh";
    rig::test::writeFile(
        clip,
        "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 3 Zrotation Xrotation Yrotation\n End Site\n"
        " {\n  OFFSET 0 1 0\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.0333\n0 0 0\n");
    const std::string clipText = rig::test::readFile(clip);
    r = run(fmt::format("{} '{}' -o '{}/./c.bvh'", rig::test::tool("bvh2rig"), clip.string(), dir.string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err.find("is the clip") != std::string::npos);
    CHECK(rig::test::readFile(clip) == clipText);

    // Two outputs on one file (one of them not there yet).
    r = run(fmt::format("{} '{}' --params 'shoulder.rotate?' -o '{}' --report-json '{}/./a.yaml'",
                        rig::test::tool("rig-learn"), rigFile.string(), (dir / "a.yaml").string(), dir.string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err ==
          fmt::format("error: --report-json {}/./a.yaml: is also -o ({}); give each output a file of its own\n",
                      dir.string(), (dir / "a.yaml").string()));
    CHECK_FALSE(fs::exists(dir / "a.yaml"));
}

TEST_CASE("rig-invert: the report names the curves it belongs to, and a real rig giving NaN is a miss with exit code 3")
{
    const auto dir = rig::test::scratchDir("outputs-invert");
    const fs::path approx = dir / "arm.approx.yaml";
    REQUIRE(run(fmt::format("{} {} --params 'shoulder.rotate?' 'wrist.rotate?' -o '{}'", rig::test::tool("rig-learn"),
                            arm, approx.string()))
                .exitCode == 0);
    const fs::path curves = dir / "curves.json", report = dir / "report.json";
    auto r = run(fmt::format("{} '{}' --rig {} --clip tests/corpus/clips/arm.json -o '{}' --report-json '{}' -q",
                             rig::test::tool("rig-invert"), approx.string(), arm, curves.string(), report.string()));
    REQUIRE(r.exitCode == 0);
    auto json = nlohmann::json::parse(rig::test::readFile(report));
    CHECK(json["curves"]["file"] == curves.string());
    CHECK(json["curves"]["fnv1a64"] == fmt::format("{:016x}", rig::fnv1a64(rig::test::readFile(curves))));
    CHECK(json["status_frames"]["non_finite"] == 0);
    CHECK(json["failed_frames"] == 0);

    // The same arm with an elbow 1e308 cm out under a scaled shoulder: its world matrices overflow to
    // inf and NaN, which must not read as a perfect fit.
    std::string text = rig::test::readFile(rig::test::sourceDir() / arm);
    auto replace = [&](const std::string& from, const std::string& to) {
        const auto at = text.find(from);
        REQUIRE(at != std::string::npos);
        text.replace(at, from.size(), to);
    };
    replace("rotateOrder: xzy}", "rotateOrder: xzy, scale: [10, 10, 10]}");
    replace("parent: shoulder, translate: [30, 0, 0]", "parent: shoulder, translate: [1e308, 0, 0]");
    const fs::path broken = rig::test::writeFile(dir / "broken.yaml", text);
    r = run(fmt::format("{} '{}' --rig '{}' --clip tests/corpus/clips/arm.json -o '{}' --report-json '{}' -q",
                        rig::test::tool("rig-invert"), approx.string(), broken.string(), curves.string(),
                        report.string()));
    CHECK(r.exitCode == 3);
    CHECK(
        r.err.ends_with("error: 2 of 2 frames are not an answer on the real rig (first: frame 1, non-finite, elbow): "
                        "the real rig gives a non-finite matrix, error or cost there\n"));
    json = nlohmann::json::parse(rig::test::readFile(report));
    CHECK(json["status_frames"]["non_finite"] == 2);
    CHECK(json["first_failure"]["status"] == "non-finite");
    CHECK(json["per_frame"][0]["non_finite_joint"] == "elbow");
}

TEST_CASE("rig-invert: a parameter edited into a plug the rig does not offer is one line, not an internal error")
{
    const auto dir = rig::test::scratchDir("outputs-renamed");
    const fs::path approx = dir / "arm.approx.yaml";
    REQUIRE(run(fmt::format("{} {} --params 'shoulder.rotate?' 'wrist.rotate?' -o '{}'", rig::test::tool("rig-learn"),
                            arm, approx.string()))
                .exitCode == 0);
    std::string text = rig::test::readFile(approx);
    const auto at = text.find("name: \"wrist.rotateX\"");
    REQUIRE(at != std::string::npos);
    text.replace(at, std::string("name: \"wrist.rotateX\"").size(), "name: \"wrist.rotate\"");
    rig::test::writeFile(approx, text);
    const auto r = run(fmt::format("{} '{}' --rig {} --clip tests/corpus/clips/arm.json -o '{}'",
                                   rig::test::tool("rig-invert"), approx.string(), arm, (dir / "c.json").string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err.find("error: " + approx.string() +
                     ": the rig has no parameter wrist.rotate (rigs/examples/arm.yaml does not "
                     "offer it as a free keyable number)") != std::string::npos);
    CHECK(r.err.find("internal error") == std::string::npos);
}

TEST_CASE("bvh2rig: a warning about a clip in a folder whose name has a newline is one escaped line, and the rig loads")
{
    const auto dir = rig::test::scratchDir("outputs-newline") / "a\nb";
    fs::create_directories(dir);
    const fs::path clip = rig::test::writeFile(
        dir / "c.bvh",
        "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 3 Zrotation Xrotation Yrotation\n End Site\n"
        " {\n  OFFSET 0 1 0\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0.0333\n0 0 0\n");
    const auto out = dir / "rig.yaml";
    const auto r = run(fmt::format("{} '{}' -o '{}'", rig::test::tool("bvh2rig"), clip.string(), out.string()));
    CHECK(r.exitCode == 0);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK(r.err.starts_with("warning: "));
    CHECK(r.err.find("a\\nb/c.bvh:12: 'Frames: 2' but the file has 1 motion lines") != std::string::npos);
    CHECK(run(graphEval(fmt::format("'{}' --get 'Hips.rotateX'", out.string()))).exitCode == 0);
}

TEST_CASE("outputs: a legal long name is written (its temporary name cut to fit), one too long is refused first")
{
    const auto dir = rig::test::scratchDir("outputs-long-names");
    const std::string expected = armTable();
    // 245 bytes: ".NAME.PID.XXXXXX.tmp" would be over 255.
    const fs::path legal = dir / (std::string(240, 'n') + ".json");
    auto r = run(graphEval(fmt::format("{} --get '*.rotateZ' --format csv -o '{}'", arm, legal.string())));
    INFO(r.err);
    CHECK(r.exitCode == 0);
    CHECK(rig::test::readFile(legal) == expected);
    CHECK(std::distance(fs::directory_iterator(dir), fs::directory_iterator()) == 1);
    // 256 bytes: refused with one line before the work, nothing written.
    const fs::path tooLong = dir / (std::string(251, 'n') + ".json");
    r = run(graphEval(fmt::format("{} --get '*.rotateZ' --format csv -o '{}'", arm, tooLong.string())));
    CHECK(r.exitCode == 2);
    CHECK(r.err == fmt::format("error: {}: the file name is 256 bytes long, over the 255 its folder's file system "
                               "allows; give a shorter name\n",
                               tooLong.string()));
    CHECK(std::distance(fs::directory_iterator(dir), fs::directory_iterator()) == 1);
}

TEST_CASE("outputs: graph-eval's -o and --html are committed together, and a FIFO no process reads is refused first")
{
    const auto dir = rig::test::scratchDir("outputs-together");
    REQUIRE(run(fmt::format("{} {} --params 'shoulder.rotate?' 'elbow.rotate?' -o '{}'", rig::test::tool("rig-learn"),
                            arm, (dir / "arm.approx.yaml").string()))
                .exitCode == 0);
    // One character: the arm driven by its inverter, so that the crowd page has something to show.
    const fs::path crowd = rig::test::writeFile(
        dir / "crowd.yaml",
        fmt::format("plugins: [rigInversion]\ninclude: [{{file: '{}', namespace: c0}}]\nnodes:\n"
                    "  - {{name: c0:inv, type: rigInversion, file: arm.approx.yaml, connect: {{parameters: true, "
                    "namespace: c0}}}}\n",
                    (rig::test::sourceDir() / arm).string()));
    const fs::path values = rig::test::writeFile(dir / "values.json", "the previous values\n");
    auto r = run(graphEval(fmt::format("'{}' -o '{}' --html /dev/full", crowd.string(), values.string())));
    CHECK(r.exitCode == 2);
    CHECK(r.err ==
          "error: /dev/full: writing failed (No space left on device); check the free space and the folder's "
          "permissions\n");
    CHECK(rig::test::readFile(values) == "the previous values\n");
    CHECK(std::distance(fs::directory_iterator(dir), fs::directory_iterator()) == 3);

    // Without a reader the write would block forever once the work is done: refused before it.
    const fs::path fifo = dir / "fifo";
    REQUIRE(::mkfifo(fifo.c_str(), 0644) == 0);
    r = run("timeout -s KILL 60 " + graphEval(fmt::format("{} -o '{}'", arm, fifo.string())));
    CHECK(r.exitCode == 2);
    CHECK(r.err == fmt::format("error: {}: is a FIFO that no process reads; start its reader first, or give a file "
                               "for -o\n",
                               fifo.string()));
    CHECK(typeOf(fifo) == fs::file_type::fifo);
}
