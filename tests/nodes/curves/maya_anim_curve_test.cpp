// animCurve nodes read as a Maya ASCII scene writes them: the Maya fields (".ktv", ".kit", ".kot", ".kix" ...,
// ".tan", ".pre", ".pst") applied the way the .ma loader applies them, then evaluated. The scenes here are written
// for the test; expected values are closed forms (Hermite and Bezier evaluated independently below).

#include <doctest/doctest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "core/error.h"
#include "graph/graph.h"
#include "graph/node_type.h"
#include "nodes/anim_curve_math.h"
#include "nodes/builtin_nodes.h"
#include "test_support.h"

namespace {

constexpr double pi = std::numbers::pi;

// One curve node and the setAttr statements of a scene, applied through its type's Maya fields.
struct MayaCurve {
    explicit MayaCurve(const char* type) : g(rig::makeBuiltinRegistry()), node(g.addNode(type, "c")), type(type) {}

    // setAttr ".attr[first:last]" words...; first = last = -1 without an element range.
    void setAttr(const std::string& attr, int first, int last, std::vector<std::string> words)
    {
        const auto& fields = g.nodeType(node).mayaFields();
        const auto field = fields.find(attr);
        REQUIRE(field != fields.end());
        rig::MayaFieldInput in;
        in.first = first;
        in.last = last;
        in.words = std::move(words);
        in.current = [this](rig::AttrId a) { return g.getValue(rig::Plug{node, a}); };
        in.linearToCm = linearToCm;
        in.angleToDegrees = angleToDegrees;
        for (const auto& [a, value] : field->second(in)) g.setValue(rig::Plug{node, a}, value);
    }

    double at(double x)
    {
        if (type[9] == 'T') g.setTime(x);
        else g.setValue(g.plug("c.input"), x);
        return std::get<double>(g.getValue(g.plug("c.output")));
    }

    std::vector<double> array(const std::string& attr)
    {
        return std::get<std::vector<double>>(g.getValue(g.plug("c." + attr)));
    }

    rig::Graph g;
    rig::NodeId node;
    std::string type;
    double linearToCm = 1.0;
    double angleToDegrees = 1.0;
};

// The cubic Hermite interpolant on [x0, x1] with end slopes m0, m1.
double hermite(double x0, double y0, double m0, double x1, double y1, double m1, double x)
{
    const double w = x1 - x0;
    const double t = (x - x0) / w;
    const double t2 = t * t, t3 = t2 * t;
    return (2 * t3 - 3 * t2 + 1) * y0 + (t3 - 2 * t2 + t) * w * m0 + (-2 * t3 + 3 * t2) * y1 + (t3 - t2) * w * m1;
}

struct Point {
    double x, y;
};

// The cubic Bezier P0..P3 at abscissa x, t found by bisection on its (non-decreasing) x(t).
double bezierAt(Point p0, Point p1, Point p2, Point p3, double x)
{
    const auto coordinate = [](double a, double b, double c, double d, double t) {
        const double s = 1 - t;
        return s * s * s * a + 3 * s * s * t * b + 3 * s * t * t * c + t * t * t * d;
    };
    double lo = 0, hi = 1;
    for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (lo + hi);
        (coordinate(p0.x, p1.x, p2.x, p3.x, mid) < x ? lo : hi) = mid;
    }
    return coordinate(p0.y, p1.y, p2.y, p3.y, 0.5 * (lo + hi));
}

}  // namespace

TEST_CASE("maya curves: .ktv ranges split over two setAttr statements make one curve")
{
    MayaCurve c("animCurveTL");
    c.setAttr("tan", -1, -1, {"2"});
    c.setAttr("ktv", 0, 1, {"0", "0", "10", "5"});
    c.setAttr("ktv", 2, 3, {"20", "5", "30", "-5"});
    // A setAttr of flags only (-l on ".ktv[0]") changes nothing.
    c.setAttr("ktv", 0, 0, {});
    CHECK(c.array("keyTime") == std::vector<double>{0, 10, 20, 30});
    CHECK(c.array("keyValue") == std::vector<double>{0, 5, 5, -5});
    // Linear tangents: each segment is its chord.
    CHECK(c.at(2.5) == doctest::Approx(1.25).epsilon(1e-14));
    CHECK(c.at(15) == doctest::Approx(5).epsilon(1e-14));
    CHECK(c.at(27.5) == doctest::Approx(-2.5).epsilon(1e-14));
    // A later statement replaces the keys it names.
    c.setAttr("keyTimeValue", 1, 1, {"10", "7"});
    CHECK(c.array("keyValue") == std::vector<double>{0, 7, 5, -5});
}

TEST_CASE("maya curves: key values in the scene's units become cm and radians")
{
    MayaCurve metres("animCurveTL");
    metres.linearToCm = 100.0;  // currentUnit -l meter
    metres.setAttr("tan", -1, -1, {"2"});
    metres.setAttr("ktv", 0, 1, {"0", "0", "10", "1.5"});
    CHECK(metres.at(5) == doctest::Approx(75.0).epsilon(1e-14));

    MayaCurve degrees("animCurveTA");
    degrees.setAttr("tan", -1, -1, {"2"});
    degrees.setAttr("ktv", 0, 1, {"0", "0", "10", "90"});
    CHECK(degrees.at(5) == doctest::Approx(pi / 4).epsilon(1e-14));

    MayaCurve radians("animCurveUA");
    radians.angleToDegrees = 180.0 / pi;  // currentUnit -a radian
    radians.setAttr("tan", -1, -1, {"2"});
    radians.setAttr("ktv", 0, 1, {"0", "0", "1", "0.5"});
    CHECK(radians.at(1) == doctest::Approx(0.5).epsilon(1e-14));
    // Set-driven keys: x is the driver's value, as written.
    CHECK(radians.array("keyTime") == std::vector<double>{0, 1});
}

TEST_CASE("maya curves: tangent type codes against the slope formulas")
{
    // Keys (0, 0), (10, 1), (20, 40): secants 0.1 and 3.9; key 1's spline slope (40 - 0) / 20 = 2, auto's
    // limit 3 * min(0.1, 3.9) = 0.3. At x = 15 (segment 1) each type is the Hermite cubic with its slopes.
    const auto curve = [](const std::string& code) {
        auto c = std::make_unique<MayaCurve>("animCurveUU");
        c->setAttr("tan", -1, -1, {code});
        c->setAttr("ktv", 0, 2, {"0", "0", "10", "1", "20", "40"});
        return c;
    };
    // spline (9): interior 2, end key the secant 3.9.
    CHECK(curve("9")->at(15) == doctest::Approx(hermite(10, 1, 2.0, 20, 40, 3.9, 15)).epsilon(1e-13));
    // clamped (10): monotone interior keeps the spline slope; the end key too.
    CHECK(curve("10")->at(15) == doctest::Approx(hermite(10, 1, 2.0, 20, 40, 3.9, 15)).epsilon(1e-13));
    // auto (18): 2 limited to 0.3; end keys flat.
    CHECK(curve("18")->at(15) == doctest::Approx(hermite(10, 1, 0.3, 20, 40, 0.0, 15)).epsilon(1e-13));
    // plateau (16): 2 exceeds the limit 0.3, so 0; end keys flat.
    CHECK(curve("16")->at(15) == doctest::Approx(hermite(10, 1, 0.0, 20, 40, 0.0, 15)).epsilon(1e-13));
    // flat (3): smoothstep between the keys.
    CHECK(curve("3")->at(15) == doctest::Approx(1 + 39 * 0.5).epsilon(1e-13));
    // step (5) holds the left key; stepnext (17) takes the right one.
    CHECK(curve("5")->at(19.5) == 1.0);
    CHECK(curve("5")->at(20) == 40.0);
    CHECK(curve("17")->at(10.5) == 40.0);

    // Per-key types (.kit/.kot) override .tan: key 1 linear on both sides, the rest auto.
    auto mixed = curve("18");
    mixed->setAttr("kit", 1, 1, {"2"});
    mixed->setAttr("kot", 1, 1, {"2"});
    CHECK(mixed->array("keyInTangent") == std::vector<double>{-1, 0});
    CHECK(mixed->at(15) == doctest::Approx(hermite(10, 1, 3.9, 20, 40, 0.0, 15)).epsilon(1e-13));
    CHECK(mixed->at(5) == doctest::Approx(hermite(0, 0, 0.0, 10, 1, 0.1, 5)).epsilon(1e-13));
}

TEST_CASE("maya curves: fixed tangents from .kix/.kiy/.kox/.koy, x in seconds, y in internal units")
{
    MayaCurve c("animCurveTL");
    c.setAttr("tan", -1, -1, {"18"});
    c.setAttr("ktv", 0, 1, {"0", "0", "10", "0"});
    c.setAttr("kit", 0, 1, {"1", "1"});
    c.setAttr("kot", 0, 1, {"1", "1"});
    // Key 0 leaves at 1 cm per 0.5 s = 2 cm/s, 1/12 cm a frame at 24 fps; key 1 arrives at -3 cm/s, -1/8 a frame.
    c.setAttr("kox", 0, 0, {"0.5"});
    c.setAttr("koy", 0, 0, {"1"});
    c.setAttr("kix", 1, 1, {"1"});
    c.setAttr("kiy", 1, 1, {"-3"});
    for (double x : {2.5, 3.0, 7.5})
        CHECK(c.at(x) == doctest::Approx(hermite(0, 0, 2.0 / 24, 10, 0, -3.0 / 24, x)).epsilon(1e-13));
    // At 30 fps a second is 30 frames.
    c.g.setValue(c.g.plug("c.framesPerSecond"), 30.0);
    CHECK(c.at(3.0) == doctest::Approx(hermite(0, 0, 2.0 / 30, 10, 0, -3.0 / 30, 3.0)).epsilon(1e-13));

    // A key whose type is computed ignores the vector Maya also writes for it (auto keys keep a stale one).
    c.setAttr("kit", 1, 1, {"18"});
    c.setAttr("kix", 1, 1, {"1"});
    c.setAttr("kiy", 1, 1, {"5"});
    // Four numbers a key (in x, in y, out x, out y): key 0's in-tangent keeps the placeholder its fixed type gave.
    CHECK(c.array("keyTangentVectors") == std::vector<double>{1, 0, 0.5, 1, 0, 0, 1, 0});
    CHECK(c.at(3.0) == doctest::Approx(hermite(0, 0, 2.0 / 30, 10, 0, 0.0, 3.0)).epsilon(1e-13));

    // An angular curve's tangent y is in radians: 0.5 rad/s is 0.5 / 24 rad a frame.
    MayaCurve a("animCurveTA");
    a.setAttr("tan", -1, -1, {"1"});  // the curve's keys default to fixed
    a.setAttr("ktv", 0, 1, {"0", "0", "24", "0"});
    a.setAttr("kox", 0, 0, {"1"});
    a.setAttr("koy", 0, 0, {"0.5"});
    // Key 1 has no vector: fixed without one is flat.
    CHECK(a.at(6) == doctest::Approx(hermite(0, 0, 0.5 / 24, 24, 0, 0, 6)).epsilon(1e-13));
}

TEST_CASE("maya curves: weighted fixed tangents make a Bezier in x and y")
{
    MayaCurve c("animCurveTU");
    c.setAttr("tan", -1, -1, {"18"});
    c.g.setValue(c.g.plug("c.weightedTangents"), true);
    c.setAttr("ktv", 0, 1, {"0", "0", "12", "6"});
    c.setAttr("kot", 0, 0, {"1"});
    c.setAttr("kit", 1, 1, {"1"});
    // Out of key 0: (0.25 s, 6) = (6 frames, 6); into key 1: (0.125 s, 0) = (3 frames, 0). Control points at a
    // third of each: P1 = (2, 2), P2 = (11, 6).
    c.setAttr("kox", 0, 0, {"0.25"});
    c.setAttr("koy", 0, 0, {"6"});
    c.setAttr("kix", 1, 1, {"0.125"});
    c.setAttr("kiy", 1, 1, {"0"});
    for (double x : {0.5, 1.0, 3.0, 6.0, 9.0, 11.5})
        CHECK(c.at(x) == doctest::Approx(bezierAt({0, 0}, {2, 2}, {11, 6}, {12, 6}, x)).epsilon(1e-10));

    // The same tangents unweighted: only their directions count (slopes 1 and 0).
    c.g.setValue(c.g.plug("c.weightedTangents"), false);
    CHECK(c.at(3.0) == doctest::Approx(hermite(0, 0, 1.0, 12, 6, 0.0, 3.0)).epsilon(1e-13));

    // A tangent longer than its segment: key 0 leaves with (2.5 s, 30) = (60 frames, 30), its control point
    // 60/3 = 20 frames out, 5/3 of the width; Maya's rule moves it to 4/3 (x 16, y 10 * 16/20 = 8) and key 1's
    // (linear: (12, 6), control (8, 4)) to 2/3 of the width, where it already is.
    c.g.setValue(c.g.plug("c.weightedTangents"), true);
    c.setAttr("kox", 0, 0, {"2.5"});
    c.setAttr("koy", 0, 0, {"30"});
    c.setAttr("kit", 1, 1, {"2"});
    for (double x : {1.0, 4.0, 8.0, 11.0})
        CHECK(c.at(x) == doctest::Approx(bezierAt({0, 0}, {16, 8}, {8, 4}, {12, 6}, x)).epsilon(1e-9));
}

TEST_CASE("maya curves: weighted curves without fixed tangents evaluate as unweighted ones")
{
    std::vector<rig::AnimKey> keys{{0, 0, rig::TangentType::auto_, rig::TangentType::auto_},
                                   {10, 1, rig::TangentType::spline, rig::TangentType::spline},
                                   {20, 40, rig::TangentType::clamped, rig::TangentType::clamped}};
    const auto plain = rig::AnimCurve::build(keys);
    const auto weighted = rig::AnimCurve::build(keys, rig::Infinity::constant, rig::Infinity::constant, true);
    for (double x = -1; x <= 21; x += 0.37) CHECK(plain.evaluate(x) == weighted.evaluate(x));
}

TEST_CASE("maya curves: infinity codes .pre/.pst")
{
    MayaCurve c("animCurveTU");
    c.setAttr("tan", -1, -1, {"2"});
    c.setAttr("ktv", 0, 1, {"0", "0", "10", "1"});
    c.setAttr("pre", -1, -1, {"4"});  // cycleRelative
    c.setAttr("pst", -1, -1, {"1"});  // linear
    CHECK(c.at(-2.5) == doctest::Approx(-0.25).epsilon(1e-14));
    CHECK(c.at(15) == doctest::Approx(1.5).epsilon(1e-14));
    c.setAttr("postInfinity", -1, -1, {"5"});  // oscillate
    CHECK(c.at(12.5) == doctest::Approx(0.75).epsilon(1e-14));
    c.setAttr("pst", -1, -1, {"3"});  // cycle
    CHECK(c.at(12.5) == doctest::Approx(0.25).epsilon(1e-14));
    c.setAttr("pst", -1, -1, {"0"});  // constant
    CHECK(c.at(12.5) == 1.0);
    CHECK(rig::test::errorOf([&] { c.setAttr("pre", -1, -1, {"2"}); }).find(".pre: 2 is not one of Maya's infinity") ==
          0);
}

TEST_CASE("maya curves: what the fields refuse, and Maya's short names")
{
    MayaCurve c("animCurveTA");
    using rig::test::errorOf;
    CHECK(errorOf([&] { c.setAttr("kit", 0, 0, {"6"}); }) ==
          ".kit: tangent type 6 (slow) is not evaluated by this reader; set the keys' tangents to fixed, linear, "
          "flat, step, stepnext, spline, clamped, plateau or auto in Maya");
    CHECK(errorOf([&] { c.setAttr("tan", -1, -1, {"28"}); }).find("28 (autoEase)") != std::string::npos);
    CHECK(errorOf([&] { c.setAttr("kot", 0, 0, {"4"}); }) == ".kot: 4 is not one of Maya's tangent type codes");
    CHECK(errorOf([&] { c.setAttr("ktv", 0, 1, {"0", "1", "2"}); }) == ".ktv[0:1]: 3 values for 2 keys; give 2 a key");
    CHECK(errorOf([&] { c.setAttr("ktv", 0, 0, {"0", "abc"}); }) == ".ktv: 'abc' is not a finite number");
    CHECK(errorOf([&] { c.setAttr("ktv", -1, -1, {"0", "1"}); }) == ".ktv: give the keys' element range (.ktv[0:2])");

    const rig::NodeType& type = c.g.nodeType(c.node);
    CHECK(type.findMayaAttribute("i") == type.findAttribute("input"));
    CHECK(type.findMayaAttribute("o") == type.findAttribute("output"));
    CHECK(type.findMayaAttribute("wgt") == type.findAttribute("weightedTangents"));
    // Editing state is read and dropped.
    c.setAttr("ktl", 0, 2, {"no", "yes", "no"});
    c.setAttr("kwl", 0, 0, {"yes"});

    rig::Graph g(rig::makeBuiltinRegistry());
    const rig::NodeId time = g.addNode("time", "time1");
    CHECK(g.nodeType(time).findMayaAttribute("o") == g.nodeType(time).findAttribute("outTime"));
    CHECK(g.nodeType(time).mayaFields().count("unw") == 1);
}
