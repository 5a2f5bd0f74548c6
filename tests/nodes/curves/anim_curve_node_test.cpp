// animCurve nodes through a Graph: scene time and time-node drivers, keys in the file's units, per-key
// tangents, infinity by name, the `keys:` sugar's error messages, evaluation errors for keys set
// directly, and a set-driven key chain into a joint. Expected values are worked out by hand.

#include <doctest/doctest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/error.h"
#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "test_support.h"

namespace {

constexpr double pi = std::numbers::pi;
constexpr double tolerance = 1e-12;

double deg(double degrees) { return degrees * pi / 180.0; }

std::unique_ptr<rig::Graph> load(const std::string& text)
{
    return rig::loadGraphText(text, "t.yaml", rig::makeBuiltinRegistry());
}

std::string loadError(const std::string& text)
{
    try {
        load(text);
    }
    catch (const rig::Error& e) {
        return e.what();
    }
    return "(no error)";
}

using rig::test::errorOf;

double num(rig::Graph& g, const std::string& path) { return std::get<double>(g.getValue(g.plug(path))); }

void set(rig::Graph& g, const std::string& path, const rig::Value& value) { g.setValue(g.plug(path), value); }

std::vector<double> array(rig::Graph& g, const std::string& path)
{
    return std::get<std::vector<double>>(g.getValue(g.plug(path)));
}

bool near(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double tol = tolerance)
{
    return a.rows() == b.rows() && a.cols() == b.cols() && (a - b).cwiseAbs().maxCoeff() <= tol;
}

Eigen::Matrix4d rz(double a)
{
    const double c = std::cos(a), s = std::sin(a);
    Eigen::Matrix4d m;
    m << c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1;
    return m;
}

Eigen::Matrix4d translation(double x, double y, double z)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m(0, 3) = x;
    m(1, 3) = y;
    m(2, 3) = z;
    return m;
}

}  // namespace

TEST_CASE("anim curve nodes: animCurveTU follows the scene time when input is unconnected")
{
    auto g = load(R"(
nodes:
  - {name: c, type: animCurveTU, keys: [[0, 0], [10, 1]], tangents: linear}
)");
    CHECK(num(*g, "c.output") == 0.0);  // time 0
    g->setTime(2.5);
    CHECK(g->time() == 2.5);
    CHECK(num(*g, "c.input") == 2.5);
    CHECK(num(*g, "c.output") == doctest::Approx(0.25).epsilon(1e-14));
    g->setTime(7.0);
    CHECK(num(*g, "c.output") == doctest::Approx(0.7).epsilon(1e-14));
    g->setTime(25.0);  // constant post-infinity holds the last key
    CHECK(num(*g, "c.output") == 1.0);
    g->setTime(-3.0);
    CHECK(num(*g, "c.output") == 0.0);
    // input is a plain input too: setting it moves this curve only until the next setTime.
    set(*g, "c.input", 5.0);
    CHECK(num(*g, "c.output") == doctest::Approx(0.5).epsilon(1e-14));
    g->setTime(1.0);
    CHECK(num(*g, "c.output") == doctest::Approx(0.1).epsilon(1e-14));
}

TEST_CASE("anim curve nodes: animCurveTU driven by a time node")
{
    auto g = load(R"(
nodes:
  - {name: time1, type: time}
  - {name: c, type: animCurveTU, keys: [[0, 0], [10, 1]], tangents: linear}
  - {name: t, type: animCurveTL, keys: [[0, 0], [10, 5]], tangents: linear}
  - {name: j, type: joint}
connections:
  - time1.outTime -> c.input
  - time1.outTime -> t.input
  - t.output -> j.translateX
)");
    g->setTime(4.0);
    CHECK(num(*g, "time1.outTime") == 4.0);
    CHECK(num(*g, "c.output") == doctest::Approx(0.4).epsilon(1e-14));
    // A distance curve: keys in cm, straight into a translate.
    CHECK(num(*g, "j.translateX") == doctest::Approx(2.0).epsilon(1e-14));
    // The curve follows the time node, not the scene time: setting time1.time moves it.
    set(*g, "time1.time", 7.5);
    CHECK(g->time() == 4.0);
    CHECK(num(*g, "c.output") == doctest::Approx(0.75).epsilon(1e-14));
    g->setTime(2.0);
    CHECK(num(*g, "c.output") == doctest::Approx(0.2).epsilon(1e-14));
    // A connected input is not set by setTime and cannot be set by hand.
    CHECK(errorOf([&] { set(*g, "c.input", 1.0); }) ==
          "cannot set c.input: it is driven by time1.outTime; disconnect it first");
}

TEST_CASE("anim curve nodes: animCurveUA keys are degrees in the file and radians inside")
{
    auto g = load(R"(
nodes:
  - {name: a, type: animCurveUA, keys: [[0, 0], [10, 90]], tangents: linear, input: 5}
  - {name: j, type: joint, translate: [1, 2, 3]}
  - {name: md, type: multiplyDivide}
connections:
  - a.output -> j.rotateZ
  - a.output -> md.input1X
)");
    // x is unitless and stays as written; y is an angle, stored in radians.
    CHECK(array(*g, "a.keyTime") == std::vector<double>{0.0, 10.0});
    const auto values = array(*g, "a.keyValue");
    REQUIRE(values.size() == 2);
    CHECK(values[0] == 0.0);
    CHECK(values[1] == doctest::Approx(pi / 2).epsilon(1e-15));
    CHECK(num(*g, "a.output") == doctest::Approx(pi / 4).epsilon(1e-14));
    // Angle to angle: no conversion, rotateZ is 45 degrees.
    CHECK(num(*g, "j.rotateZ") == doctest::Approx(pi / 4).epsilon(1e-14));
    CHECK(near(std::get<Eigen::Matrix4d>(g->getValue(g->plug("j.worldMatrix"))), translation(1, 2, 3) * rz(pi / 4)));
    // Angle to unitless: degrees, as Maya's unitConversion.
    CHECK(num(*g, "md.outputX") == doctest::Approx(45.0).epsilon(1e-14));

    set(*g, "a.input", 10.0);
    CHECK(num(*g, "j.rotateZ") == doctest::Approx(pi / 2).epsilon(1e-14));
    set(*g, "a.input", 2.0);
    CHECK(num(*g, "md.outputX") == doctest::Approx(18.0).epsilon(1e-14));
}

TEST_CASE("anim curve nodes: per-key tangents from keys: [[0, 0, linear], [10, 1, flat, spline]]")
{
    auto g = load(R"(
nodes:
  - {name: c, type: animCurveUU, keys: [[0, 0, linear], [10, 1, flat, spline]], preInfinity: linear,
     postInfinity: linear}
  - {name: d, type: animCurveUU, keys: [[0, 0, step], [10, 1], [20, 0]], tangents: linear}
)");
    // [x, y, t] sets both tangents; [x, y, in, out] each; [x, y] leaves -1 (the `tangents` type).
    // Indices: linear 0, flat 1, step 2, spline 4.
    CHECK(array(*g, "c.keyInTangent") == std::vector<double>{0, 1});
    CHECK(array(*g, "c.keyOutTangent") == std::vector<double>{0, 4});
    CHECK(array(*g, "d.keyInTangent") == std::vector<double>{2, -1, -1});
    CHECK(array(*g, "d.keyOutTangent") == std::vector<double>{2, -1, -1});

    // Segment 0: out-slope of key 0 is linear, the secant 0.1; in-slope of key 1 is flat, 0. Hermite on
    // t = x / 10 with m0 = 0.1 * 10 = 1, m1 = 0: y = (t^3 - 2t^2 + t) + (3t^2 - 2t^3) = t + t^2 - t^3.
    auto hermite = [](double t) { return t + t * t - t * t * t; };
    for (double x : {2.5, 5.0, 7.5}) {
        CAPTURE(x);
        set(*g, "c.input", x);
        CHECK(num(*g, "c.output") == doctest::Approx(hermite(x / 10)).epsilon(1e-14));
    }
    set(*g, "c.input", 5.0);
    CHECK(num(*g, "c.output") == doctest::Approx(0.625).epsilon(1e-14));
    // Linear infinity: before, key 0's in-slope (linear at an end key: the secant, 0.1); after, key
    // 1's out-slope (spline at an end key: the secant, 0.1).
    set(*g, "c.input", -10.0);
    CHECK(num(*g, "c.output") == doctest::Approx(-1.0).epsilon(1e-14));
    set(*g, "c.input", 20.0);
    CHECK(num(*g, "c.output") == doctest::Approx(2.0).epsilon(1e-14));

    // d: step out of key 0 holds 0 up to x = 10; then linear (the fallback) from 1 down to 0.
    set(*g, "d.input", 9.75);
    CHECK(num(*g, "d.output") == 0.0);
    set(*g, "d.input", 10.0);
    CHECK(num(*g, "d.output") == 1.0);
    set(*g, "d.input", 12.5);
    CHECK(num(*g, "d.output") == doctest::Approx(0.75).epsilon(1e-14));
    // Changing the fallback changes only the keys without a tangent: flat gives smoothstep,
    // 1 - (3t^2 - 2t^3) at t = 1/4 = 0.84375.
    set(*g, "d.tangents", 1);
    CHECK(num(*g, "d.output") == doctest::Approx(0.84375).epsilon(1e-14));
    set(*g, "d.input", 5.0);
    CHECK(num(*g, "d.output") == 0.0);
}

TEST_CASE("anim curve nodes: pre and post infinity by name")
{
    auto g = load(R"(
nodes:
  - {name: c, type: animCurveUU, keys: [[0, 0], [10, 1]], tangents: linear, preInfinity: cycle, postInfinity: oscillate}
  - {name: d, type: animCurveUU, keys: [[0, 0], [10, 1]], tangents: linear, preInfinity: cycleRelative,
     postInfinity: linear}
  - {name: e, type: animCurveUU, keys: [[0, 0], [10, 1]], tangents: linear, preInfinity: constant, postInfinity: 3}
)");
    CHECK(std::get<int>(g->getValue(g->plug("c.preInfinity"))) == 2);
    CHECK(std::get<int>(g->getValue(g->plug("c.postInfinity"))) == 4);
    CHECK(std::get<int>(g->getValue(g->plug("d.preInfinity"))) == 3);
    CHECK(std::get<int>(g->getValue(g->plug("d.postInfinity"))) == 1);
    CHECK(std::get<int>(g->getValue(g->plug("e.postInfinity"))) == 3);

    auto at = [&](const char* node, double x) {
        set(*g, std::string(node) + ".input", x);
        return num(*g, std::string(node) + ".output");
    };
    // cycle: -2.5 is 7.5 one period back.
    CHECK(at("c", -2.5) == doctest::Approx(0.75).epsilon(1e-14));
    CHECK(at("c", -17.5) == doctest::Approx(0.25).epsilon(1e-14));
    // oscillate: 12.5 is the mirrored pass (10 - 2.5), 22.5 a forward pass again (2.5).
    CHECK(at("c", 12.5) == doctest::Approx(0.75).epsilon(1e-14));
    CHECK(at("c", 22.5) == doctest::Approx(0.25).epsilon(1e-14));
    // cycleRelative: one period back is shifted down by y[last] - y[first] = 1.
    CHECK(at("d", -2.5) == doctest::Approx(-0.25).epsilon(1e-14));
    CHECK(at("d", -12.5) == doctest::Approx(-1.25).epsilon(1e-14));
    // linear: the end slope 0.1 continues.
    CHECK(at("d", 15.0) == doctest::Approx(1.5).epsilon(1e-14));
    // constant holds the first key; cycleRelative (given as index 3) shifts up by 1 per period.
    CHECK(at("e", -5.0) == 0.0);
    CHECK(at("e", 12.5) == doctest::Approx(1.25).epsilon(1e-14));
    CHECK(at("e", 27.5) == doctest::Approx(2.75).epsilon(1e-14));

    CHECK(loadError("nodes:\n  - {name: s, type: animCurveUU, preInfinity: cycel}") ==
          "t.yaml:2:47: s.preInfinity: 'cycel' is not one of constant, linear, cycle, cycleRelative, oscillate; "
          "did you mean 'cycle'?");
}

TEST_CASE("anim curve nodes: keys: sugar errors")
{
    const std::string head = "nodes:\n  - {name: s, type: animCurveUU, keys: ";
    const std::string who = "node 's' (animCurveUU)";
    // Columns count from the line's start; head's second line is 39 characters long.
    CHECK(loadError(head + "[[10, 0], [5, 1]]}") ==
          "t.yaml:2:51: " + who +
              ": key x 5 is not greater than the previous key's x 10 (keys must be strictly increasing)");
    CHECK(loadError(head + "[[0, 0], [0, 1]]}") ==
          "t.yaml:2:50: " + who +
              ": key x 0 is not greater than the previous key's x 0 (keys must be strictly increasing)");
    CHECK(loadError(head + "[[0, zero], [5, 1]]}") ==
          "t.yaml:2:45: " + who + ": key y must be a finite number, got 'zero'");
    CHECK(loadError(head + "[[0, 0], [abc, 1]]}") ==
          "t.yaml:2:50: " + who + ": key x must be a finite number, got 'abc'");
    CHECK(loadError(head + "[[.inf, 0]]}") == "t.yaml:2:42: " + who + ": key x must be a finite number, got '.inf'");
    CHECK(loadError(head + "[[0, ~]]}") == "t.yaml:2:45: " + who + ": key y must be a finite number, got nothing");
    CHECK(loadError(head + "[[0, [1]]]}") ==
          "t.yaml:2:45: " + who + ": key y must be a finite number, got a list of 1");
    CHECK(
        loadError(head + "[[0, 0, linear], [10, 1, flat, splin]]}") ==
        "t.yaml:2:71: " + who +
            ": unknown tangent type 'splin'; use one of linear, flat, step, stepnext, spline, clamped, plateau, auto");
    CHECK(
        loadError(head + "[[0, 0, Linear]]}") ==
        "t.yaml:2:48: " + who +
            ": unknown tangent type 'Linear'; use one of linear, flat, step, stepnext, spline, clamped, plateau, auto");
    CHECK(loadError(head + "[[0, 0, [flat]]]}") == "t.yaml:2:48: " + who +
                                                       ": unknown tangent type a list of 1; use one of linear, flat, "
                                                       "step, stepnext, spline, clamped, plateau, auto");
    const std::string shape = ": a key is [x, y], [x, y, tangent] or [x, y, inTangent, outTangent]";
    CHECK(loadError(head + "[[0, 0], [10]]}") == "t.yaml:2:49: " + who + shape);
    CHECK(loadError(head + "[[0, 0, flat, flat, flat]]}") == "t.yaml:2:41: " + who + shape);
    CHECK(loadError(head + "[0, 10]}") == "t.yaml:2:41: " + who + shape);
    CHECK(loadError(head + "{0: 1}}") ==
          "t.yaml:2:40: " + who + ": 'keys' is a list of [x, y] or [x, y, tangent] or [x, y, in, out]");
    // An empty list is a curve without keys: 0 everywhere.
    auto g = load(head + "[]}");
    CHECK(num(*g, "s.output") == 0.0);
}

TEST_CASE("anim curve nodes: keys set directly are checked at evaluation")
{
    rig::Graph g(rig::makeBuiltinRegistry());
    g.addNode("animCurveUU", "c");
    set(g, "c.keyTime", std::vector<double>{0, 1, 2});
    set(g, "c.keyValue", std::vector<double>{0, 1});
    CHECK(errorOf([&] { num(g, "c.output"); }) ==
          "node 'c': keyTime has 3 values but keyValue has 2; give one value per key");
    // Still wrong when asked again, and right once fixed.
    CHECK(errorOf([&] { num(g, "c.output"); }) ==
          "node 'c': keyTime has 3 values but keyValue has 2; give one value per key");
    set(g, "c.keyValue", std::vector<double>{0, 1, 4});
    set(g, "c.input", 1.0);
    CHECK(num(g, "c.output") == 1.0);

    set(g, "c.keyTime", std::vector<double>{0, 2, 1});
    CHECK(errorOf([&] { num(g, "c.output"); }) ==
          "node 'c': key 2: x 1 is not greater than the previous key's x 2 (keys must be strictly increasing)");
    set(g, "c.keyTime", std::vector<double>{0, 1, 2});
    set(g, "c.keyInTangent", std::vector<double>{0, 8});
    CHECK(errorOf([&] { num(g, "c.output"); }) == "node 'c': keyInTangent[1] = 8 is not a tangent type index");
    set(g, "c.keyInTangent", std::vector<double>{0.5});
    CHECK(errorOf([&] { num(g, "c.output"); }) == "node 'c': keyInTangent[0] = 0.5 is not a tangent type index");
    set(g, "c.keyInTangent", std::vector<double>{});
    set(g, "c.keyOutTangent", std::vector<double>{-2});
    CHECK(errorOf([&] { num(g, "c.output"); }) == "node 'c': keyOutTangent[0] = -2 is not a tangent type index");
    // Shorter tangent arrays fall back to `tangents` for the missing keys.
    set(g, "c.keyOutTangent", std::vector<double>{0});
    set(g, "c.tangents", 0);
    set(g, "c.input", 1.5);
    CHECK(num(g, "c.output") == doctest::Approx(2.5).epsilon(1e-14));
}

TEST_CASE("anim curve nodes: a driven key chain ctrl.attr -> animCurveUA -> joint.rotateZ")
{
    auto g = load(R"(
nodes:
  - {name: ctrl, type: transform, addAttr: [{name: bend, min: 0, max: 10}]}
  - {name: sdk, type: animCurveUA, keys: [[0, 0], [10, 90]], tangents: linear}
  - {name: twist, type: animCurveUA, keys: [[0, 0], [60, -90]], tangents: linear}
  - {name: shoulder, type: joint, translate: [0, 150, 0]}
  - {name: elbow, type: joint, parent: shoulder, translate: [30, 0, 0]}
  - {name: wrist, type: joint, parent: elbow, translate: [25, 0, 0]}
connections:
  - ctrl.bend -> sdk.input
  - sdk.output -> elbow.rotateZ
  - ctrl.rotateX -> twist.input
  - twist.output -> shoulder.rotateZ
)");
    set(*g, "ctrl.bend", 5.0);
    // elbow at (30, 150, 0) turned 45 degrees; the wrist 25 along that direction.
    CHECK(near(std::get<Eigen::Matrix4d>(g->getValue(g->plug("elbow.worldMatrix"))),
               translation(30, 150, 0) * rz(pi / 4)));
    const double h = 25 * std::sqrt(0.5);
    CHECK(near(std::get<Eigen::Matrix4d>(g->getValue(g->plug("wrist.worldMatrix"))),
               translation(30 + h, 150 + h, 0) * rz(pi / 4)));

    set(*g, "ctrl.bend", 10.0);
    CHECK(near(std::get<Eigen::Matrix4d>(g->getValue(g->plug("wrist.worldMatrix"))),
               translation(30, 175, 0) * rz(pi / 2)));

    // An angle driver reaches a U curve in degrees: rotateX 30 -> input 30 -> -45 degrees at the shoulder.
    set(*g, "ctrl.rotateX", deg(30));
    CHECK(num(*g, "twist.input") == doctest::Approx(30.0).epsilon(1e-14));
    CHECK(num(*g, "shoulder.rotateZ") == doctest::Approx(-pi / 4).epsilon(1e-14));
    // shoulder Rz(-45), elbow Rz(90): the elbow sits at 30 along (h, -h)/25, the wrist turned +45.
    const double e = 30 * std::sqrt(0.5);
    CHECK(near(std::get<Eigen::Matrix4d>(g->getValue(g->plug("elbow.worldMatrix"))),
               translation(e, 150 - e, 0) * rz(pi / 4)));
    CHECK(near(std::get<Eigen::Matrix4d>(g->getValue(g->plug("wrist.worldMatrix"))),
               translation(e + h, 150 - e + h, 0) * rz(pi / 4)));
}
