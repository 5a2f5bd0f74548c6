#include "nodes/anim_curve_math.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <string>
#include <utility>
#include <variant>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {

namespace {

constexpr std::array<std::pair<TangentType, std::string_view>, 8> tangentNames{{
    {TangentType::linear, "linear"},
    {TangentType::flat, "flat"},
    {TangentType::step, "step"},
    {TangentType::stepNext, "stepnext"},
    {TangentType::spline, "spline"},
    {TangentType::clamped, "clamped"},
    {TangentType::plateau, "plateau"},
    {TangentType::auto_, "auto"},
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
    }
    return 0.0;  // only reachable with a value cast from outside the enum
}

}  // namespace

std::optional<TangentType> tangentTypeFromName(std::string_view name) { return lookupByName(tangentNames, name); }

std::string_view tangentTypeName(TangentType type) { return lookupName(tangentNames, type); }

std::optional<Infinity> infinityFromName(std::string_view name) { return lookupByName(infinityNames, name); }

std::string_view infinityName(Infinity mode) { return lookupName(infinityNames, mode); }

AnimCurve AnimCurve::build(std::vector<AnimKey> keys, Infinity pre, Infinity post)
{
    auto built = tryBuild(std::move(keys), pre, post);
    if (const auto* problem = std::get_if<AnimKeyProblem>(&built))
        throw Error("key " + std::to_string(problem->key) + ": " + problem->what);
    return std::get<AnimCurve>(std::move(built));
}

std::variant<AnimCurve, AnimKeyProblem> AnimCurve::tryBuild(std::vector<AnimKey> keys, Infinity pre, Infinity post)
{
    if (auto problem = validate(keys)) return *std::move(problem);

    AnimCurve curve;
    curve.pre_ = pre;
    curve.post_ = post;

    const std::size_t n = keys.size();
    curve.inSlopes_.reserve(n);
    curve.outSlopes_.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        curve.inSlopes_.push_back(resolveSlope(keys, i, Side::in));
        curve.outSlopes_.push_back(resolveSlope(keys, i, Side::out));
    }

    for (std::size_t i = 0; i + 1 < n; ++i) {
        const AnimKey& left = keys[i];
        const AnimKey& right = keys[i + 1];
        const double width = right.x - left.x;
        // Step segments are constant polynomials; the value exactly at the
        // left key is handled by evaluateInRange's exact-key lookup.
        if (left.outTangent == TangentType::step) {
            curve.segments_.push_back({width, left.y, 0.0, 0.0, 0.0});
        } else if (left.outTangent == TangentType::stepNext) {
            curve.segments_.push_back({width, right.y, 0.0, 0.0, 0.0});
        } else {
            // Hermite basis expanded to power form, tangents scaled to t.
            const double rise = right.y - left.y;
            const double m0 = curve.outSlopes_[i] * width;
            const double m1 = curve.inSlopes_[i + 1] * width;
            curve.segments_.push_back({width, left.y, m0, 3.0 * rise - 2.0 * m0 - m1, -2.0 * rise + m0 + m1});
        }
    }

    curve.keys_ = std::move(keys);
    if (auto problem = curve.overflow()) return *std::move(problem);
    return curve;
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

double AnimCurve::evaluateInRange(double x) const
{
    const std::size_t index = keyIndexAtOrBefore(x);
    // Exact key values, free of cubic rounding, and y[i] at a stepNext key.
    if (keys_[index].x == x) return keys_[index].y;
    const std::size_t s = std::min(index, segments_.size() - 1);
    const Segment& segment = segments_[s];
    const double t = (x - keys_[s].x) / segment.width;
    return segment.c0 + t * (segment.c1 + t * (segment.c2 + t * segment.c3));
}

double AnimCurve::derivativeInRange(double x) const
{
    const std::size_t s = std::min(keyIndexAtOrBefore(x), segments_.size() - 1);
    const Segment& segment = segments_[s];
    const double t = (x - keys_[s].x) / segment.width;
    return (segment.c1 + t * (2.0 * segment.c2 + 3.0 * t * segment.c3)) / segment.width;
}

}  // namespace rig
