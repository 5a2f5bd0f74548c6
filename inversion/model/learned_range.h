#pragma once
// Where an approximation's word stops: a parameter outside the range it was learned over (RigParameter::min..max,
// the range rig-learn sampled and validated). A sampled operator is exact over its samples only and extrapolates past
// them (the biped's sliding knees past 90 degrees), so a model mismatch where one left its range is mended by learning
// over the range the motion uses (rig-learn --range, --ranges-from: docs/rig-learn.md). rig-invert's error line, the
// reports of rig-invert, rig-batch and Python, and rig-learn --ranges-from read these.

#include <span>
#include <string>
#include <string_view>
#include <utility>

#include "inversion/model/approximation.h"

namespace rig {

// A parameter seen outside its learned range: values in the rig file's units (degrees for angles).
struct RangeLeft {
    std::string parameter;  // its name; "" for none
    bool angular = false;
    double learnedMin = 0.0, learnedMax = 0.0;  // the range it was learned over
    double low = 0.0, high = 0.0;               // the values it took (over the frames that blamed it)
    bool found() const { return !parameter.empty(); }
    // Another frame's value of the same parameter: low..high grows to cover it.
    void cover(double value);
};

// Of the parameters outside their learned range at `values` (internal units, Approximation::parameters' order) that
// move output `output` (Approximation::reach), the one most likely to make the approximation disagree there: one with
// a sampled operator first (exact over its samples only; an analytic operator extrapolates as its axis and slope do),
// then the furthest out for its range's width. A limited parameter is never blamed (the solver keeps it within its
// limits, which are the rig's). None (found() false) when no parameter that moves the output left its range.
RangeLeft rangeLeft(const Approximation& approximation, std::span<const double> values, int output);

// The share of a learned range's width added past the values reached when a range is widened to cover them: a
// second learning and solve reach a little further than the first (the first extrapolated there), and a sampled
// operator's spline is least certain at its ends. 10% is 18 degrees for the default +-90.
inline constexpr double rangeMargin = 0.1;

// learnedMin..learnedMax (the rig file's units) widened to cover low..high with rangeMargin of the learned width
// on each side widened, rounded outward to two significant digits of that margin; a side already covering its
// values is kept as learned, so the range is never narrower.
std::pair<double, double> widenedRange(double learnedMin, double learnedMax, double low, double high);

// A glob (fnmatch's) that matches `name` alone: its * ? [ and \ escaped, as a range names one parameter
// (Maya's 'blendShape1.weight[0]' too).
std::string exactGlob(std::string_view name);

}  // namespace rig
