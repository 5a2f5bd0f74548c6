// graph-eval end to end: the built binary run through the shell, exact outputs and exit codes.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "test_support.h"

using rig::test::run;

namespace {

const std::string arm = "rigs/examples/arm.yaml";

std::string graphEval(const std::string& args) { return fmt::format("{} {}", rig::test::tool("graph-eval"), args); }

std::string quote(const std::filesystem::path& p) { return fmt::format("'{}'", p.string()); }

std::vector<std::string> lines(const std::string& text)
{
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) out.push_back(line);
    return out;
}

std::vector<std::string> split(const std::string& line, char sep)
{
    std::vector<std::string> out;
    std::string field;
    std::istringstream in(line);
    while (std::getline(in, field, sep)) out.push_back(field);
    if (!line.empty() && line.back() == sep) out.emplace_back();
    return out;
}

// JSON output is valid YAML: parse it to read numbers back.
YAML::Node parseJson(const std::string& text) { return YAML::Load(text); }

std::vector<std::string> keysOf(const YAML::Node& object)
{
    std::vector<std::string> keys;
    for (const auto& kv : object) keys.push_back(kv.first.as<std::string>());
    return keys;
}

// Runs graph-eval and expects exit code 2, nothing on stdout and exactly "error: <message>\n" on stderr.
void checkBadInput(const std::string& args, const std::string& message)
{
    CAPTURE(args);
    const auto r = run(graphEval(args));
    CHECK(r.exitCode == 2);
    CHECK(r.out.empty());
    CHECK(r.err == "error: " + message + "\n");
}

// A joint chain j1 -> j2 (10 cm along x) under its own decomposeMatrix, and a control with a limited
// dynamic attribute.
const std::string twoJointRig = R"(nodes:
  - {name: ctrl, type: transform, addAttr: [{name: bend, min: 0, max: 10}]}
  - {name: j1, type: joint}
  - {name: j2, type: joint, parent: j1, translate: [10, 0, 0]}
  - {name: pos, type: decomposeMatrix}
connections:
  - j2.worldMatrix -> pos.inputMatrix
)";

// `chains` independent joint chains of `length` joints, each joint's rotateZ and rotateX driven by the
// chain's own animCurveTA, plus the time node: 1 + chains * (length + 1) nodes.
std::string manyChainsRig(int chains, int length)
{
    std::string text = "nodes:\n  - {name: time1, type: time}\n";
    std::string connections = "connections:\n";
    for (int c = 0; c < chains; ++c) {
        text += fmt::format(
            "  - {{name: c{}_anim, type: animCurveTA, keys: [[1, {}], [{}, {}], [24, {}]], tangents: "
            "{}}}\n",
            c, -5 * c, 6 + c, 40 + 3 * c, -10 + c, c % 2 ? "spline" : "clamped");
        connections += fmt::format("  - time1.outTime -> c{}_anim.input\n", c);
        for (int j = 0; j < length; ++j) {
            text +=
                fmt::format("  - {{name: c{}_j{}, type: joint, translate: [{}, {}, 0]{}}}\n", c, j, j == 0 ? 10 * c : 5,
                            j == 0 ? 0 : 1, j == 0 ? "" : fmt::format(", parent: c{}_j{}", c, j - 1));
            connections += fmt::format("  - c{}_anim.output -> c{}_j{}.rotateZ\n", c, c, j);
            if (j % 3 == 1) connections += fmt::format("  - c{}_anim.output -> c{}_j{}.rotateX\n", c, c, j);
        }
    }
    return text + connections;
}

// Control A's bend is animated over time and drives a chain of `lengthA` joints; control B drives a
// chain of `lengthB` joints and is not animated (or the other way round with `animateB`).
std::string twoControlsRig(int lengthA, int lengthB, bool animateB)
{
    std::string text = R"(nodes:
  - {name: time1, type: time}
  - {name: anim, type: animCurveTU, keys: [[1, 0], [10, 10]], tangents: linear}
)";
    std::string connections = fmt::format("connections:\n  - time1.outTime -> anim.input\n  - anim.output -> {}.bend\n",
                                          animateB ? "ctrlB" : "ctrlA");
    for (const auto& [name, length] : {std::pair{std::string("A"), lengthA}, std::pair{std::string("B"), lengthB}}) {
        text +=
            fmt::format("  - {{name: ctrl{}, type: transform, addAttr: [{{name: bend, min: 0, max: 10}}]}}\n", name);
        text +=
            fmt::format("  - {{name: sdk{}, type: animCurveUA, keys: [[0, 0], [10, 90]], tangents: linear}}\n", name);
        connections += fmt::format("  - ctrl{0}.bend -> sdk{0}.input\n  - sdk{0}.output -> {0}0.rotateZ\n", name);
        for (int j = 0; j < length; ++j)
            text += fmt::format("  - {{name: {}{}, type: joint, translate: [10, 0, 0]{}}}\n", name, j,
                                j == 0 ? "" : fmt::format(", parent: {}{}", name, j - 1));
    }
    return text + connections;
}

}  // namespace

TEST_CASE("graph-eval --help exits 0, shows examples, and the examples run")
{
    const auto r = run(graphEval("--help"));
    CHECK(r.exitCode == 0);
    CHECK(r.err.empty());
    CHECK(r.out.find("Example:") != std::string::npos);
    CHECK(r.out.find("graph-eval rigs/examples/arm.yaml --frames 1:24") != std::string::npos);
    CHECK(r.out.find("docs/graph-eval.md") != std::string::npos);
    for (const char* flag :
         {"--set", "--get", "--frames", "--format", "--output", "--plugin", "--dot", "--threads", "--stats", "--check"})
        CHECK(r.out.find(flag) != std::string::npos);
    int examples = 0;
    for (const auto& line : lines(r.out)) {
        const std::string prefix = "  graph-eval ";
        if (!line.starts_with(prefix)) continue;
        ++examples;
        CAPTURE(line);
        const auto example = run(graphEval(line.substr(prefix.size())));
        CHECK(example.exitCode == 0);
        CHECK(example.err.empty());
        CHECK(!example.out.empty());
    }
    CHECK(examples >= 2);
}

TEST_CASE("graph-eval JSON for the arm over frames: the driven key, the swing, matrix layout")
{
    const auto r =
        run(graphEval(arm + " --frames 1:24 --get elbow.rotateZ --get arm_ctrl.bend --get shoulder.rotateY"));
    REQUIRE(r.exitCode == 0);
    CHECK(r.err.empty());
    CHECK(
        r.out.starts_with("[\n  {\"frame\": 1,\n   \"elbow.rotateZ\": 0,\n   \"arm_ctrl.bend\": 0,\n"
                          "   \"shoulder.rotateY\": -20},\n  {\"frame\": 2,\n"));
    CHECK(r.out.ends_with("   \"shoulder.rotateY\": 20}\n]\n"));
    const YAML::Node rows = parseJson(r.out);
    REQUIRE(rows.IsSequence());
    REQUIRE(rows.size() == 24);
    for (std::size_t i = 0; i < rows.size(); ++i) {
        const YAML::Node& row = rows[i];
        CAPTURE(i);
        CHECK(keysOf(row) == std::vector<std::string>{"frame", "elbow.rotateZ", "arm_ctrl.bend", "shoulder.rotateY"});
        CHECK(row["frame"].as<double>() == static_cast<double>(i + 1));
        const double bend = row["arm_ctrl.bend"].as<double>();
        CHECK(bend >= 0.0);
        CHECK(bend <= 10.0);
        // The set-driven key is linear 0..10 -> 0..120 degrees: the elbow turns 12 degrees per unit of bend.
        CHECK(row["elbow.rotateZ"].as<double>() == doctest::Approx(12.0 * bend).epsilon(1e-12));
        // Two spline keys (1, -20) and (24, 20) make a straight line.
        CHECK(row["shoulder.rotateY"].as<double>() ==
              doctest::Approx(-20.0 + 40.0 * static_cast<double>(i) / 23.0).epsilon(1e-9));
    }
    CHECK(rows[0]["shoulder.rotateY"].as<double>() == -20.0);
    CHECK(rows[23]["shoulder.rotateY"].as<double>() == 20.0);
    // bend_anim peaks at its key (12, 10): the elbow is at 120 degrees.
    CHECK(rows[11]["arm_ctrl.bend"].as<double>() == 10.0);
    CHECK(rows[11]["elbow.rotateZ"].as<double>() == doctest::Approx(120.0).epsilon(1e-12));

    // Matrices are four rows, column vectors: the translation is the last column. At frame 1 the elbow is
    // straight, the shoulder turned -20 degrees about y and the elbow's orient -10 more.
    const auto m = run(graphEval(arm + " --frames 1:1 --get wrist.worldMatrix --get shoulder.rotateOrder"));
    REQUIRE(m.exitCode == 0);
    const YAML::Node frame1 = parseJson(m.out)[0];
    CHECK(frame1["shoulder.rotateOrder"].as<std::string>() == "xzy");
    const YAML::Node w = frame1["wrist.worldMatrix"];
    REQUIRE(w.size() == 4);
    const double deg = std::numbers::pi / 180.0;
    CHECK(w[0][3].as<double>() == doctest::Approx(20 + 30 * std::cos(20 * deg) + 25 * std::cos(30 * deg)));
    CHECK(w[1][3].as<double>() == doctest::Approx(150));
    CHECK(w[2][3].as<double>() == doctest::Approx(30 * std::sin(20 * deg) + 25 * std::sin(30 * deg)));
    CHECK(w[0][0].as<double>() == doctest::Approx(std::cos(30 * deg)));
    CHECK(w[2][0].as<double>() == doctest::Approx(std::sin(30 * deg)));
    for (int c = 0; c < 4; ++c) CHECK(w[3][c].as<double>() == (c == 3 ? 1.0 : 0.0));

    // Without --frames: one object at the current time, frame 0; enums print as names.
    const auto now = run(graphEval(arm + " --get shoulder.rotateY --get shoulder.rotateOrder"));
    CHECK(now.exitCode == 0);
    CHECK(now.out == "[\n  {\"frame\": 0,\n   \"shoulder.rotateY\": -20,\n   \"shoulder.rotateOrder\": \"xzy\"}\n]\n");
}

TEST_CASE("graph-eval without --get prints every output plug, and non-finite numbers as null")
{
    const auto r = run(graphEval(arm));
    REQUIRE(r.exitCode == 0);
    const YAML::Node rows = parseJson(r.out);
    REQUIRE(rows.size() == 1);
    const auto keys = keysOf(rows[0]);
    CHECK(std::count(keys.begin(), keys.end(), "wrist.worldMatrix") == 1);
    CHECK(std::count(keys.begin(), keys.end(), "wrist_world.outputTranslate") == 1);
    CHECK(std::count(keys.begin(), keys.end(), "elbow_bend_sdk.output") == 1);
    // Inputs and vector components are not listed by default.
    CHECK(std::count(keys.begin(), keys.end(), "elbow.rotate") == 0);
    CHECK(std::count(keys.begin(), keys.end(), "wrist_world.outputTranslateX") == 0);

    // 2 * 1e308 overflows in the plugin's node: JSON null, an empty CSV field.
    const auto dir = rig::test::scratchDir("graph-eval-null");
    const auto rig = rig::test::writeFile(dir / "doubler.yaml", "nodes:\n  - {name: d, type: testDoubler}\n");
    const std::string plugin = quote(std::filesystem::path(RIG_BINARY_DIR) / "test-plugins" / "test_plugin.so");
    const auto json = run(graphEval(fmt::format("{} --plugin {} --set d.input=1e308", quote(rig), plugin)));
    CHECK(json.exitCode == 0);
    CHECK(json.out == "[\n  {\"frame\": 0,\n   \"d.output\": null}\n]\n");
    const auto csv = run(graphEval(fmt::format("{} --plugin {} --set d.input=1e308 --format csv", quote(rig), plugin)));
    CHECK(csv.exitCode == 0);
    CHECK(csv.out == "frame,d.output\n0,\n");
}

TEST_CASE("graph-eval --format csv: a header naming components and matrix cells, one row per frame")
{
    const auto r = run(graphEval(
        arm + " --frames 1:24 --get elbow.rotate --get wrist.worldMatrix --get shoulder.rotateOrder --format csv"));
    REQUIRE(r.exitCode == 0);
    CHECK(r.err.empty());
    const auto rows = lines(r.out);
    REQUIRE(rows.size() == 25);
    std::string header = "frame,elbow.rotateX,elbow.rotateY,elbow.rotateZ";
    for (int row = 0; row < 4; ++row)
        for (int col = 0; col < 4; ++col) header += fmt::format(",wrist.worldMatrix[{}][{}]", row, col);
    header += ",shoulder.rotateOrder";
    CHECK(rows[0] == header);
    for (std::size_t i = 1; i < rows.size(); ++i) {
        CAPTURE(rows[i]);
        const auto fields = split(rows[i], ',');
        REQUIRE(fields.size() == 21);
        CHECK(fields[0] == std::to_string(i));
        CHECK(fields[16] == "0");  // matrix row 3: 0 0 0 1
        CHECK(fields[19] == "1");
        CHECK(fields[20] == "xzy");  // an enum by its name, as in JSON and the table
    }
    CHECK(rows[1] ==
          "1,0,0,0,0.8660254037844387,0,-0.5,69.84141371818822,0,1,0,150,0.5,0,0.8660254037844387,"
          "22.760604299770062,0,0,0,1,xzy");

    // A fractional step.
    const auto half = run(graphEval(arm + " --frames 0:2:0.5 --get shoulder.rotateY --format csv"));
    CHECK(half.exitCode == 0);
    CHECK(half.out.starts_with("frame,shoulder.rotateY\n0,-20\n0.5,-20\n1,-20\n1.5,"));
    CHECK(lines(half.out).size() == 6);
}

TEST_CASE("graph-eval --format table: aligned columns, six significant digits")
{
    const auto r = run(graphEval(arm + " --frames 1:3 --get elbow.rotateZ --get shoulder.rotateY --format table"));
    CHECK(r.exitCode == 0);
    CHECK(r.err.empty());
    CHECK(r.out ==
          "frame  elbow.rotateZ  shoulder.rotateY\n"
          "    1              0               -20\n"
          "    2        2.79489          -18.2609\n"
          "    3        10.4583          -16.5217\n");
}

TEST_CASE("graph-eval --get globs and names")
{
    auto keys = [](const std::string& args) {
        const auto r = run(graphEval(arm + " " + args));
        REQUIRE(r.exitCode == 0);
        auto k = keysOf(parseJson(r.out)[0]);
        k.erase(k.begin());  // "frame"
        return k;
    };
    CHECK(keys("--get '*.rotateZ'") ==
          std::vector<std::string>{"arm_ctrl.rotateZ", "shoulder.rotateZ", "elbow.rotateZ", "wrist.rotateZ"});
    CHECK(keys("--get 'elbow.rotate?'") == std::vector<std::string>{"elbow.rotateX", "elbow.rotateY", "elbow.rotateZ"});
    CHECK(keys("--get '*.worldMatrix'") == std::vector<std::string>{"arm_ctrl.worldMatrix", "shoulder.worldMatrix",
                                                                    "elbow.worldMatrix", "wrist.worldMatrix"});
    CHECK(keys("--get 'wrist_world.outputTranslate[XZ]'") ==
          std::vector<std::string>{"wrist_world.outputTranslateX", "wrist_world.outputTranslateZ"});
    // Patterns in the order given; a plug matched twice is printed once.
    CHECK(keys("--get elbow.rotateZ --get 'elbow.rotate?' --get elbow.rotate") ==
          std::vector<std::string>{"elbow.rotateZ", "elbow.rotateX", "elbow.rotateY", "elbow.rotate"});
    // CSV names vector components like their plugs; a component selected with its vector is one column.
    const auto csv = run(graphEval(arm + " --get 'wrist.rotate*' --format csv"));
    CHECK(csv.exitCode == 0);
    CHECK(csv.out ==
          "frame,wrist.rotateX,wrist.rotateY,wrist.rotateZ,wrist.rotateOrder,wrist.rotateAxisX,"
          "wrist.rotateAxisY,wrist.rotateAxisZ\n0,0,0,0,xyz,0,0,0\n");
    CHECK(keys("--get 'wrist.rotate*'") == std::vector<std::string>{"wrist.rotate", "wrist.rotateX", "wrist.rotateY",
                                                                    "wrist.rotateZ", "wrist.rotateOrder",
                                                                    "wrist.rotateAxis", "wrist.rotateAxisX",
                                                                    "wrist.rotateAxisY", "wrist.rotateAxisZ"});
    // The rig may come after the flags: each --get takes one value.
    const auto after = run(graphEval("--get 'elbow.rotate?' --get shoulder.rotateY " + arm + " --format csv"));
    CHECK(after.exitCode == 0);
    CHECK(after.out == "frame,elbow.rotateX,elbow.rotateY,elbow.rotateZ,shoulder.rotateY\n0,0,0,0,-20\n");
}

TEST_CASE("graph-eval --get: [*] and [N] select array elements, other brackets are sets")
{
    const auto columns = [](const std::string& gets) {
        const auto r = run(graphEval("rigs/biped.yaml " + gets + " --format csv"));
        REQUIRE(r.exitCode == 0);
        return split(lines(r.out).front(), ',');
    };
    // [*] was read as the set {'*'} and matched nothing.
    CHECK(columns("--get 'L_thumb2_curl_sum.input1D[*]'") ==
          std::vector<std::string>{"frame", "L_thumb2_curl_sum.input1D[0]", "L_thumb2_curl_sum.input1D[1]"});
    // A set in the node name beside an index; an index as plug names write it, leading zeros or not.
    CHECK(columns("--get '[LR]_thumb2_curl_sum.input1D[1]' --get '*_index2_curl_sum.input1D[001]'") ==
          std::vector<std::string>{"frame", "L_thumb2_curl_sum.input1D[1]", "R_thumb2_curl_sum.input1D[1]",
                                   "L_index2_curl_sum.input1D[1]", "R_index2_curl_sum.input1D[1]"});
    // [*] stands for an index only, not for what follows it, and a plug without elements has none.
    const auto none = run(graphEval("rigs/biped.yaml --get 'L_thumb2_curl_sum.input1D[*]x'"));
    CHECK(none.exitCode == 2);
    CHECK(none.err ==
          "error: no plug matches 'L_thumb2_curl_sum.input1D[*]x'; patterns look like '*.worldMatrix' or "
          "'L_arm_*.rotate?'\n");
    const auto noIndex = run(graphEval("rigs/biped.yaml --get 'L_thumb2_curl_sum.output1D[*]'"));
    CHECK(noIndex.exitCode == 2);
    // An array named without an element: the way to take them all is said, before any frame is evaluated.
    const auto whole = run(graphEval("rigs/biped.yaml --get L_thumb2_curl_sum.input1D"));
    CHECK(whole.exitCode == 2);
    CHECK(whole.err ==
          "error: L_thumb2_curl_sum.input1D is an array attribute: name an element, e.g. "
          "L_thumb2_curl_sum.input1D[0], or take them all with L_thumb2_curl_sum.input1D[*]\n");
}

TEST_CASE("graph-eval --types lists every node type, the bundled rigInversion plugin's among them")
{
    const auto r = run(graphEval("--types"));
    REQUIRE(r.exitCode == 0);
    CHECK(r.out.find("\n### joint\n") != std::string::npos);
    CHECK(r.out.find("\n### rigInversion\n") != std::string::npos);
    // Given with --plugin too, it is listed once.
    const auto again = run(graphEval("--plugin rigInversion --types"));
    REQUIRE(again.exitCode == 0);
    CHECK(again.out == r.out);
}

TEST_CASE("graph-eval --set takes degrees: a scalar, a vector and an enum by name or index")
{
    const auto dir = rig::test::scratchDir("graph-eval-set");
    const std::string rig = quote(rig::test::writeFile(dir / "two.yaml", twoJointRig));
    auto position = [&](const std::string& sets) {
        const auto r = run(graphEval(rig + " " + sets + " --get pos.outputTranslate"));
        REQUIRE(r.exitCode == 0);
        CHECK(r.err.empty());
        return parseJson(r.out)[0]["pos.outputTranslate"];
    };
    auto near = [](const YAML::Node& v, double x, double y, double z) {
        REQUIRE(v.size() == 3);
        CHECK(v[0].as<double>() == doctest::Approx(x));
        CHECK(v[1].as<double>() == doctest::Approx(y));
        CHECK(v[2].as<double>() == doctest::Approx(z));
    };
    near(position(""), 10, 0, 0);
    // 90 degrees about z takes j2 from +x to +y.
    near(position("--set j1.rotateZ=90"), 0, 10, 0);
    // xyz applies X first (no effect on +x), then Z: +y. zyx applies Z first (+y), then X: +z.
    near(position("--set 'j1.rotate=[90, 0, 90]'"), 0, 10, 0);
    near(position("--set 'j1.rotate=[90, 0, 90]' --set j1.rotateOrder=zyx"), 0, 0, 10);
    near(position("--set 'j1.rotate=[90, 0, 90]' --set j1.rotateOrder=5"), 0, 0, 10);
    near(position("--set j1.translateY=-4 --set j2.scaleX=3"), 10, -4, 0);

    const auto r = run(graphEval(rig + " --set 'j1.rotate=[0, 0, 90]' --set j1.rotateOrder=zyx --set ctrl.bend=10"
                                       " --get j1.rotate --get j1.rotateOrder --get ctrl.bend"));
    CHECK(r.exitCode == 0);
    CHECK(r.out ==
          "[\n  {\"frame\": 0,\n   \"j1.rotate\": [0, 0, 90],\n   \"j1.rotateOrder\": \"zyx\",\n"
          "   \"ctrl.bend\": 10}\n]\n");
}

TEST_CASE("graph-eval -o writes the file and prints nothing, and a failing run leaves files alone")
{
    const auto dir = rig::test::scratchDir("graph-eval-output");
    const std::string args = arm + " --frames 1:5 --get '*.rotateZ'";
    const auto expected = run(graphEval(args));
    REQUIRE(expected.exitCode == 0);

    const auto file = dir / "out.json";
    const auto r = run(graphEval(args + " -o " + quote(file)));
    CHECK(r.exitCode == 0);
    CHECK(r.out.empty());
    CHECK(r.err.empty());
    CHECK(rig::test::readFile(file) == expected.out);
    const auto csv = run(graphEval(args + " --format csv --output " + quote(dir / "out.csv")));
    CHECK(csv.exitCode == 0);
    CHECK(csv.out.empty());
    CHECK(rig::test::readFile(dir / "out.csv").starts_with("frame,arm_ctrl.rotateZ,"));

    // A bad run does not touch an existing output.
    checkBadInput(arm + " --frames 1:x -o " + quote(file),
                  "--frames '1:x': 'x' is not a number; expected A:B[:STEP], e.g. 1:240 or 1:240:2");
    CHECK(rig::test::readFile(file) == expected.out);

    // An unwritable path: exit 2, one error line, nothing created (no temporary file left either).
    checkBadInput(arm + " -o /nonexistent/dir/out.json",
                  "/nonexistent/dir/out.json: cannot write here (No such file or directory); check the folder "
                  "exists and is writable");
    CHECK(!std::filesystem::exists("/nonexistent"));
    const auto missing = dir / "missing" / "out.json";
    checkBadInput(
        arm + " -o " + quote(missing),
        fmt::format("{}: cannot write here (No such file or directory); check the folder exists and is writable",
                    missing.string()));
    CHECK(!std::filesystem::exists(dir / "missing"));
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(dir))
        names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    CHECK(names == std::vector<std::string>{"out.csv", "out.json"});
}

TEST_CASE("graph-eval --dot prints a digraph with every node and connection")
{
    const auto dir = rig::test::scratchDir("graph-eval-dot");
    const std::string rig = quote(rig::test::writeFile(dir / "two.yaml", twoJointRig));
    const auto r = run(graphEval(rig + " --dot"));
    CHECK(r.exitCode == 0);
    CHECK(r.err.empty());
    CHECK(r.out == R"dot(digraph rig {
  rankdir=LR;
  node [shape=box, fontname=Helvetica];
  n0 [label="ctrl\n(transform)"];
  n1 [label="j1\n(joint)"];
  n2 [label="j2\n(joint)"];
  n3 [label="pos\n(decomposeMatrix)"];
  n1 -> n2 [label="worldMatrix -> parentMatrix", fontsize=9];
  n1 -> n2 [label="scale -> inverseScale", fontsize=9];
  n2 -> n3 [label="worldMatrix -> inputMatrix", fontsize=9];
}
)dot");

    const auto a = run(graphEval(arm + " --dot"));
    CHECK(a.exitCode == 0);
    CHECK(a.out.starts_with("digraph rig {\n"));
    CHECK(a.out.ends_with("}\n"));
    const auto all = lines(a.out);
    CHECK(std::count_if(all.begin(), all.end(), [](const std::string& l) {
              return l.find("[label=\"") != std::string::npos && l.find(" -> n") != std::string::npos;
          }) == 11);
    CHECK(a.out.find("  n6 -> n1 [label=\"output -> bend\", fontsize=9];\n") != std::string::npos);
    CHECK(a.out.find("  n5 -> n3 [label=\"output -> rotateZ\", fontsize=9];\n") != std::string::npos);
    CHECK(a.out.find("  n5 [label=\"elbow_bend_sdk\\n(animCurveUA)\"];\n") != std::string::npos);
}

TEST_CASE("graph-eval --threads 1, 2 and 8 print byte-identical results on a 200+ node rig")
{
    const auto dir = rig::test::scratchDir("graph-eval-threads");
    const int chains = 12;
    const int length = 17;
    const std::string rig = quote(rig::test::writeFile(dir / "chains.yaml", manyChainsRig(chains, length)));
    const int nodes = 1 + chains * (length + 1);
    REQUIRE(nodes >= 200);

    const std::string csvArgs = rig + " --frames 1:24:0.5 --get '*.worldMatrix' --format csv";
    const auto serialCsv = run(graphEval(csvArgs));
    REQUIRE(serialCsv.exitCode == 0);
    CHECK(lines(serialCsv.out).size() == 48);
    std::string reference;
    for (int threads : {1, 2, 8}) {
        CAPTURE(threads);
        const auto r = run(graphEval(fmt::format("{} --frames 1:12 --threads {} --stats", rig, threads)));
        REQUIRE(r.exitCode == 0);
        CHECK(r.err.starts_with(fmt::format("stats: {} nodes, ", nodes)));
        CHECK(r.err.find(fmt::format(", {} threads, 12 frames, ", threads)) != std::string::npos);
        if (threads == 1) {
            reference = r.out;
            const YAML::Node rows = parseJson(r.out);
            REQUIRE(rows.size() == 12);
            // "frame", time1.outTime, every joint's three matrices and every curve's output.
            CHECK(rows[0].size() == 2 + 3 * chains * length + chains);
            // The chains moved: c3's tip is not where it was at frame 1.
            CHECK(rows[0]["c3_j16.worldMatrix"][0][3].as<double>() !=
                  rows[10]["c3_j16.worldMatrix"][0][3].as<double>());
        } else CHECK(r.out == reference);

        const auto csv = run(graphEval(fmt::format("{} --threads {}", csvArgs, threads)));
        REQUIRE(csv.exitCode == 0);
        CHECK(csv.out == serialCsv.out);
    }
}

TEST_CASE("graph-eval --stats prints counts to stderr: animating one control recomputes only its downstream")
{
    const auto dir = rig::test::scratchDir("graph-eval-stats");
    // Per frame, time1, anim, the animated control's sdk and its chain recompute; the control node
    // itself does not (a dynamic attribute affects nothing on its node) and nor does the other chain.
    auto stats = [&](const std::string& name, int lengthA, int lengthB, bool animateB, const std::string& args) {
        const auto rig = rig::test::writeFile(dir / name, twoControlsRig(lengthA, lengthB, animateB));
        const auto r = run(graphEval(quote(rig) + " " + args));
        REQUIRE(r.exitCode == 0);
        CHECK(!r.out.empty());
        REQUIRE(lines(r.err).size() == 1);
        CHECK(r.err.ends_with(" ms per frame\n"));
        return r.err.substr(0, r.err.rfind(", ") + 2);
    };
    // Nodes: time1, anim, 2 controls, 2 sdks, 2 + 8 joints = 16; connections: 2 + 2 * 2 + 2 per parented joint.
    CHECK(stats("a.yaml", 2, 8, false, "--frames 1:5 --stats") ==
          "stats: 16 nodes, 22 connections, 1 threads, 5 frames, 25 node computations, ");
    CHECK(stats("b.yaml", 2, 8, true, "--frames 1:5 --stats") ==
          "stats: 16 nodes, 22 connections, 1 threads, 5 frames, 55 node computations, ");
    CHECK(stats("b.yaml", 2, 8, true, "--frames 1:5 --stats --threads 2") ==
          "stats: 16 nodes, 22 connections, 2 threads, 5 frames, 55 node computations, ");
    // Only what is asked for is pulled: the unanimated chain's tip costs nothing per frame.
    CHECK(stats("a.yaml", 2, 8, false, "--frames 1:5 --stats --get B7.worldMatrix") ==
          "stats: 16 nodes, 22 connections, 1 threads, 5 frames, 0 node computations, ");
    CHECK(stats("a.yaml", 2, 8, false, "--frames 1:5 --stats --get A1.worldMatrix") ==
          "stats: 16 nodes, 22 connections, 1 threads, 5 frames, 25 node computations, ");
    // Without --stats nothing goes to stderr.
    const auto quiet = run(graphEval(quote(dir / "a.yaml") + " --frames 1:5"));
    CHECK(quiet.exitCode == 0);
    CHECK(quiet.err.empty());
}

TEST_CASE("graph-eval --check passes on the arm and changes nothing in the output")
{
    const std::string args = arm + " --frames 1:24:0.5";
    const auto plain = run(graphEval(args));
    const auto checked = run(graphEval(args + " --check"));
    CHECK(checked.exitCode == 0);
    CHECK(checked.err.empty());
    CHECK(checked.out == plain.out);
    const auto parallel = run(graphEval(args + " --check --threads 8 --format csv"));
    CHECK(parallel.exitCode == 0);
    CHECK(parallel.err.empty());
}

TEST_CASE("graph-eval --plugin loads node types a rig can use")
{
    const auto dir = rig::test::scratchDir("graph-eval-plugin");
    const auto rig = rig::test::writeFile(dir / "doubler.yaml", R"(nodes:
  - {name: d, type: testDoubler, input: 21}
  - {name: d2, type: testDoubler}
  - {name: j, type: joint}
connections:
  - d.output -> d2.input
  - d2.output -> j.translateY
)");
    const std::string plugin = quote(std::filesystem::path(RIG_BINARY_DIR) / "test-plugins" / "test_plugin.so");
    const auto r = run(graphEval(fmt::format("{} --plugin {} --get '*.output' --get j.translate", quote(rig), plugin)));
    CHECK(r.exitCode == 0);
    CHECK(r.err.empty());
    CHECK(r.out ==
          "[\n  {\"frame\": 0,\n   \"d.output\": 42,\n   \"d2.output\": 84,\n   \"j.translate\": [0, 84, 0]}\n]\n");
    const auto set = run(
        graphEval(fmt::format("--plugin {} {} --set d.input=-1.5 --get d2.output --format csv", plugin, quote(rig))));
    CHECK(set.exitCode == 0);
    CHECK(set.out == "frame,d2.output\n0,-6\n");

    checkBadInput(quote(rig), fmt::format("{}:2:21: unknown node type 'testDoubler'", rig.string()));
    checkBadInput(
        arm + " --plugin /no/such/plugin.so",
        "plugin '/no/such/plugin.so' not found (looked for /no/such/plugin.so); build it, or add its folder to "
        "RIG_PLUGIN_PATH");
}

TEST_CASE("graph-eval bad input: exit 2, one error line, nothing on stdout")
{
    const std::string frames = "expected A:B[:STEP], e.g. 1:240 or 1:240:2";
    checkBadInput("no/such/rig.yaml", "no/such/rig.yaml: no such rig file");
    checkBadInput("", "no rig file given; usage: graph-eval RIG.yaml [options], or --help");
    checkBadInput(arm + " --bogus",
                  "The following argument was not expected: --bogus; run 'graph-eval --help' for usage");
    checkBadInput(arm + " --format xml", "--format: xml not in {json,csv,table}; run 'graph-eval --help' for usage");
    checkBadInput(arm + " --threads -1",
                  "--threads: '-1' is not a thread count; give a whole number from 0 (all cores) "
                  "to 1024; run 'graph-eval --help' for usage");
    checkBadInput(arm + " --frames 1:x", "--frames '1:x': 'x' is not a number; " + frames);
    checkBadInput(arm + " --frames 5:1", "--frames '5:1': the last frame is before the first; " + frames);
    checkBadInput(arm + " --frames 1:10:0", "--frames '1:10:0': the step must be positive; " + frames);
    checkBadInput(arm + " --frames 1", "--frames '1': give two or three numbers; " + frames);
    checkBadInput(arm + " --frames 1:2:3:4", "--frames '1:2:3:4': give two or three numbers; " + frames);
    checkBadInput(arm + " --frames :5", "--frames ':5': '' is not a number; " + frames);

    checkBadInput(arm + " --set elbow.rotateZ",
                  "--set 'elbow.rotateZ': expected node.attr=VALUE, e.g. --set elbow.rotateZ=45");
    checkBadInput(arm + " --set elbow.jointOrent=5",
                  "node 'elbow' (joint) has no attribute 'jointOrent'; did you mean 'jointOrient'?");
    checkBadInput(arm + " --set elbo.rotateX=5", "no node named 'elbo'; did you mean 'elbow'?");
    checkBadInput(arm + " --set elbow.rotateZ=5",
                  "cannot set elbow.rotateZ: it is driven by elbow_bend_sdk.output; disconnect it first");
    checkBadInput(arm + " --set elbow.rotateX=abc", "--set elbow.rotateX: expected a number, got 'abc'");
    checkBadInput(arm + " --set 'elbow.rotate=[1, 2'",
                  "--set elbow.rotate: '[1, 2' is not a value; numbers, true/false, names, [x, y, z]");
    checkBadInput(arm + " --set shoulder.rotateOrder=xyy",
                  "--set shoulder.rotateOrder: 'xyy' is not one of xyz, yzx, zxy, xzy, yxz, zyx; did you mean 'xyz'?");

    const auto dir = rig::test::scratchDir("graph-eval-bad-input");
    const std::string two = quote(rig::test::writeFile(dir / "two.yaml", twoJointRig));
    checkBadInput(two + " --set ctrl.bend=10.5", "cannot set ctrl.bend: 10.5 is above its maximum 10");
    checkBadInput(two + " --set ctrl.bend=-1", "cannot set ctrl.bend: -1 is below its minimum 0");
    checkBadInput(two + " --set j1.rotateX=.inf", "--set j1.rotateX: .inf is not a finite number");

    checkBadInput(arm + " --get 'nothing*'",
                  "no plug matches 'nothing*'; patterns look like '*.worldMatrix' or 'L_arm_*.rotate?'");
    checkBadInput(arm + " --get '*.rotateZ' --get '*.rotateW'",
                  "no plug matches '*.rotateW'; patterns look like '*.worldMatrix' or 'L_arm_*.rotate?'");
    checkBadInput(arm + " --get elbow.rotat", "node 'elbow' (joint) has no attribute 'rotat'; did you mean 'rotate'?");
    // A name close to none (another tool's word): what the node computes, named.
    checkBadInput(arm + " --get elbow_bend_sdk.converged",
                  "node 'elbow_bend_sdk' (animCurveUA) has no attribute 'converged'; its outputs are output "
                  "(graph-eval --types lists its inputs)");

    const auto syntax = rig::test::writeFile(dir / "syntax.yaml", "nodes:\n  - {name: a, type: joint\n  - {name: b}\n");
    checkBadInput(quote(syntax), fmt::format("{}:3:5: YAML syntax error: end of map flow not found", syntax.string()));
    const auto type = rig::test::writeFile(dir / "type.yaml", "nodes:\n  - {name: a, type: jiont}\n");
    checkBadInput(quote(type), fmt::format("{}:2:21: unknown node type 'jiont'; did you mean 'joint'?", type.string()));
    const auto cycle = rig::test::writeFile(dir / "cycle.yaml", R"(nodes:
  - {name: a, type: joint}
  - {name: b, type: joint, parent: a}
connections:
  - b.worldMatrix -> a.parentMatrix
)");
    checkBadInput(
        quote(cycle),
        fmt::format("{}:5:5: cannot connect b.worldMatrix -> a.parentMatrix: it would close a cycle "
                    "(a.scale -> b.inverseScale, b.worldMatrix -> a.parentMatrix); the graph must stay acyclic "
                    "at node level, so feed a from nodes that do not depend on a",
                    cycle.string()));
    // Bad input is reported even with --dot or -o, and before anything is written.
    checkBadInput(quote(type) + " --dot",
                  fmt::format("{}:2:21: unknown node type 'jiont'; did you mean 'joint'?", type.string()));
    checkBadInput(quote(type) + " -o " + quote(dir / "out.json"),
                  fmt::format("{}:2:21: unknown node type 'jiont'; did you mean 'joint'?", type.string()));
    CHECK(!std::filesystem::exists(dir / "out.json"));
}
