#pragma once

// Evaluation of Maya-style animation curves (animCurveTU/TA/UU/UA).
//
// Raw keys go through AnimCurve::build() once, which validates them, resolves
// every tangent type to a numeric slope and precomputes one cubic per segment.
// The resulting AnimCurve is immutable; evaluate() is a binary search plus a
// cubic polynomial.
//
// Maya does not publish its tangent formulas, so this is the exact rule we
// compute. Notation: key i has (x[i], y[i]); d[i] = (y[i+1]-y[i])/(x[i+1]-x[i])
// is the secant slope of segment i; an "end key" is the first or last key;
// an interior key is "monotone" when d[i-1] and d[i] are both > 0 or both < 0
// (otherwise it is an extremum or equals a neighbour's value).
//
//   linear   in-slope d[i-1], out-slope d[i]. An end key has no neighbour on
//            one side and uses the slope toward its only neighbour instead, so
//            linear infinity continues the end segment (the usual rigging setup).
//   flat     0.
//   step     slope 0. As the out-tangent of key i, segment i holds y[i] up to,
//            excluding, x[i+1].
//   stepNext slope 0. As the out-tangent of key i, segment i takes y[i+1] just
//            after x[i] (at x[i] itself the value is still y[i]).
//   spline   interior: (y[i+1]-y[i-1])/(x[i+1]-x[i-1]) (Catmull-Rom style);
//            end key: the secant toward its neighbour.
//   clamped  as spline, but 0 at a non-monotone interior key. End keys keep the
//            spline slope, which is already 0 when they equal their neighbour.
//            Like Maya's clamped this is not overshoot-proof on unevenly spaced
//            monotone keys; use auto or plateau for that.
//   plateau  0 at end keys and non-monotone interior keys. At a monotone key
//            the spline slope s is kept if |s| <= 3*min(|d[i-1]|, |d[i]|) and
//            becomes 0 otherwise (our reading of Maya's plateau: it flattens
//            rather than bends a tangent that would overshoot).
//   auto_    Maya 2017+ auto: 0 at end keys and non-monotone interior keys; at
//            a monotone key the spline slope with its magnitude limited to
//            3*min(|d[i-1]|, |d[i]|) (the rule in Autodesk's AnimX library).
//
// The bound 3*min(...) keeps each segment's Bezier control points within the
// segment's value range, so a segment whose both keys use plateau or auto_
// never overshoots either key.
//
//   fixed    the key's own tangent vector (x, y) (Maya's keyTanInX/Y,
//            keyTanOutX/Y): slope y / x. x must be > 0 (a vertical tangent
//            has no slope); a zero vector is flat.
//
// Segment i uses the out-tangent type of key i to choose between step,
// stepNext and a cubic. On a curve without weighted tangents (Maya's default)
// a cubic segment is the plain Hermite interpolant in x with the out-slope of
// key i and the in-slope of key i+1; only a tangent's direction counts.
//
// Weighted tangents (Maya's weightedTangents): a segment is the cubic Bezier
// through P0 = key i, P1 = P0 + out/3, P2 = P3 - in/3, P3 = key i+1, in x as
// well as in y, where out is key i's out-tangent vector and in key i+1's
// in-tangent vector (Maya's convention, as Autodesk's AnimX library evaluates
// it). A fixed tangent gives its own vector, so its length (its weight) bends
// the segment; every other type has the vector (w, slope * w) with w the width
// of the segment on that side, which puts P1 and P2 at a third of the segment
// in x: such a segment is exactly the Hermite cubic above. x(t) must grow with
// t for the segment to be a function of x (Maya's rule, as AnimX applies it):
// P1 is kept at or after the segment's start and P2 at or before its end;
// where one of them still lies past the other end and x(t) would fold back,
// P1 stays and P2 moves onto the boundary of the region where x(t) is
// monotonic (when P1 lies 4/3 of the width or more from the start, it moves
// there and P2 to 2/3 of the width). A moved point keeps its tangent's
// direction.
// The value at x is y(t) with t the root of x(t) = x in [0, 1].
//
// Infinity (before the first key uses pre, after the last key uses post):
//   constant       holds the end key's value.
//   linear         extrapolates with the first key's in-slope (pre) or the
//                  last key's out-slope (post).
//   cycle          repeats the keyed range with period R = x[last]-x[first].
//   cycleRelative  repeats like cycle, each period shifted by y[last]-y[first].
//   oscillate      repeats the keyed range alternately forwards and mirrored.
// As in Maya, a post-infinity point a whole number of periods past the first
// key maps to the first key and a pre-infinity one maps to the last key.

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace rig {

// `fixed` comes last so that the indices of the others (stored in rig files' curve nodes) do not move.
enum class TangentType { linear, flat, step, stepNext, spline, clamped, plateau, auto_, fixed };

// Maya's keyTangent names: "linear", "flat", "step", "stepnext", "spline",
// "clamped", "plateau", "auto" (case-sensitive). "fixed" is not read by name:
// a name alone gives no vector; tangentTypeName(fixed) is "fixed".
std::optional<TangentType> tangentTypeFromName(std::string_view name);
std::string_view tangentTypeName(TangentType type);

enum class Infinity { constant, linear, cycle, cycleRelative, oscillate };

// Maya's preInfinity/postInfinity names: "constant", "linear", "cycle",
// "cycleRelative", "oscillate" (case-sensitive).
std::optional<Infinity> infinityFromName(std::string_view name);
std::string_view infinityName(Infinity mode);

// A fixed tangent's vector: x in the curve's x units (> 0), y in its value units.
struct TangentVector {
    double x = 1.0;
    double y = 0.0;
};

struct AnimKey {
    double x;
    double y;
    TangentType inTangent;
    TangentType outTangent;
    // Read only where the tangent on that side is `fixed`.
    TangentVector inVector{};
    TangentVector outVector{};
};

// Why keys make no curve: the first key at fault (its index) and what is wrong with it.
struct AnimKeyProblem {
    std::size_t key = 0;
    std::string what;
};

class AnimCurve {
public:
    // An empty curve; evaluates to 0 everywhere, same as build({}).
    AnimCurve() = default;

    // Throws rig::Error "key I: what" for tryBuild's problem.
    // weighted: Maya's weighted tangents (the Bezier segments above).
    static AnimCurve build(std::vector<AnimKey> keys, Infinity pre = Infinity::constant,
                           Infinity post = Infinity::constant, bool weighted = false);
    // The curve, or the first key it cannot be built from: a key's x or y not finite, x not strictly
    // increasing, or keys so far apart that a tangent's slope, the cubic to the next key or the range a
    // cyclic infinity repeats overflows a double (the curve would play NaN), or a fixed tangent's vector that
    // is not finite or has x <= 0 (but for the zero vector). Readers that know where each key is written (.anim
    // files) report the problem there.
    static std::variant<AnimCurve, AnimKeyProblem> tryBuild(std::vector<AnimKey> keys,
                                                            Infinity pre = Infinity::constant,
                                                            Infinity post = Infinity::constant, bool weighted = false);

    double evaluate(double x) const;

    // dy/dx. At a key this is the slope just right of it (left of it at the
    // last key); it is 0 on step/stepNext segments and constant infinity.
    double derivative(double x) const;

    std::span<const AnimKey> keys() const { return keys_; }
    Infinity preInfinity() const { return pre_; }
    Infinity postInfinity() const { return post_; }
    bool weighted() const { return weighted_; }

    // Resolved tangent slopes (dy/dx) of key `index`, per the rules above.
    double inSlope(std::size_t index) const { return inSlopes_.at(index); }
    double outSlope(std::size_t index) const { return outSlopes_.at(index); }

private:
    // y = c0 + t*(c1 + t*(c2 + t*c3)) with t = (x - x[i]) / width; step and
    // stepNext segments are the constant c0. A weighted Bezier segment whose
    // control points are not at the thirds (bezier) reaches t through
    // (x - x[i]) / width = t*(b1 + t*(b2 + t*b3)) instead.
    struct Segment {
        double width;
        double c0, c1, c2, c3;
        bool bezier = false;
        double b1 = 1.0, b2 = 0.0, b3 = 0.0;
    };

    // Where an out-of-range x lands inside the keyed range.
    struct Wrapped {
        double x;
        double offset;  // added to the value (cycleRelative)
        bool mirrored;  // oscillate's backward pass flips the derivative
    };

    Wrapped wrap(double x, Infinity mode, bool before) const;
    std::size_t keyIndexAtOrBefore(double x) const;
    double evaluateInRange(double x) const;
    double derivativeInRange(double x) const;
    // The segment's parameter t in [0, 1] at x.
    double parameterAt(const Segment& segment, double x, std::size_t index) const;
    std::optional<AnimKeyProblem> overflow() const;
    void buildSegment(std::size_t i);

    std::vector<AnimKey> keys_;
    std::vector<double> inSlopes_;
    std::vector<double> outSlopes_;
    std::vector<Segment> segments_;
    Infinity pre_ = Infinity::constant;
    Infinity post_ = Infinity::constant;
    bool weighted_ = false;
};

}  // namespace rig
