#pragma once
// Sparse keys for dense curves (one value per frame, as rig-invert solves them), chosen so that the real rig
// driven by the keyed curves stays within a tolerance of the rig driven by the dense values, on every joint
// of every frame (docs/keys-anim-report.md).
//
// Key values are fitted, not placed on the dense values: a curve through jittery values keeps to their middle.
// The joints' errors are predicted by the approximation's Jacobian at every frame (linear in the controls'
// offsets, and each curve linear in its key values), starting from a key on every frame; keys are taken out
// one at a time, the values of the keys around each fitted by reweighted least squares to the joints (the
// other curves as they are), while every joint stays within the tolerance, then moved by a frame or two where
// that lets more go. Then the real rig is evaluated at every frame with the keyed values: while a frame is over
// the tolerance, the control that moves its worst joint most goes back to its dense value there. A frame with
// every control on its dense value is the dense pose, so the loop ends; the result is within the tolerance by
// measurement, not by the prediction.

#include <functional>
#include <span>
#include <string>
#include <vector>

#include "inversion/clip/rig_binding.h"
#include "nodes/anim_curve_math.h"

namespace rig {

struct KeyReductionOptions {
    // The smallest tolerances: far above the round-off of joint positions in cm and of rotations in degrees,
    // below which the dense pose itself would measure over the tolerance (docs/keys-anim-report.md).
    static constexpr double minToleranceCm = 1e-9;
    static constexpr double minToleranceDeg = 1e-9;

    double toleranceCm = 0.1;   // joint positions
    double toleranceDeg = 0.5;  // joint rotations
    TangentType tangent = TangentType::auto_;
    // Called with the fraction done; may be empty.
    std::function<void(double fraction)> progress;

    // Throws rig::Error naming the field.
    void validate() const;
};

// The real rig under keyed values against the dense ones, per frame: the worst joint's errors.
struct KeyedError {
    std::vector<double> positionCm;   // [frame]
    std::vector<double> rotationDeg;  // [frame]
    std::vector<int> worstOutput;     // [frame], an index into Approximation::outputs (by position error)
    double maxPositionCm = 0.0;
    double maxRotationDeg = 0.0;
    int worstFrame = 0;  // of the position error
    int worstOutputOverall = 0;
};

struct KeyedCurves {
    std::vector<std::vector<AnimKey>> keys;   // [parameter]: x the frame number, y internal units
    std::vector<std::vector<double>> values;  // [frame][parameter]: the keyed curves at each frame
    KeyedError error;
    long long rigEvaluations = 0;

    std::size_t keyCount() const;
};

// Keys at a uniform step (every `step` frames from the first, and the last frame; one for a constant curve),
// their values fitted as reduceKeys fits its own, for comparison.
struct UniformKeys {
    int step = 1;
    std::size_t keyCount = 0;
    std::size_t constantCurves = 0;  // keyed once: why a step of 1 has fewer keys than one per frame and control
    KeyedError error;
};

// `frames`: the frame numbers of the rows of `dense` ([frame][parameter], one value per
// Approximation::parameters entry, internal units), increasing. Throws an internal rig::Error for sizes
// that do not match or fewer than one frame.
KeyedCurves reduceKeys(RigBinding& rig, std::span<const double> frames, const std::vector<std::vector<double>>& dense,
                       const KeyReductionOptions& options);

// The largest uniform step whose fitted keys keep the real rig within the tolerance (found by doubling, then
// bisection), with its keys and errors.
UniformKeys uniformKeys(RigBinding& rig, std::span<const double> frames, const std::vector<std::vector<double>>& dense,
                        const KeyReductionOptions& options);

// The keys of a curve at every frame: one per row of `dense`.
std::vector<std::vector<AnimKey>> denseKeys(std::span<const double> frames,
                                            const std::vector<std::vector<double>>& dense, TangentType tangent);

}  // namespace rig
