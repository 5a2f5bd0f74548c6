// Natural cubic splines, with and without breaks (a knot given twice: independent pieces).
#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <vector>

#include "core/error.h"
#include "inversion/model/cubic_spline.h"

using namespace rig;

namespace {

using V = CubicSpline<1>::Vector;

CubicSpline<1> spline(std::vector<double> x, const std::vector<double>& y)
{
    std::vector<V> values;
    for (double v : y) values.push_back(V(v));
    return CubicSpline<1>(std::move(x), std::move(values));
}

}  // namespace

TEST_CASE("cubic spline: without breaks, the values and slopes it always gave, bit for bit")
{
    // Pinned from the spline before breaks existed: a curve without one is computed with the same arithmetic.
    const CubicSpline<1> s = spline({-1.0, 0.0, 0.5, 1.5, 2.0}, {-0.8, 0.0, 0.3, 1.9, 1.2});
    const std::vector<std::array<double, 3>> pinned{
        {-1.5, -1.2989247311827958, 0.99784946236559147}, {-0.3, -0.16936774193548385, 0.70701075268817215},
        {0.2, 0.072877419354838713, 0.40326881720430102}, {0.5, 0.29999999999999999, 1.2881720430107524},
        {1.1, 1.4802838709677419, 1.908301075268817},     {1.7, 1.7411870967741936, -1.3495053763440858},
        {2.5, 0.18440860215053756, -2.0311827956989248}};
    for (const auto& [x, value, slope] : pinned) {
        CAPTURE(x);
        CHECK(s.value(x)[0] == value);
        CHECK(s.derivative(x)[0] == slope);
    }
}

TEST_CASE("cubic spline: a break joins two different lines with a kink, exactly")
{
    // 2x up to 1, then falling by 1 per unit: each piece is a natural spline through points of one line.
    const CubicSpline<1> s = spline({0.0, 0.5, 1.0, 1.0, 2.0, 3.0}, {0.0, 1.0, 2.0, 2.0, 1.0, 0.0});
    const auto f = [](double x) { return x <= 1.0 ? 2.0 * x : 3.0 - x; };
    for (double x : {-1.0, 0.0, 0.25, 0.75, 0.999, 1.0, 1.001, 1.5, 2.5, 3.0, 4.0}) {
        CAPTURE(x);
        CHECK(s.value(x)[0] == doctest::Approx(f(x)).epsilon(1e-15));
    }
    // One-sided at the break: the right-hand piece's slope there, the left-hand one's just before.
    CHECK(s.derivative(1.0)[0] == doctest::Approx(-1.0).epsilon(1e-15));
    CHECK(s.derivative(1.0 - 1e-12)[0] == doctest::Approx(2.0).epsilon(1e-12));
    CHECK(s.derivative(0.0)[0] == doctest::Approx(2.0).epsilon(1e-15));
    CHECK(s.derivative(5.0)[0] == doctest::Approx(-1.0).epsilon(1e-15));
    // Without the break, the same samples are a curve that rounds the kink.
    const CubicSpline<1> rounded = spline({0.0, 0.5, 1.0, 2.0, 3.0}, {0.0, 1.0, 2.0, 1.0, 0.0});
    CHECK(std::abs(rounded.value(0.75)[0] - f(0.75)) > 0.05);
}

TEST_CASE("cubic spline: a flat stretch between two breaks stays flat exactly, the curves either side their own")
{
    // A foot roll's shape: rising to 1, flat from 1 to 3, then rising again on a curve of its own.
    const CubicSpline<1> s =
        spline({0.0, 0.5, 1.0, 1.0, 2.0, 3.0, 3.0, 3.5, 4.0}, {0.0, 0.6, 1.0, 1.0, 1.0, 1.0, 1.0, 1.1, 1.5});
    for (double x : {1.0, 1.0 + 1e-12, 1.5, 2.0, 2.999999, 3.0}) {
        CAPTURE(x);
        CHECK(s.value(x)[0] == 1.0);
    }
    CHECK(s.derivative(1.0)[0] == 0.0);
    CHECK(s.derivative(2.5)[0] == 0.0);
    CHECK(s.derivative(3.0)[0] > 0.0);  // the right-hand piece's
    CHECK(s.value(0.9)[0] < 1.0);
    CHECK(s.value(3.1)[0] > 1.0);
    // Each outer piece is the natural spline of its own knots alone.
    const CubicSpline<1> left = spline({0.0, 0.5, 1.0}, {0.0, 0.6, 1.0});
    const CubicSpline<1> right = spline({3.0, 3.5, 4.0}, {1.0, 1.1, 1.5});
    for (double x : {-0.5, 0.2, 0.7, 0.99}) CHECK(s.value(x)[0] == left.value(x)[0]);
    for (double x : {3.2, 3.7, 4.5}) CHECK(s.value(x)[0] == right.value(x)[0]);
}

TEST_CASE("cubic spline: a break is one knot twice, inside, with one value")
{
    CHECK_THROWS_AS(spline({0.0, 1.0, 1.0, 1.0, 2.0}, {0.0, 1.0, 1.0, 1.0, 2.0}), Error);
    CHECK_THROWS_AS(spline({0.0, 0.0, 1.0}, {0.0, 0.0, 1.0}), Error);
    CHECK_THROWS_AS(spline({0.0, 1.0, 1.0}, {0.0, 1.0, 1.0}), Error);
    CHECK_THROWS_AS(spline({0.0, 1.0, 1.0, 2.0}, {0.0, 1.0, 1.5, 2.0}), Error);
    CHECK_THROWS_AS(spline({0.0, 2.0, 1.0}, {0.0, 1.0, 2.0}), Error);
    CHECK_NOTHROW(spline({0.0, 1.0, 1.0, 2.0}, {0.0, 1.0, 1.0, 2.0}));
}
