// Maya .anim files: a file as Maya's exporter writes it read back with its units, tangents and infinities;
// writing then reading gives the same bits; the one-line errors with file:line:col; animCurve nodes that play
// a file's curve (animFile, animPlug) as they play the same keys given with `keys:`.

#include <doctest/doctest.h>

#include <cmath>
#include <numbers>
#include <string>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "nodes/curves/anim_file.h"
#include "test_support.h"

using namespace rig;

namespace {

// As Maya 2018's animExport writes a selection of one transform: units in mm and radians, a node kept for
// the hierarchy with no curve, comments.
constexpr const char* mayaFile = R"(animVersion 1.1;
mayaVersion 2018 x64;
timeUnit ntsc;
linearUnit mm;
angularUnit rad;
startTime 1;
endTime 24;
// a comment
anim ctrl 0 1 0;
anim translate.translateX translateX ctrl 0 0 0;
animData {
  input time;
  output linear;
  weighted 0;
  preInfinity constant;
  postInfinity linear;
  keys {
    1 10 linear linear 1 1 0;
    12 -25.5 spline auto 1 1 0;   # a key with different tangents
    24 40 stepnext flat 0 1 1;
  }
}
anim rotate.rotateY rotateY ctrl 0 0 1;
animData {
  input time;
  output angular;
  weighted 0;
  preInfinity cycle;
  postInfinity oscillate;
  keys {
    1 0.5 clamped plateau 1 1;
    10 1 auto auto 1 1 0;
  }
}
)";

std::string errorOf(const std::string& text)
{
    try {
        parseAnimFile(text, "t.anim");
    }
    catch (const Error& e) {
        return e.what();
    }
    return "no error";
}

std::string header(const std::string& more = "") { return "animVersion 1.1;\nmayaVersion 2024;\n" + more; }

}  // namespace

TEST_CASE("anim file: Maya's export reads with its units, tangents, infinities and plugs")
{
    const AnimFile file = parseAnimFile(mayaFile, "t.anim");
    CHECK(file.timeUnit == "ntsc");
    CHECK(*file.startTime == 1.0);
    CHECK(*file.endTime == 24.0);
    REQUIRE(file.curves.size() == 2);

    const AnimFileCurve& tx = file.curves[0];
    CHECK(tx.plugName() == "ctrl.translateX");
    CHECK(tx.attribute == "translate.translateX");
    CHECK(tx.nodeTypeName() == "animCurveTL");
    CHECK(tx.mark.line == 10);
    CHECK(tx.mark.column == 1);
    CHECK(tx.post == Infinity::linear);
    REQUIRE(tx.keys.size() == 3);
    CHECK(tx.keys[1].x == 12.0);
    CHECK(tx.keys[1].y == doctest::Approx(-2.55));  // mm to cm
    CHECK(tx.keys[1].inTangent == TangentType::spline);
    CHECK(tx.keys[1].outTangent == TangentType::auto_);
    CHECK(tx.keys[2].inTangent == TangentType::stepNext);

    const AnimFileCurve& ry = file.curves[1];
    CHECK(ry.nodeTypeName() == "animCurveTA");
    CHECK(ry.keys[1].y == doctest::Approx(180.0 / std::numbers::pi));  // radians to degrees
    CHECK(ry.pre == Infinity::cycle);
    CHECK(ry.post == Infinity::oscillate);
    CHECK(ry.keys[0].outTangent == TangentType::plateau);
    CHECK(file.find("ctrl.rotateY") == &ry);
    CHECK(file.find("ctrl.rotateX") == nullptr);
}

TEST_CASE("anim file: written then read gives the same keys, bit for bit, in cm and degrees")
{
    AnimFile file = parseAnimFile(mayaFile, "t.anim");
    file.curves[0].keys[0].y = 0.1 + 0.2;  // a number with no short decimal form
    file.timeUnit = *mayaTimeUnit(120.0);
    const std::string text = formatAnimFile(file);
    CHECK(text.find("linearUnit cm;") != std::string::npos);
    CHECK(text.find("angularUnit deg;") != std::string::npos);
    CHECK(text.find("timeUnit 120fps;") != std::string::npos);
    const AnimFile back = parseAnimFile(text, "back.anim");
    REQUIRE(back.curves.size() == file.curves.size());
    for (std::size_t c = 0; c < file.curves.size(); ++c) {
        CHECK(back.curves[c].plugName() == file.curves[c].plugName());
        CHECK(back.curves[c].attribute == file.curves[c].attribute);
        CHECK(back.curves[c].output == file.curves[c].output);
        CHECK(back.curves[c].pre == file.curves[c].pre);
        CHECK(back.curves[c].post == file.curves[c].post);
        REQUIRE(back.curves[c].keys.size() == file.curves[c].keys.size());
        for (std::size_t k = 0; k < file.curves[c].keys.size(); ++k) {
            CHECK(back.curves[c].keys[k].x == file.curves[c].keys[k].x);
            CHECK(back.curves[c].keys[k].y == file.curves[c].keys[k].y);
            CHECK(back.curves[c].keys[k].inTangent == file.curves[c].keys[k].inTangent);
            CHECK(back.curves[c].keys[k].outTangent == file.curves[c].keys[k].outTangent);
        }
    }
    CHECK(back.timeUnit == "120fps");
    CHECK(mayaTimeUnit(24.0) == "film");
    CHECK(mayaTimeUnit(1.0 / 0.0083333) == "120fps");  // a CMU clip's Frame Time
    CHECK_FALSE(mayaTimeUnit(7.0).has_value());
}

TEST_CASE("anim file: bad files give one line with file:line:col and what to do")
{
    const std::string curve = "anim rotate.rotateX rotateX a 0 0 0;\nanimData {\n  output angular;\n  keys {\n";
    CHECK(errorOf("") == "t.anim:1:1: the file is empty; a .anim file starts with its animVersion line");
    CHECK(errorOf("hello;") ==
          "t.anim:1:1: 'hello': a .anim file starts with its animVersion line; this is not a "
          "Maya .anim file (export one with the animImportExport plugin)");
    CHECK(errorOf("animVersion 3.0;") ==
          "t.anim:1:13: animVersion 3.0: this reader knows versions 1.0 and 1.1 of the "
          "format");
    CHECK(errorOf(header("timeUnit sec;\n")) ==
          "t.anim:3:10: timeUnit sec: key times in clock units are not read; "
          "export with a frame rate (film, ntsc, 120fps, ...)");
    CHECK(errorOf(header("linearUnit furlong;\n")) ==
          "t.anim:3:12: unknown linearUnit 'furlong'; use one of mm, cm, "
          "m, km, in, ft, yd, mi");
    CHECK(errorOf(header(curve + "    1 0 bouncy auto 1 1 0;\n  }\n}\n")) ==
          "t.anim:7:9: unknown tangent type 'bouncy'; use one of spline, linear, flat, step, stepnext, clamped, "
          "plateau, auto");
    CHECK(errorOf(header(curve + "    1 0 fixed fixed 1 1 0 0 1 0 1;\n  }\n}\n")) ==
          "t.anim:7:9: tangent type 'fixed' (explicit angles) is not read; give these keys another tangent type in "
          "Maya (auto, spline, ...) and export again");
    CHECK(errorOf(header(curve + "    1 0 auto auto 1 1 0;\n    2 5 auto")) ==
          "t.anim:8:13: the file ends inside the '2' line (line 8); the file is truncated: export it again");
    CHECK(errorOf(header(curve + "    1 0 auto auto 1 1 0;\n")) ==
          "t.anim:8:1: the file ends inside the keys of a.rotateX (line 6); the file is truncated: export it again");
    CHECK(errorOf(header(curve + "    1 0 auto auto 1 1 0;\n  }\n")) ==
          "t.anim:9:1: the file ends inside the animData block of a.rotateX (line 4); the file is truncated: export "
          "it again");
    CHECK(errorOf(header(curve + "    2 0 auto auto 1 1 0;\n    2 1 auto auto 1 1 0;\n  }\n}\n")) ==
          "t.anim:8:5: key time 2 is not after the previous key's 2; keys are in increasing time");
    CHECK(errorOf(header(curve + "    1 nan auto auto 1 1 0;\n  }\n}\n")) ==
          "t.anim:7:7: key value 'nan' is not a finite number");
    CHECK(errorOf(header(curve + "    1 0 auto auto 2 1 0;\n  }\n}\n")) ==
          "t.anim:7:19: '2': the locks and the breakdown flag are 0 or 1");
    CHECK(errorOf(header("anim rotate.rotateX rotateX a 0 0 0;\nanimData {\n  weighted 1;\n")) ==
          "t.anim:5:12: weighted tangents are not read; make the curve's tangents non-weighted in Maya and export "
          "again");
    CHECK(errorOf(header("anim rotate.rotateX rotateX a 0 0 0;\nanimData {\n  output angular;\n}\n")) ==
          "t.anim:4:1: the animData of a.rotateX has no key");
    CHECK(errorOf(header("animData {\n}\n")) ==
          "t.anim:3:1: animData without an anim line naming its plug before it; write 'anim ATTRIBUTE LEAF NODE "
          "...;' first");
    const std::string keyed = curve + "    1 0 auto auto 1 1 0;\n  }\n}\n";
    CHECK(errorOf(header(keyed + keyed)) ==
          "t.anim:10:1: a second curve for a.rotateX (the first is at line 3); keep "
          "one");
}

TEST_CASE("anim file: keys that overflow in cm or degrees, or whose curve overflows, are refused where they are")
{
    const auto curve = [](const char* output, const std::string& keys) {
        return fmt::format("anim rotate.rotateX rotateX a 0 0 0;\nanimData {{\n  output {};\n  keys {{\n{}  }}\n}}\n",
                           output, keys);
    };
    const std::string units = "angularUnit rad;\nlinearUnit km;\n";
    // Radians to degrees and km to cm multiply past the largest double.
    CHECK(errorOf(header(units + curve("angular", "    1 1e307 auto auto 1 1 0;\n"))) ==
          "t.anim:9:7: key value '1e307' overflows in degrees (the file's unit makes it more than a double holds, "
          "about 1.8e308); check the value and the unit");
    CHECK(errorOf(header(units + curve("linear", "    1 0 auto auto;\n    2 -1e305 auto auto;\n"))) ==
          "t.anim:10:7: key value '-1e305' overflows in cm (the file's unit makes it more than a double holds, about "
          "1.8e308); check the value and the unit");
    // Finite keys a frame apart whose slope or cubic is infinite: the curve would play NaN.
    CHECK(errorOf(header(curve("angular",
                               "    0 0 step step;\n    2 1.7e308 linear linear;\n    3 -1.7e308 "
                               "linear linear;\n"))) ==
          "t.anim:8:5: a.rotateX: the curve overflows at this key (x 2, y 1.7e+308): a tangent's slope is not a "
          "finite number; bring the keys' values nearer each other or the keys further apart");
    CHECK(errorOf(header(curve("unitless", "    -1.7e308 0 flat flat;\n    1.7e308 1 flat flat;\n"))) ==
          "t.anim:7:5: a.rotateX: the curve overflows at this key (x -1.7e+308, y 0): the cubic to the next key is "
          "not a finite number; bring the keys' values nearer each other or the keys further apart");
    CHECK(errorOf(header(curve("unitless", "    1 1.7e400 auto auto;\n"))) ==
          "t.anim:7:7: key value '1.7e400' is not a finite number");
    // Huge keys that make a finite curve are read as they are.
    const AnimFile huge = parseAnimFile(header(curve("unitless",
                                                     "    1 1.7e308 step step;\n    2 -1.7e308 step "
                                                     "step;\n")),
                                        "t.anim");
    REQUIRE(huge.curves.size() == 1);
    CHECK(huge.curves[0].keys[1].y == -1.7e308);
}

TEST_CASE("anim file: 80,000 curves are read in linear time, and a check stops the reading at the first curve")
{
    // 7 MB, as an exported crowd gives: the duplicate check searched the curves read for each new one (113 s).
    constexpr int count = 80000;
    std::string text = header("timeUnit film;\n");
    for (int i = 0; i < count; ++i)
        text += fmt::format(
            "anim rotate.rotateX rotateX joint{} 0 0 0;\nanimData {{\n  output angular;\n  keys {{\n"
            "    1 {} auto auto 1 1 0;\n    24 0 auto auto 1 1 0;\n  }}\n}}\n",
            i, i % 360);
    const AnimFile file = parseAnimFile(text, "crowd.anim");
    REQUIRE(file.curves.size() == count);
    CHECK(file.curves.back().plugName() == "joint79999.rotateX");
    CHECK(file.curves.back().keys[0].y == 79999 % 360);
    CHECK(file.curves.back().mark.line == 4 + 8 * (count - 1));
    // A second curve for a plug is still found, with the first one's line.
    CHECK(errorOf(text + "anim rotate.rotateX rotateX joint40000 0 0 0;\n") ==
          fmt::format("t.anim:{}:1: a second curve for joint40000.rotateX (the first is at line {}); keep one",
                      4 + 8 * count, 4 + 8 * 40000));
    // A caller's check throws on the first curve, before the rest (here a broken end) is read.
    int checked = 0;
    try {
        parseAnimFile(text + "garbage", "crowd.anim", [&](const AnimFileCurve& c) {
            ++checked;
            throw Error(fmt::format("{}: no plug {}", formatMark(c.mark), c.plugName()));
        });
        FAIL("no error");
    }
    catch (const Error& e) {
        CHECK(std::string(e.what()) == "crowd.anim:4:1: no plug joint0.rotateX");
    }
    CHECK(checked == 1);
}

TEST_CASE("anim file: an animCurve node plays a file's curve as it plays the same keys")
{
    const auto dir = test::scratchDir("anim_file_node");
    test::writeFile(dir / "arm.anim", header("anim rotate.rotateZ rotateZ shoulder 0 0 0;\nanimData {\n  input time;\n"
                                             "  output angular;\n  postInfinity linear;\n  keys {\n"
                                             "    1 -20 spline spline 1 1 0;\n    8 35 auto linear 1 1 0;\n"
                                             "    24 10 clamped clamped 1 1 0;\n  }\n}\n"));
    const auto rig =
        test::writeFile(dir / "rig.yaml",
                        "nodes:\n"
                        "  - {name: fromFile, type: animCurveTA, animFile: arm.anim, animPlug: shoulder.rotateZ}\n"
                        "  - {name: fromKeys, type: animCurveTA, postInfinity: linear,\n"
                        "     keys: [[1, -20, spline], [8, 35, auto, linear], [24, 10, clamped]]}\n"
                        "  - {name: wrongKind, type: animCurveTL, animFile: arm.anim, animPlug: shoulder.rotateZ}\n"
                        "  - {name: missing, type: animCurveTA, animFile: arm.anim, animPlug: elbow.rotateZ}\n");
    auto graph = loadGraphFile(rig, makeBuiltinRegistry());
    for (const double frame : {0.0, 1.0, 3.5, 8.0, 13.25, 24.0, 30.0}) {
        graph->setTime(frame);
        CHECK(std::get<double>(graph->getValue(graph->plug("fromFile.output"))) ==
              std::get<double>(graph->getValue(graph->plug("fromKeys.output"))));
    }
    const auto message = [&](const char* plug) {
        try {
            graph->getValue(graph->plug(plug));
        }
        catch (const Error& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    const std::string file = (dir / "arm.anim").string();
    CHECK(message("wrongKind.output") ==
          fmt::format("node 'wrongKind': {}:3:1: the curve of shoulder.rotateZ goes from time to angular; play it "
                      "with an animCurveTA, not an animCurveTL",
                      file));
    CHECK(message("missing.output") == fmt::format("node 'missing': {} has no curve for elbow.rotateZ (it has "
                                                   "shoulder.rotateZ); set animPlug to one of its plugs",
                                                   file));
}
