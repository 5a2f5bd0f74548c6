#include "nodes/anim_curve_math.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <string>
#include <tuple>
#include <utility>
#include <variant>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {

namespace {

constexpr std::array<std::pair<TangentType, std::string_view>, 9> tangentNames{{
    {TangentType::linear, "linear"},
    {TangentType::flat, "flat"},
    {TangentType::step, "step"},
    {TangentType::stepNext, "stepnext"},
    {TangentType::spline, "spline"},
    {TangentType::clamped, "clamped"},
    {TangentType::plateau, "plateau"},
    {TangentType::auto_, "auto"},
    {TangentType::fixed, "fixed"},
}};

constexpr std::array<std::pair<Infinity, std::string_view>, 5> infinityNames{{
    {Infinity::constant, "constant"},
    {Infinity::linear, "linear"},
    {Infinity::cycle, "cycle"},
    {Infinity::cycleRelative, "cycleRelative"},
    {Infinity::oscillate, "oscillate"},
}};

template <typename Table>
auto lookupByName(const Table& table, std::string_view name) -> std::optional<typename Table::value_type::first_type>
{
    for (const auto& [value, entryName] : table) {
        if (entryName == name) return value;
    }
    return std::nullopt;
}

template <typename Table>
std::string_view lookupName(const Table& table, typename Table::value_type::first_type value)
{
    for (const auto& [entryValue, name] : table) {
        if (entryValue == value) return name;
    }
    return {};  // only reachable with a value cast from outside the enum
}

// Shortest round-trip form, so messages show "10" rather than "10.000000" and
// never print two different values identically.
std::string formatNumber(double value)
{
    std::array<char, 32> buffer{};
    const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
    return std::string(buffer.data(), result.ptr);
}

std::optional<AnimKeyProblem> validate(const std::vector<AnimKey>& keys)
{
    for (std::size_t i = 0; i < keys.size(); ++i) {
        for (const auto& [label, value] : {std::pair{"x", keys[i].x}, std::pair{"y", keys[i].y}}) {
            if (!std::isfinite(value))
                return AnimKeyProblem{
                    i, fmt::format("{} {} is not finite (keys must have finite x and y)", label, formatNumber(value))};
        }
        for (const auto& [side, type, vector] : {std::tuple{"in", keys[i].inTangent, keys[i].inVector},
                                                 std::tuple{"out", keys[i].outTangent, keys[i].outVector}}) {
            if (type != TangentType::fixed) continue;
            if (!std::isfinite(vector.x) || !std::isfinite(vector.y))
                return AnimKeyProblem{i, fmt::format("the fixed {}-tangent ({}, {}) is not finite", side,
                                                     formatNumber(vector.x), formatNumber(vector.y))};
            // Maya's tangents point forward in x; a vertical one has no slope. The zero vector is flat.
            if (!(vector.x > 0.0) && !(vector.x == 0.0 && vector.y == 0.0))
                return AnimKeyProblem{i, fmt::format("the fixed {}-tangent ({}, {}) has x <= 0; a tangent points "
                                                     "forward in x (give x > 0)",
                                                     side, formatNumber(vector.x), formatNumber(vector.y))};
        }
        if (i > 0 && !(keys[i].x > keys[i - 1].x)) {
            return AnimKeyProblem{i, "x " + formatNumber(keys[i].x) + " is not greater than the previous key's x " +
                                         formatNumber(keys[i - 1].x) + " (keys must be strictly increasing)"};
        }
    }
    return std::nullopt;
}

bool isCyclic(Infinity mode) { return mode != Infinity::constant && mode != Infinity::linear; }

enum class Side { in, out };

double secant(const AnimKey& a, const AnimKey& b) { return (b.y - a.y) / (b.x - a.x); }

// The slope rules documented in the header, for one side of key i.
double resolveSlope(const std::vector<AnimKey>& keys, std::size_t i, Side side)
{
    const std::size_t n = keys.size();
    if (n < 2) return 0.0;

    const bool first = i == 0;
    const bool last = i + 1 == n;
    const bool end = first || last;
    const double before = first ? 0.0 : secant(keys[i - 1], keys[i]);
    const double after = last ? 0.0 : secant(keys[i], keys[i + 1]);
    const double towardNeighbour = first ? after : before;
    const double splineSlope =
        end ? towardNeighbour : (keys[i + 1].y - keys[i - 1].y) / (keys[i + 1].x - keys[i - 1].x);
    // Sign tests rather than before * after, which can underflow to 0.
    const bool monotone = !end && ((before > 0.0 && after > 0.0) || (before < 0.0 && after < 0.0));
    // Keeps both Bezier control points of each adjacent segment inside its value range.
    const double overshootLimit = 3.0 * std::min(std::abs(before), std::abs(after));

    switch (side == Side::in ? keys[i].inTangent : keys[i].outTangent) {
        case TangentType::linear:
            if (end) return towardNeighbour;
            return side == Side::in ? before : after;
        case TangentType::flat:
        case TangentType::step:
        case TangentType::stepNext:
            return 0.0;
        case TangentType::spline:
            return splineSlope;
        case TangentType::clamped:
            return end || monotone ? splineSlope : 0.0;
        case TangentType::plateau:
            return monotone && std::abs(splineSlope) <= overshootLimit ? splineSlope : 0.0;
        case TangentType::auto_:
            if (!monotone) return 0.0;
            return std::copysign(std::min(std::abs(splineSlope), overshootLimit), splineSlope);
        case TangentType::fixed: {
            const TangentVector& v = side == Side::in ? keys[i].inVector : keys[i].outVector;
            return v.x == 0.0 ? 0.0 : v.y / v.x;  // x == 0 only for the zero vector (validate)
        }
    }
    return 0.0;  // only reachable with a value cast from outside the enum
}

// A weighted segment's inner Bezier control points, x normalised to the segment ([0, 1] from its start to its
// end) and y as is.
struct BezierControls {
    double x1, y1, x2, y2;
};

// The control points moved so that x(t) = 3 x1 t (1-t)^2 + 3 x2 t^2 (1-t) + t^3 never decreases (the header gives
// the rule). With u = x1 and v = 1 - x2 (each point's distance into the segment from its own key), x(t) is
// monotonic when both are in [0, 1], or when u, v >= 0 and u^2 + v^2 + uv - 2u - 2v + 1 <= 0 (the discriminant of
// x'(t) / 3, a quadratic in t).
BezierControls monotonicControls(double y0, double y3, double x1, double y1, double x2, double y2)
{
    double u = std::max(x1, 0.0);
    double v = std::max(1.0 - x2, 0.0);
    if ((u > 1.0 || v > 1.0) && u * (u - 2.0 + v) + v * (v - 2.0) + 1.0 > 0.0) {
        if (u < 4.0 / 3.0) {
            // v between the roots of v^2 + (u - 2) v + (u - 1)^2 = 0; discriminant u (4 - 3u) >= 0 here.
            const double root = std::sqrt(u * (4.0 - 3.0 * u));
            v = std::clamp(v, (2.0 - u - root) / 2.0, (2.0 - u + root) / 2.0);
        } else {
            u = 4.0 / 3.0;
            v = 1.0 / 3.0;
        }
    }
    // A moved point slides along its tangent: its rise scales with its distance from its key.
    BezierControls moved{u, y1, 1.0 - v, y2};
    if (u != x1 && x1 != 0.0) moved.y1 = y0 + (y1 - y0) * u / x1;
    if (1.0 - v != x2 && x2 != 1.0) moved.y2 = y3 - (y3 - y2) * v / (1.0 - x2);
    return moved;
}

}  // namespace

std::optional<TangentType> tangentTypeFromName(std::string_view name)
{
    const auto type = lookupByName(tangentNames, name);
    return type == TangentType::fixed ? std::nullopt : type;
}

std::string_view tangentTypeName(TangentType type) { return lookupName(tangentNames, type); }

std::optional<Infinity> infinityFromName(std::string_view name) { return lookupByName(infinityNames, name); }

std::string_view infinityName(Infinity mode) { return lookupName(infinityNames, mode); }

AnimCurve AnimCurve::build(std::vector<AnimKey> keys, Infinity pre, Infinity post, bool weighted)
{
    auto built = tryBuild(std::move(keys), pre, post, weighted);
    if (const auto* problem = std::get_if<AnimKeyProblem>(&built))
        throw Error("key " + std::to_string(problem->key) + ": " + problem->what);
    return std::get<AnimCurve>(std::move(built));
}

std::variant<AnimCurve, AnimKeyProblem> AnimCurve::tryBuild(std::vector<AnimKey> keys, Infinity pre, Infinity post,
                                                            bool weighted)
{
    if (auto problem = validate(keys)) return *std::move(problem);

    AnimCurve curve;
    curve.pre_ = pre;
    curve.post_ = post;
    curve.weighted_ = weighted;

    const std::size_t n = keys.size();
    curve.inSlopes_.reserve(n);
    curve.outSlopes_.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        curve.inSlopes_.push_back(resolveSlope(keys, i, Side::in));
        curve.outSlopes_.push_back(resolveSlope(keys, i, Side::out));
    }
    curve.keys_ = std::move(keys);
    for (std::size_t i = 0; i + 1 < n; ++i) curve.buildSegment(i);

    if (auto problem = curve.overflow()) return *std::move(problem);
    return curve;
}

void AnimCurve::buildSegment(std::size_t i)
{
    const AnimKey& left = keys_[i];
    const AnimKey& right = keys_[i + 1];
    const double width = right.x - left.x;
    // Step segments are constant polynomials; the value exactly at the
    // left key is handled by evaluateInRange's exact-key lookup.
    if (left.outTangent == TangentType::step) {
        segments_.push_back({width, left.y, 0.0, 0.0, 0.0});
        return;
    }
    if (left.outTangent == TangentType::stepNext) {
        segments_.push_back({width, right.y, 0.0, 0.0, 0.0});
        return;
    }
    // Only a fixed tangent on a weighted curve has a length of its own; every other tangent puts its Bezier
    // control point at a third of the segment, where the Bezier is this Hermite cubic.
    const bool bezier = weighted_ && (left.outTangent == TangentType::fixed || right.inTangent == TangentType::fixed);
    if (!bezier) {
        // Hermite basis expanded to power form, tangents scaled to t.
        const double rise = right.y - left.y;
        const double m0 = outSlopes_[i] * width;
        const double m1 = inSlopes_[i + 1] * width;
        segments_.push_back({width, left.y, m0, 3.0 * rise - 2.0 * m0 - m1, -2.0 * rise + m0 + m1});
        return;
    }
    // Tangent vectors (x, y): a fixed one's own, any other (width, slope * width).
    const TangentVector out =
        left.outTangent == TangentType::fixed ? left.outVector : TangentVector{width, outSlopes_[i] * width};
    const TangentVector in =
        right.inTangent == TangentType::fixed ? right.inVector : TangentVector{width, inSlopes_[i + 1] * width};
    const BezierControls controls = monotonicControls(left.y, right.y, out.x / (3.0 * width), left.y + out.y / 3.0,
                                                      1.0 - in.x / (3.0 * width), right.y - in.y / 3.0);
    const auto& [a, y1, b, y2] = controls;
    Segment segment{width, left.y, 3.0 * (y1 - left.y), 3.0 * (y2 - 2.0 * y1 + left.y),
                    right.y - 3.0 * y2 + 3.0 * y1 - left.y};
    segment.bezier = true;
    segment.b1 = 3.0 * a;
    segment.b2 = 3.0 * b - 6.0 * a;
    segment.b3 = 1.0 + 3.0 * a - 3.0 * b;
    segments_.push_back(segment);
}

// Finite keys can still be too far apart for doubles: +-1.7e308 a frame apart have an infinite slope, and a
// cubic with an infinite coefficient evaluates to NaN between them.
std::optional<AnimKeyProblem> AnimCurve::overflow() const
{
    const auto problem = [&](std::size_t i, const char* what) {
        return AnimKeyProblem{i, "the curve overflows at this key (x " + formatNumber(keys_[i].x) + ", y " +
                                     formatNumber(keys_[i].y) + "): " + what +
                                     " is not a finite number; bring the keys' values nearer each other or the keys "
                                     "further apart"};
    };
    for (std::size_t i = 0; i < keys_.size(); ++i) {
        if (!std::isfinite(inSlopes_[i]) || !std::isfinite(outSlopes_[i])) return problem(i, "a tangent's slope");
        if (i >= segments_.size()) continue;
        const Segment& s = segments_[i];
        if (!std::isfinite(s.width) || !std::isfinite(s.c1) || !std::isfinite(s.c2) || !std::isfinite(s.c3))
            return problem(i, "the cubic to the next key");
    }
    if (keys_.size() < 2 || !(isCyclic(pre_) || isCyclic(post_))) return std::nullopt;
    const AnimKey& first = keys_.front();
    const AnimKey& last = keys_.back();
    if (!std::isfinite(last.x - first.x) || !std::isfinite(last.y - first.y))
        return problem(keys_.size() - 1, "the keyed range, which a cyclic infinity repeats,");
    return std::nullopt;
}

double AnimCurve::evaluate(double x) const
{
    if (keys_.empty()) return 0.0;
    const AnimKey& first = keys_.front();
    const AnimKey& last = keys_.back();
    if (keys_.size() == 1) return first.y;
    if (x >= first.x && x <= last.x) return evaluateInRange(x);

    const bool before = x < first.x;
    const Infinity mode = before ? pre_ : post_;
    const AnimKey& end = before ? first : last;
    if (mode == Infinity::constant) return end.y;
    if (mode == Infinity::linear) {
        return end.y + (x - end.x) * (before ? inSlopes_.front() : outSlopes_.back());
    }
    const Wrapped wrapped = wrap(x, mode, before);
    return evaluateInRange(wrapped.x) + wrapped.offset;
}

double AnimCurve::derivative(double x) const
{
    if (keys_.size() < 2) return 0.0;
    if (x >= keys_.front().x && x <= keys_.back().x) return derivativeInRange(x);

    const bool before = x < keys_.front().x;
    const Infinity mode = before ? pre_ : post_;
    if (mode == Infinity::constant) return 0.0;
    if (mode == Infinity::linear) return before ? inSlopes_.front() : outSlopes_.back();
    const Wrapped wrapped = wrap(x, mode, before);
    const double slope = derivativeInRange(wrapped.x);
    return wrapped.mirrored ? -slope : slope;
}

AnimCurve::Wrapped AnimCurve::wrap(double x, Infinity mode, bool before) const
{
    const AnimKey& first = keys_.front();
    const AnimKey& last = keys_.back();
    const double period = last.x - first.x;
    // Whole periods to shift by: pre-infinity lands in (first, last], post in
    // [first, last), matching Maya at exact multiples of the period.
    const double cycles = before ? std::ceil((x - last.x) / period) : std::floor((x - first.x) / period);
    // Rounding in the shift can leave the result a hair outside the range.
    const double local = std::clamp(x - cycles * period, first.x, last.x);

    Wrapped wrapped{local, 0.0, false};
    if (mode == Infinity::cycleRelative) {
        wrapped.offset = cycles * (last.y - first.y);
    } else if (mode == Infinity::oscillate && std::fmod(cycles, 2.0) != 0.0) {
        wrapped.x = std::clamp(first.x + last.x - local, first.x, last.x);
        wrapped.mirrored = true;
    }
    return wrapped;
}

std::size_t AnimCurve::keyIndexAtOrBefore(double x) const
{
    const auto isBefore = [](double value, const AnimKey& key) { return value < key.x; };
    const auto after = std::upper_bound(keys_.begin(), keys_.end(), x, isBefore);
    return after == keys_.begin() ? 0 : static_cast<std::size_t>(after - keys_.begin()) - 1;
}

double AnimCurve::parameterAt(const Segment& segment, double x, std::size_t index) const
{
    const double s = std::clamp((x - keys_[index].x) / segment.width, 0.0, 1.0);
    if (!segment.bezier) return s;
    // X(t) = t (b1 + t (b2 + t b3)) rises from 0 to 1: Newton steps kept inside a shrinking bracket, with
    // bisection where a step would leave it (X' may touch 0 inside the segment).
    double lo = 0.0, hi = 1.0, t = s;
    for (int iteration = 0; iteration < 100; ++iteration) {
        const double f = t * (segment.b1 + t * (segment.b2 + t * segment.b3)) - s;
        if (f == 0.0) return t;
        (f < 0.0 ? lo : hi) = t;
        const double slope = segment.b1 + t * (2.0 * segment.b2 + 3.0 * t * segment.b3);
        double next = slope > 0.0 ? t - f / slope : lo;
        if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
        if (next == t || hi - lo <= 1e-16) return next;
        t = next;
    }
    return t;
}

double AnimCurve::evaluateInRange(double x) const
{
    const std::size_t index = keyIndexAtOrBefore(x);
    // Exact key values, free of cubic rounding, and y[i] at a stepNext key.
    if (keys_[index].x == x) return keys_[index].y;
    const std::size_t s = std::min(index, segments_.size() - 1);
    const Segment& segment = segments_[s];
    const double t = segment.bezier ? parameterAt(segment, x, s) : (x - keys_[s].x) / segment.width;
    return segment.c0 + t * (segment.c1 + t * (segment.c2 + t * segment.c3));
}

double AnimCurve::derivativeInRange(double x) const
{
    const std::size_t s = std::min(keyIndexAtOrBefore(x), segments_.size() - 1);
    const Segment& segment = segments_[s];
    const double t = segment.bezier ? parameterAt(segment, x, s) : (x - keys_[s].x) / segment.width;
    const double dy = segment.c1 + t * (2.0 * segment.c2 + 3.0 * t * segment.c3);
    if (!segment.bezier) return dy / segment.width;
    // dy/dx = Y'(t) / X'(t); X' vanishes only where the control points were moved onto the monotonic boundary.
    const double dx = segment.b1 + t * (2.0 * segment.b2 + 3.0 * t * segment.b3);
    return dy / (std::max(dx, 1e-12) * segment.width);
}

}  // namespace rig
