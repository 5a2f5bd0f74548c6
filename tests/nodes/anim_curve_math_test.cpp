#include "nodes/anim_curve_math.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "core/error.h"

using rig::AnimCurve;
using rig::AnimKey;
using rig::Error;
using rig::Infinity;
using rig::TangentType;

namespace {

// Slack for rounding in the cubic where a curve just touches a key value.
constexpr double tolerance = 1e-12;

// Keys at the given points, all with the same in and out tangent type.
std::vector<AnimKey> keysOf(const std::vector<std::pair<double, double>>& points, TangentType type)
{
    std::vector<AnimKey> keys;
    for (const auto& [x, y] : points) keys.push_back({x, y, type, type});
    return keys;
}

constexpr TangentType allTangentTypes[] = {
    TangentType::linear, TangentType::flat,    TangentType::step,    TangentType::stepNext,
    TangentType::spline, TangentType::clamped, TangentType::plateau, TangentType::auto_,
};

constexpr Infinity allInfinities[] = {Infinity::constant, Infinity::linear, Infinity::cycle, Infinity::cycleRelative,
                                      Infinity::oscillate};

// Smallest and largest value over [from, to] sampled every 1e-3.
std::pair<double, double> sampledRange(const AnimCurve& curve, double from, double to)
{
    double lowest = curve.evaluate(from);
    double highest = lowest;
    for (double x = from; x <= to; x += 1e-3) {
        lowest = std::min(lowest, curve.evaluate(x));
        highest = std::max(highest, curve.evaluate(x));
    }
    return {lowest, highest};
}

}  // namespace

TEST_CASE("tangent type names round-trip with Maya's spelling")
{
    for (TangentType type : allTangentTypes) {
        CHECK(rig::tangentTypeFromName(rig::tangentTypeName(type)) == type);
    }
    CHECK(rig::tangentTypeName(TangentType::stepNext) == "stepnext");
    CHECK(rig::tangentTypeName(TangentType::auto_) == "auto");
    CHECK(rig::tangentTypeFromName("clamped") == TangentType::clamped);
    CHECK_FALSE(rig::tangentTypeFromName("Linear").has_value());
    CHECK_FALSE(rig::tangentTypeFromName("fixed").has_value());
    CHECK_FALSE(rig::tangentTypeFromName("").has_value());
}

TEST_CASE("infinity names round-trip with Maya's spelling")
{
    for (Infinity mode : allInfinities) {
        CHECK(rig::infinityFromName(rig::infinityName(mode)) == mode);
    }
    CHECK(rig::infinityName(Infinity::cycleRelative) == "cycleRelative");
    CHECK(rig::infinityFromName("oscillate") == Infinity::oscillate);
    CHECK_FALSE(rig::infinityFromName("cyclerelative").has_value());
    CHECK_FALSE(rig::infinityFromName("none").has_value());
}

TEST_CASE("a curve without keys evaluates to 0")
{
    for (Infinity mode : allInfinities) {
        const AnimCurve curve = AnimCurve::build({}, mode, mode);
        for (double x : {-100.0, 0.0, 3.5}) {
            CHECK(curve.evaluate(x) == 0.0);
            CHECK(curve.derivative(x) == 0.0);
        }
    }
    const AnimCurve defaulted;
    CHECK(defaulted.evaluate(1.0) == 0.0);
    CHECK(defaulted.keys().empty());
}

TEST_CASE("a one-key curve is constant under every infinity mode")
{
    for (TangentType type : allTangentTypes) {
        for (Infinity mode : allInfinities) {
            const AnimCurve curve = AnimCurve::build(keysOf({{2.0, 7.5}}, type), mode, mode);
            for (double x : {-50.0, 1.0, 2.0, 3.0, 80.0}) {
                CHECK(curve.evaluate(x) == 7.5);
                CHECK(curve.derivative(x) == 0.0);
            }
        }
    }
}

TEST_CASE("build keeps the keys and infinity modes")
{
    const AnimCurve curve =
        AnimCurve::build(keysOf({{0.0, 1.0}, {1.0, 2.0}}, TangentType::flat), Infinity::cycle, Infinity::oscillate);
    REQUIRE(curve.keys().size() == 2);
    CHECK(curve.keys()[1].x == 1.0);
    CHECK(curve.keys()[1].y == 2.0);
    CHECK(curve.preInfinity() == Infinity::cycle);
    CHECK(curve.postInfinity() == Infinity::oscillate);
}

TEST_CASE("build rejects keys that are not strictly increasing")
{
    CHECK_THROWS_WITH_AS(
        AnimCurve::build(keysOf({{0.0, 0.0}, {5.0, 1.0}, {7.5, 2.0}, {10.0, 3.0}, {10.0, 4.0}}, TangentType::linear)),
        "key 4: x 10 is not greater than the previous key's x 10 (keys must be strictly increasing)", Error);
    CHECK_THROWS_WITH_AS(AnimCurve::build(keysOf({{0.0, 0.0}, {2.5, 1.0}, {1.0, 2.0}}, TangentType::linear)),
                         "key 2: x 1 is not greater than the previous key's x 2.5 (keys must be strictly increasing)",
                         Error);
}

TEST_CASE("build rejects non-finite keys")
{
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    CHECK_THROWS_WITH_AS(AnimCurve::build(keysOf({{0.0, 0.0}, {1.0, nan}}, TangentType::spline)),
                         "key 1: y nan is not finite (keys must have finite x and y)", Error);
    CHECK_THROWS_WITH_AS(AnimCurve::build(keysOf({{inf, 0.0}}, TangentType::spline)),
                         "key 0: x inf is not finite (keys must have finite x and y)", Error);
    CHECK_THROWS_WITH_AS(AnimCurve::build(keysOf({{0.0, 0.0}, {1.0, 1.0}, {2.0, -inf}}, TangentType::spline)),
                         "key 2: y -inf is not finite (keys must have finite x and y)", Error);
}

TEST_CASE("build rejects finite keys whose tangents or cubics overflow, and keeps huge keys that do not")
{
    const double big = 1.7e308;
    const std::string advice =
        " is not a finite number; bring the keys' values nearer each other or the keys "
        "further apart";
    // A frame apart, their slope is -3.4e308: infinite.
    CHECK_THROWS_WITH_AS(
        AnimCurve::build(keysOf({{0.0, big}, {1.0, -big}}, TangentType::linear)),
        ("key 0: the curve overflows at this key (x 0, y 1.7e+308): a tangent's slope" + advice).c_str(), Error);
    // Flat tangents keep the slopes at 0, but the cubic's coefficients are 3 times the rise.
    CHECK_THROWS_WITH_AS(
        AnimCurve::build(keysOf({{0.0, big}, {1.0, -big}}, TangentType::flat)),
        ("key 0: the curve overflows at this key (x 0, y 1.7e+308): the cubic to the next key" + advice).c_str(),
        Error);
    // Times too far apart: the segment's width is infinite.
    CHECK_THROWS_WITH_AS(
        AnimCurve::build(keysOf({{-big, 0.0}, {big, 1.0}}, TangentType::spline)),
        ("key 0: the curve overflows at this key (x -1.7e+308, y 0): the cubic to the next key" + advice).c_str(),
        Error);
    // Step keys play their values as they are, until a cyclic infinity repeats a range it cannot hold.
    const auto steps = keysOf({{0.0, big}, {1.0, -big}}, TangentType::step);
    CHECK(AnimCurve::build(steps).evaluate(0.5) == big);
    CHECK_THROWS_WITH_AS(AnimCurve::build(steps, Infinity::constant, Infinity::cycleRelative),
                         ("key 1: the curve overflows at this key (x 1, y -1.7e+308): the keyed range, which a "
                          "cyclic infinity repeats," +
                          advice)
                             .c_str(),
                         Error);
    const auto problem =
        AnimCurve::tryBuild(keysOf({{0.0, 0.0}, {1.0, 1.0}, {2.0, big}, {3.0, -big}}, TangentType::linear));
    REQUIRE(std::holds_alternative<rig::AnimKeyProblem>(problem));
    CHECK(std::get<rig::AnimKeyProblem>(problem).key == 1);
    // Equal huge values are a flat curve.
    const AnimCurve flat = AnimCurve::build(keysOf({{0.0, big}, {1.0, big}, {2.0, big}}, TangentType::spline));
    CHECK(flat.evaluate(0.5) == big);
    CHECK(flat.evaluate(1.5) == big);
}

TEST_CASE("linear tangents interpolate linearly")
{
    const AnimCurve curve = AnimCurve::build(keysOf({{0.0, 1.0}, {2.0, 5.0}, {3.0, 2.0}}, TangentType::linear));
    for (double x = 0.0; x < 2.0; x += 0.125) {
        CHECK(curve.evaluate(x) == doctest::Approx(1.0 + 2.0 * x).epsilon(1e-14));
        CHECK(curve.derivative(x) == doctest::Approx(2.0).epsilon(1e-14));
    }
    for (double x = 2.125; x < 3.0; x += 0.125) {
        CHECK(curve.evaluate(x) == doctest::Approx(5.0 - 3.0 * (x - 2.0)).epsilon(1e-14));
        CHECK(curve.derivative(x) == doctest::Approx(-3.0).epsilon(1e-14));
    }
    // End keys have no neighbour outside the range and face their only neighbour.
    CHECK(curve.inSlope(0) == doctest::Approx(2.0));
    CHECK(curve.outSlope(2) == doctest::Approx(-3.0));
}

TEST_CASE("flat tangents give the smoothstep shape")
{
    const AnimCurve curve = AnimCurve::build(keysOf({{10.0, 2.0}, {14.0, 10.0}}, TangentType::flat));
    // 3t^2 - 2t^3 is 0.15625 at t = 0.25 and 0.5 at t = 0.5.
    CHECK(curve.evaluate(11.0) == doctest::Approx(2.0 + 8.0 * 0.15625).epsilon(1e-14));
    CHECK(curve.evaluate(12.0) == doctest::Approx(6.0).epsilon(1e-14));
    CHECK(curve.evaluate(13.0) == doctest::Approx(10.0 - 8.0 * 0.15625).epsilon(1e-14));
    CHECK(curve.derivative(10.0) == 0.0);
    CHECK(curve.derivative(14.0) == doctest::Approx(0.0));
    // d/dx of 8 * smoothstep((x - 10) / 4) at t = 0.5 is 8 * 1.5 / 4.
    CHECK(curve.derivative(12.0) == doctest::Approx(3.0).epsilon(1e-14));
}

TEST_CASE("step holds the left key's value until the next key")
{
    const AnimCurve curve = AnimCurve::build(keysOf({{0.0, 1.0}, {1.0, 5.0}, {2.0, 3.0}}, TangentType::step));
    CHECK(curve.evaluate(0.0) == 1.0);
    CHECK(curve.evaluate(0.5) == 1.0);
    CHECK(curve.evaluate(0.999) == 1.0);
    CHECK(curve.evaluate(1.0) == 5.0);
    CHECK(curve.evaluate(1.75) == 5.0);
    CHECK(curve.evaluate(2.0) == 3.0);
    CHECK(curve.derivative(0.5) == 0.0);
    CHECK(curve.derivative(1.5) == 0.0);
}

TEST_CASE("the left key's out-tangent alone decides a step segment")
{
    const AnimCurve curve = AnimCurve::build(
        {{0.0, 1.0, TangentType::spline, TangentType::step}, {1.0, 5.0, TangentType::spline, TangentType::spline}});
    CHECK(curve.evaluate(0.5) == 1.0);
    CHECK(curve.evaluate(1.0) == 5.0);
}

TEST_CASE("stepNext takes the next key's value right after a key")
{
    const AnimCurve curve = AnimCurve::build(keysOf({{0.0, 1.0}, {1.0, 5.0}, {2.0, 3.0}}, TangentType::stepNext));
    CHECK(curve.evaluate(0.0) == 1.0);
    CHECK(curve.evaluate(0.001) == 5.0);
    CHECK(curve.evaluate(1.0) == 5.0);
    CHECK(curve.evaluate(1.5) == 3.0);
    CHECK(curve.evaluate(2.0) == 3.0);
    CHECK(curve.derivative(0.5) == 0.0);
}

TEST_CASE("spline through three keys matches the hand-computed Hermite cubic")
{
    const AnimCurve curve = AnimCurve::build(keysOf({{0.0, 0.0}, {1.0, 1.0}, {3.0, 4.0}}, TangentType::spline));
    // Slopes: end keys face their neighbour (1 and 1.5), the middle key is
    // Catmull-Rom (4 - 0) / (3 - 0).
    CHECK(curve.outSlope(0) == doctest::Approx(1.0));
    CHECK(curve.inSlope(1) == doctest::Approx(4.0 / 3.0));
    CHECK(curve.outSlope(1) == doctest::Approx(4.0 / 3.0));
    CHECK(curve.inSlope(2) == doctest::Approx(1.5));
    // Segment 0: y = t - t^2/3 + t^3/3, so y(0.5) = 11/24.
    CHECK(curve.evaluate(0.5) == doctest::Approx(11.0 / 24.0).epsilon(1e-14));
    // Segment 1 (width 2): y = 1 + 8t/3 + 2t^2/3 - t^3/3, so y(t = 0.5) = 59/24.
    CHECK(curve.evaluate(2.0) == doctest::Approx(59.0 / 24.0).epsilon(1e-14));
    // dy/dx at t = 0.5 is (8/3 + 2/3 - 1/4) / 2.
    CHECK(curve.derivative(2.0) == doctest::Approx((8.0 / 3.0 + 2.0 / 3.0 - 0.25) / 2.0));
    for (const AnimKey& key : curve.keys()) CHECK(curve.evaluate(key.x) == key.y);
}

TEST_CASE("two spline keys make a straight line")
{
    const AnimCurve curve = AnimCurve::build(keysOf({{0.0, 1.0}, {4.0, 3.0}}, TangentType::spline));
    CHECK(curve.evaluate(1.0) == doctest::Approx(1.5).epsilon(1e-14));
    CHECK(curve.evaluate(3.0) == doctest::Approx(2.5).epsilon(1e-14));
}

TEST_CASE("clamped, plateau and auto do not overshoot an extremum key")
{
    const auto points = std::vector<std::pair<double, double>>{{0.0, 0.0}, {1.0, 10.0}, {2.0, 8.0}};

    // Spline overshoots here, which is what the other types prevent.
    CHECK(sampledRange(AnimCurve::build(keysOf(points, TangentType::spline)), 0.0, 2.0).second > 10.1);

    for (TangentType type : {TangentType::clamped, TangentType::plateau, TangentType::auto_}) {
        CAPTURE(rig::tangentTypeName(type));
        const AnimCurve curve = AnimCurve::build(keysOf(points, type));
        CHECK(curve.inSlope(1) == 0.0);
        CHECK(curve.outSlope(1) == 0.0);
        const auto [low, high] = sampledRange(curve, 0.0, 2.0);
        CHECK(low >= -tolerance);
        CHECK(high <= 10.0 + tolerance);
        CHECK(sampledRange(curve, 1.0, 2.0).first >= 8.0 - tolerance);
    }
}

TEST_CASE("clamped is flat where a key equals its neighbour")
{
    const AnimCurve curve =
        AnimCurve::build(keysOf({{0.0, 0.0}, {1.0, 4.0}, {2.0, 4.0}, {3.0, 8.0}}, TangentType::clamped));
    CHECK(curve.outSlope(1) == 0.0);
    CHECK(curve.inSlope(2) == 0.0);
    CHECK(curve.evaluate(1.5) == doctest::Approx(4.0).epsilon(1e-14));
    // End keys keep the spline slope toward their neighbour.
    CHECK(curve.outSlope(0) == doctest::Approx(4.0));
}

TEST_CASE("slope rules at a monotone key beside a much gentler segment")
{
    // Key 1: secants 9 before and 1 after, Catmull-Rom slope 5, limit 3 * 1.
    const auto points = std::vector<std::pair<double, double>>{{0.0, 0.0}, {1.0, 9.0}, {2.0, 10.0}, {3.0, 0.0}};
    const auto slopeAtKey1 = [&](TangentType type) {
        const AnimCurve curve = AnimCurve::build(keysOf(points, type));
        CHECK(curve.inSlope(1) == curve.outSlope(1));
        return curve.outSlope(1);
    };
    CHECK(slopeAtKey1(TangentType::spline) == doctest::Approx(5.0));
    CHECK(slopeAtKey1(TangentType::clamped) == doctest::Approx(5.0));
    CHECK(slopeAtKey1(TangentType::auto_) == doctest::Approx(3.0));
    CHECK(slopeAtKey1(TangentType::plateau) == 0.0);

    for (TangentType type : {TangentType::plateau, TangentType::auto_}) {
        CAPTURE(rig::tangentTypeName(type));
        const AnimCurve curve = AnimCurve::build(keysOf(points, type));
        // Flat at the end keys, and the gentle segment stays within its keys.
        CHECK(curve.outSlope(0) == 0.0);
        CHECK(curve.inSlope(3) == 0.0);
        const auto [low, high] = sampledRange(curve, 1.0, 2.0);
        CHECK(low >= 9.0 - tolerance);
        CHECK(high <= 10.0 + tolerance);
    }
}

TEST_CASE("derivative matches central finite differences")
{
    // Integer key x values and period, so sampling at odd multiples of 0.05
    // keeps every sample and its wrapped image away from keys.
    const std::vector<AnimKey> keys = {
        {0.0, 0.0, TangentType::spline, TangentType::spline},    {1.0, 3.0, TangentType::clamped, TangentType::plateau},
        {2.0, 2.0, TangentType::auto_, TangentType::step},       {4.0, 6.0, TangentType::flat, TangentType::linear},
        {5.0, 1.0, TangentType::linear, TangentType::auto_},     {7.0, 2.0, TangentType::spline, TangentType::stepNext},
        {8.0, -1.0, TangentType::plateau, TangentType::clamped},
    };
    const double h = 1e-5;
    for (Infinity mode : allInfinities) {
        CAPTURE(rig::infinityName(mode));
        const AnimCurve curve = AnimCurve::build(keys, mode, mode);
        for (int i = -200; i < 400; ++i) {
            const double x = 0.05 + 0.1 * i;
            CAPTURE(x);
            const double finite = (curve.evaluate(x + h) - curve.evaluate(x - h)) / (2.0 * h);
            CHECK(curve.derivative(x) == doctest::Approx(finite).epsilon(1e-6));
        }
    }
}

TEST_CASE("derivative at a key is the slope on its right")
{
    const AnimCurve curve = AnimCurve::build({{0.0, 0.0, TangentType::linear, TangentType::linear},
                                              {1.0, 1.0, TangentType::linear, TangentType::flat},
                                              {2.0, 3.0, TangentType::linear, TangentType::linear}});
    CHECK(curve.derivative(1.0) == 0.0);
    CHECK(curve.derivative(2.0) == doctest::Approx(2.0));
}

TEST_CASE("infinity modes beyond both ends")
{
    // Linear keys (0, 0) (1, 2) (2, 1): period 2, value change 1.
    const auto points = std::vector<std::pair<double, double>>{{0.0, 0.0}, {1.0, 2.0}, {2.0, 1.0}};
    const auto curveWith = [&](Infinity mode) {
        return AnimCurve::build(keysOf(points, TangentType::linear), mode, mode);
    };

    SUBCASE("constant holds the end values")
    {
        const AnimCurve curve = curveWith(Infinity::constant);
        CHECK(curve.evaluate(-3.0) == 0.0);
        CHECK(curve.evaluate(7.0) == 1.0);
        CHECK(curve.derivative(-3.0) == 0.0);
        CHECK(curve.derivative(7.0) == 0.0);
    }
    SUBCASE("linear extrapolates the end tangents")
    {
        const AnimCurve curve = curveWith(Infinity::linear);
        CHECK(curve.evaluate(-1.0) == doctest::Approx(-2.0));
        CHECK(curve.evaluate(-3.0) == doctest::Approx(-6.0));
        CHECK(curve.evaluate(3.0) == doctest::Approx(0.0));
        CHECK(curve.evaluate(5.0) == doctest::Approx(-2.0));
        CHECK(curve.derivative(-3.0) == doctest::Approx(2.0));
        CHECK(curve.derivative(5.0) == doctest::Approx(-1.0));
    }
    SUBCASE("cycle repeats the keyed range")
    {
        const AnimCurve curve = curveWith(Infinity::cycle);
        CHECK(curve.evaluate(2.5) == doctest::Approx(1.0));
        CHECK(curve.evaluate(3.0) == doctest::Approx(2.0));
        CHECK(curve.evaluate(6.5) == doctest::Approx(1.0));
        CHECK(curve.evaluate(-0.5) == doctest::Approx(1.5));
        CHECK(curve.evaluate(-1.0) == doctest::Approx(2.0));
        CHECK(curve.evaluate(-5.5) == doctest::Approx(1.0));
        // Whole periods past the first key map to the first key, before it to the last.
        CHECK(curve.evaluate(4.0) == 0.0);
        CHECK(curve.evaluate(-2.0) == 1.0);
        CHECK(curve.derivative(2.5) == doctest::Approx(2.0));
    }
    SUBCASE("cycleRelative offsets each period by the value change")
    {
        const AnimCurve curve = curveWith(Infinity::cycleRelative);
        CHECK(curve.evaluate(2.5) == doctest::Approx(2.0));
        CHECK(curve.evaluate(3.0) == doctest::Approx(3.0));
        CHECK(curve.evaluate(4.0) == doctest::Approx(2.0));
        CHECK(curve.evaluate(7.0) == doctest::Approx(5.0));
        CHECK(curve.evaluate(-0.5) == doctest::Approx(0.5));
        CHECK(curve.evaluate(-2.0) == doctest::Approx(-1.0));
        CHECK(curve.evaluate(-3.0) == doctest::Approx(0.0));
        CHECK(curve.derivative(3.5) == doctest::Approx(-1.0));
    }
    SUBCASE("oscillate mirrors back and forth")
    {
        const AnimCurve curve = curveWith(Infinity::oscillate);
        CHECK(curve.evaluate(2.5) == doctest::Approx(1.5));
        CHECK(curve.evaluate(3.0) == doctest::Approx(2.0));
        CHECK(curve.evaluate(4.0) == doctest::Approx(0.0));
        CHECK(curve.evaluate(4.5) == doctest::Approx(1.0));
        CHECK(curve.evaluate(-0.5) == doctest::Approx(1.0));
        CHECK(curve.evaluate(-2.0) == doctest::Approx(1.0));
        CHECK(curve.evaluate(-2.5) == doctest::Approx(1.5));
        // Mirrored passes run the curve backwards, so the slope flips.
        CHECK(curve.derivative(2.5) == doctest::Approx(1.0));
        CHECK(curve.derivative(-0.5) == doctest::Approx(-2.0));
        CHECK(curve.derivative(4.5) == doctest::Approx(2.0));
    }
}

TEST_CASE("linear infinity follows flat end tangents")
{
    const AnimCurve curve =
        AnimCurve::build(keysOf({{0.0, 1.0}, {1.0, 4.0}}, TangentType::auto_), Infinity::linear, Infinity::linear);
    CHECK(curve.evaluate(-10.0) == 1.0);
    CHECK(curve.evaluate(10.0) == 4.0);
}
