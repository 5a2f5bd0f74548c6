#include "nodes/curves/key_reduction.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "core/error.h"
#include "core/rotation_math.h"
#include "inversion/jacobian.h"

namespace rig {
namespace {

constexpr double infinite = std::numeric_limits<double>::infinity();

// One frame of the real rig under keyed values against the dense pose.
struct FrameError {
    double positionCm = 0.0;
    double rotationDeg = 0.0;
    int worstOutput = 0;      // by position
    double normalized = 0.0;  // the largest error over the tolerance, either kind: within it at <= 1
    int worstNormalized = 0;  // the output where that is
};

// The real rig driven by the dense values (kept per frame) and by keyed ones (measured against them).
class Comparison {
public:
    Comparison(RigBinding& rig, const std::vector<std::vector<double>>& dense, const KeyReductionOptions& options)
        : rig_(rig), options_(options)
    {
        for (const auto& values : dense) {
            rig_.evaluate(values, worlds_);
            ++evaluations;
            auto& positions = positions_.emplace_back();
            auto& rotations = rotations_.emplace_back();
            for (const auto& w : worlds_) {
                positions.push_back(w.block<3, 1>(0, 3));
                rotations.push_back(polarRotation(w.topLeftCorner<3, 3>()));
            }
        }
    }

    std::size_t outputs() const { return positions_.empty() ? 0 : positions_.front().size(); }

    FrameError measure(std::size_t frame, std::span<const double> values)
    {
        rig_.evaluate(values, worlds_);
        ++evaluations;
        FrameError e;
        for (std::size_t o = 0; o < worlds_.size(); ++o) {
            double p = (worlds_[o].block<3, 1>(0, 3) - positions_[frame][o]).norm();
            double r = rotationDeg(worlds_[o], rotations_[frame][o]);
            // A rig that fails under the keyed values is as far as can be.
            if (!std::isfinite(p) || !std::isfinite(r)) p = r = infinite;
            if (p > e.positionCm) {
                e.positionCm = p;
                e.worstOutput = static_cast<int>(o);
            }
            e.rotationDeg = std::max(e.rotationDeg, r);
            const double n = std::max(p / options_.toleranceCm, r / options_.toleranceDeg);
            if (n > e.normalized) {
                e.normalized = n;
                e.worstNormalized = static_cast<int>(o);
            }
        }
        return e;
    }

    // The errors over the tolerances per unit of each parameter, per output (sensitivity[o][p]), by finite
    // differences at a few frames of the dense values, the largest kept.
    std::vector<std::vector<double>> sensitivity(const std::vector<std::vector<double>>& dense)
    {
        const std::vector<RigParameter> parameters = parametersOf(rig_);
        std::vector<std::vector<double>> s(outputs(), std::vector<double>(parameters.size(), 0.0));
        const std::size_t samples = std::min<std::size_t>(dense.size(), 5);
        for (std::size_t k = 0; k < samples; ++k) {
            const std::size_t frame = samples == 1 ? 0 : k * (dense.size() - 1) / (samples - 1);
            std::vector<double> values = dense[frame];
            for (std::size_t p = 0; p < parameters.size(); ++p) {
                const RigParameter& parameter = parameters[p];
                double h = parameter.angular ? 1e-3 : 1e-3 * std::max(1.0, parameter.max - parameter.min);
                // A control at its upper limit is moved down instead.
                if (parameter.limited && values[p] + h > parameter.max) h = -h;
                values[p] += h;
                rig_.evaluate(values, worlds_);
                ++evaluations;
                values[p] = dense[frame][p];
                for (std::size_t o = 0; o < worlds_.size(); ++o) {
                    const double dp = (worlds_[o].block<3, 1>(0, 3) - positions_[frame][o]).norm() / std::abs(h);
                    const double dr = rotationDeg(worlds_[o], rotations_[frame][o]) / std::abs(h);
                    const double n = std::max(dp / options_.toleranceCm, dr / options_.toleranceDeg);
                    if (std::isfinite(n)) s[o][p] = std::max(s[o][p], n);
                }
            }
        }
        return s;
    }

    long long evaluations = 0;

private:
    static std::vector<RigParameter> parametersOf(const RigBinding& rig)
    {
        std::vector<RigParameter> out;
        for (const auto& m : rig.approximation().parameters) out.push_back(m.parameter);
        return out;
    }

    static double rotationDeg(const Eigen::Matrix4d& world, const Eigen::Matrix3d& rotation)
    {
        return orientationAngle(world.topLeftCorner<3, 3>(), rotation) * 180.0 / std::numbers::pi;
    }

    RigBinding& rig_;
    const KeyReductionOptions& options_;
    std::vector<Eigen::Matrix4d> worlds_;
    std::vector<std::vector<Eigen::Vector3d>> positions_;  // [frame][output], dense
    std::vector<std::vector<Eigen::Matrix3d>> rotations_;
};

void checkInputs(std::span<const double> frames, const std::vector<std::vector<double>>& dense, const RigBinding& rig)
{
    if (frames.empty() || frames.size() != dense.size())
        throw internalError(
            fmt::format("reduceKeys: {} frame numbers for {} rows of values", frames.size(), dense.size()));
    for (std::size_t f = 0; f < frames.size(); ++f) {
        if (dense[f].size() != rig.approximation().parameters.size())
            throw internalError(fmt::format("reduceKeys: frame {} has {} values for {} parameters", f, dense[f].size(),
                                            rig.approximation().parameters.size()));
        if (f > 0 && !(frames[f] > frames[f - 1])) throw internalError("reduceKeys: frame numbers must increase");
    }
}

KeyedError summarize(const std::vector<FrameError>& errors)
{
    KeyedError out;
    for (std::size_t f = 0; f < errors.size(); ++f) {
        const FrameError& e = errors[f];
        out.positionCm.push_back(e.positionCm);
        out.rotationDeg.push_back(e.rotationDeg);
        out.worstOutput.push_back(e.worstOutput);
        if (e.positionCm > out.maxPositionCm || f == 0) {
            out.maxPositionCm = e.positionCm;
            out.worstFrame = static_cast<int>(f);
            out.worstOutputOverall = e.worstOutput;
        }
        out.maxRotationDeg = std::max(out.maxRotationDeg, e.rotationDeg);
    }
    return out;
}

// Keys on the dense values at chosen frames, the keyed values of every curve at every frame and the real
// rig's errors under them, kept up to date as keys come and go.
class KeyedState {
public:
    KeyedState(Comparison& comparison, std::span<const double> frames, const std::vector<std::vector<double>>& dense,
               const RigBinding& rig, TangentType tangent)
        : comparison_(comparison), frames_(frames), dense_(dense), tangent_(tangent)
    {
        values = dense;
        errors.resize(frames.size());
        for (const auto& m : rig.approximation().parameters) parameters_.push_back(m.parameter);
    }

    std::size_t frameCount() const { return frames_.size(); }
    bool constant(std::size_t p) const
    {
        return std::all_of(dense_.begin(), dense_.end(), [&](const auto& row) { return row[p] == dense_[0][p]; });
    }

    // Sets every curve's keys, then measures every frame.
    void reset(std::vector<std::vector<int>> keys)
    {
        at = std::move(keys);
        for (std::size_t p = 0; p < at.size(); ++p) {
            keepWithinLimits(p);
            const AnimCurve curve = curve_(p);
            for (std::size_t f = 0; f < frameCount(); ++f) values[f][p] = curve.evaluate(frames_[f]);
        }
        for (std::size_t f = 0; f < frameCount(); ++f) errors[f] = comparison_.measure(f, values[f]);
    }

    // Adds (or removes) the key of curve `p` at frame `frame` and measures again the frames it changes. The
    // frames changed and their values and errors before are kept for undo().
    void toggle(std::size_t p, int frame)
    {
        auto& keys = at[p];
        const auto place = std::lower_bound(keys.begin(), keys.end(), frame);
        const bool removing = place != keys.end() && *place == frame;
        // A key moves the slopes of its neighbours, so the curve changes from two keys before it to two after;
        // before the first key or past the last one it is held, so it changes there too.
        const auto index = place - keys.begin();
        const std::size_t from = index < 2 ? 0 : static_cast<std::size_t>(keys[static_cast<std::size_t>(index - 2)]);
        const auto after = static_cast<std::size_t>(index + (removing ? 2 : 1));
        const std::size_t to = after >= keys.size() ? frameCount() - 1 : static_cast<std::size_t>(keys[after]);
        undoKeys_ = keys;
        if (removing) keys.erase(place);
        else keys.insert(place, frame);
        undoParameter_ = p;
        undoFrames_.clear();
        undoValues_.clear();
        undoErrors_.clear();
        if (keepWithinLimits(p)) update(p, 0, frameCount() - 1);
        else update(p, from, to);
    }

    // Back to before the last toggle.
    void undo()
    {
        at[undoParameter_] = undoKeys_;
        for (std::size_t i = 0; i < undoFrames_.size(); ++i) {
            values[undoFrames_[i]][undoParameter_] = undoValues_[i];
            errors[undoFrames_[i]] = undoErrors_[i];
        }
    }

    // Whether the frames the last toggle changed are within the tolerance.
    bool changedWithin() const
    {
        return std::all_of(undoFrames_.begin(), undoFrames_.end(),
                           [&](std::size_t f) { return errors[f].normalized <= 1.0; });
    }

    AnimCurve curve(std::size_t p) const { return curve_(p); }

    std::vector<std::vector<int>> at;  // [parameter]: the frame indices of its keys, increasing
    std::vector<std::vector<double>> values;
    std::vector<FrameError> errors;

private:
    AnimCurve curve_(std::size_t p) const
    {
        std::vector<AnimKey> keys;
        for (const int f : at[p]) {
            const auto i = static_cast<std::size_t>(f);
            keys.push_back({frames_[i], dense_[i][p], tangent_, tangent_});
        }
        return AnimCurve::build(std::move(keys));
    }

    // A control with limits keeps them between its keys too (a spline can overshoot): a key at the frame
    // furthest out, until none is. True when keys were added.
    bool keepWithinLimits(std::size_t p)
    {
        const RigParameter& parameter = parameters_[p];
        if (!parameter.limited) return false;
        bool added = false;
        while (true) {
            const AnimCurve c = curve_(p);
            double furthest = 0.0;
            int frame = -1;
            for (std::size_t f = 0; f < frameCount(); ++f) {
                const double v = c.evaluate(frames_[f]);
                const double out = std::max(parameter.min - v, v - parameter.max);
                if (out > furthest) {
                    furthest = out;
                    frame = static_cast<int>(f);
                }
            }
            if (frame < 0) return added;
            at[p].insert(std::upper_bound(at[p].begin(), at[p].end(), frame), frame);
            added = true;
        }
    }

    void update(std::size_t p, std::size_t from, std::size_t to)
    {
        const AnimCurve c = curve_(p);
        for (std::size_t f = from; f <= to; ++f) {
            const double value = c.evaluate(frames_[f]);
            if (value == values[f][p]) continue;
            undoFrames_.push_back(f);
            undoValues_.push_back(values[f][p]);
            undoErrors_.push_back(errors[f]);
            values[f][p] = value;
            errors[f] = comparison_.measure(f, values[f]);
        }
    }

    Comparison& comparison_;
    std::span<const double> frames_;
    const std::vector<std::vector<double>>& dense_;
    TangentType tangent_;
    std::vector<RigParameter> parameters_;
    std::size_t undoParameter_ = 0;
    std::vector<int> undoKeys_;
    std::vector<std::size_t> undoFrames_;
    std::vector<double> undoValues_;
    std::vector<FrameError> undoErrors_;
};

// A curve's first keys: the first frame (only it when the curve is constant), the last, then a key at the
// frame it misses most until it misses none by more than `tolerance`.
std::vector<int> fitCurve(const KeyedState& state, const std::vector<std::vector<double>>& dense,
                          std::span<const double> frames, std::size_t p, double tolerance, TangentType tangent)
{
    const int n = static_cast<int>(frames.size());
    std::vector<int> at{0};
    if (state.constant(p) || n == 1) return at;
    at.push_back(n - 1);
    std::vector<double> miss(frames.size(), 0.0);
    int from = 0, to = n - 1;  // the frames whose miss changed
    while (true) {
        std::vector<AnimKey> keys;
        for (const int f : at) {
            const auto i = static_cast<std::size_t>(f);
            keys.push_back({frames[i], dense[i][p], tangent, tangent});
        }
        const AnimCurve curve = AnimCurve::build(std::move(keys));
        for (int f = from; f <= to; ++f) {
            const auto i = static_cast<std::size_t>(f);
            miss[i] = std::abs(curve.evaluate(frames[i]) - dense[i][p]);
        }
        const auto worst = std::max_element(miss.begin(), miss.end());
        if (*worst <= tolerance) return at;
        const int frame = static_cast<int>(worst - miss.begin());
        const auto place = std::upper_bound(at.begin(), at.end(), frame);
        const auto k = static_cast<int>(place - at.begin());
        at.insert(place, frame);
        from = at[static_cast<std::size_t>(std::max(0, k - 2))];
        to = at[static_cast<std::size_t>(std::min(static_cast<int>(at.size()) - 1, k + 2))];
    }
}

bool allWithin(const std::vector<FrameError>& errors)
{
    return std::all_of(errors.begin(), errors.end(), [](const FrameError& e) { return e.normalized <= 1.0; });
}

}  // namespace

void KeyReductionOptions::validate() const
{
    if (!(toleranceCm > 0.0) || !std::isfinite(toleranceCm))
        throw Error(fmt::format("toleranceCm must be a positive number, got {}", toleranceCm));
    if (!(toleranceDeg > 0.0) || !std::isfinite(toleranceDeg))
        throw Error(fmt::format("toleranceDeg must be a positive number, got {}", toleranceDeg));
}

std::size_t KeyedCurves::keyCount() const
{
    std::size_t n = 0;
    for (const auto& k : keys) n += k.size();
    return n;
}

KeyedCurves reduceKeys(RigBinding& rig, std::span<const double> frames, const std::vector<std::vector<double>>& dense,
                       const KeyReductionOptions& options)
{
    options.validate();
    checkInputs(frames, dense, rig);
    const auto report = [&](double fraction) {
        if (options.progress) options.progress(fraction);
    };
    Comparison comparison(rig, dense, options);
    const std::size_t parameters = dense.front().size();
    const auto sensitivity = comparison.sensitivity(dense);
    KeyedState state(comparison, frames, dense, rig, options.tangent);
    report(0.05);

    // Each curve on its own, allowed the whole tolerance at its most sensitive joint.
    std::vector<std::vector<int>> first;
    for (std::size_t p = 0; p < parameters; ++p) {
        double most = 0.0;
        for (const auto& row : sensitivity) most = std::max(most, row[p]);
        first.push_back(fitCurve(state, dense, frames, p, most > 0.0 ? 1.0 / most : infinite, options.tangent));
    }
    state.reset(std::move(first));
    report(0.1);

    // Then a key where the real rig is furthest out, on the control that moves the worst joint most there.
    const std::size_t total = frames.size();
    std::size_t best = 0;
    while (true) {
        const auto worst =
            std::max_element(state.errors.begin(), state.errors.end(),
                             [](const FrameError& a, const FrameError& b) { return a.normalized < b.normalized; });
        if (worst->normalized <= 1.0) break;
        const auto f = static_cast<std::size_t>(worst - state.errors.begin());
        const auto& weights = sensitivity[static_cast<std::size_t>(worst->worstNormalized)];
        std::size_t chosen = parameters;
        double largest = -1.0;
        for (std::size_t p = 0; p < parameters; ++p) {
            // A curve keyed at this frame is on its dense value there.
            const double miss = std::abs(state.values[f][p] - dense[f][p]);
            if (miss == 0.0) continue;
            // A control the sensitivities missed still counts, below every one they saw.
            const double effect = std::max(weights[p] * miss, miss * 1e-12);
            if (effect > largest) {
                largest = effect;
                chosen = p;
            }
        }
        // Every control on its dense value is the dense pose, whose error is none.
        if (chosen == parameters) throw internalError("reduceKeys: a frame on the dense values is off the tolerance");
        state.toggle(chosen, static_cast<int>(f));
        const auto within = static_cast<std::size_t>(std::count_if(
            state.errors.begin(), state.errors.end(), [](const FrameError& e) { return e.normalized <= 1.0; }));
        best = std::max(best, within);
        report(0.1 + 0.6 * static_cast<double>(best) / static_cast<double>(total));
    }

    // Last, keys the later ones made unneeded: each inner key taken out where every frame stays within.
    for (std::size_t p = 0; p < parameters; ++p) {
        for (std::size_t k = 1; k + 1 < state.at[p].size();) {
            const std::size_t before = state.at[p].size();
            state.toggle(p, state.at[p][k]);
            // (Keeping within the limits can put back as many keys as went.)
            if (state.at[p].size() < before && state.changedWithin()) continue;
            state.undo();
            ++k;
        }
        report(0.7 + 0.3 * static_cast<double>(p + 1) / static_cast<double>(parameters));
    }

    KeyedCurves out;
    for (std::size_t p = 0; p < parameters; ++p) {
        const AnimCurve curve = state.curve(p);
        out.keys.emplace_back(curve.keys().begin(), curve.keys().end());
    }
    out.values = std::move(state.values);
    out.error = summarize(state.errors);
    out.rigEvaluations = comparison.evaluations;
    return out;
}

UniformKeys uniformKeys(RigBinding& rig, std::span<const double> frames, const std::vector<std::vector<double>>& dense,
                        const KeyReductionOptions& options)
{
    options.validate();
    checkInputs(frames, dense, rig);
    Comparison comparison(rig, dense, options);
    KeyedState state(comparison, frames, dense, rig, options.tangent);
    const int n = static_cast<int>(frames.size());
    const std::size_t parameters = dense.front().size();
    UniformKeys out;
    const auto keysEvery = [&](int step) {
        std::vector<std::vector<int>> at;
        for (std::size_t p = 0; p < parameters; ++p) {
            std::vector<int> frameKeys;
            const bool constant = state.constant(p);
            for (int f = 0; f < n; f += constant ? n : step) frameKeys.push_back(f);
            if (!constant && frameKeys.back() != n - 1) frameKeys.push_back(n - 1);
            at.push_back(std::move(frameKeys));
        }
        state.reset(std::move(at));
        if (!allWithin(state.errors)) return false;
        out.step = step;
        out.keyCount = 0;
        for (const auto& a : state.at) out.keyCount += a.size();
        out.error = summarize(state.errors);
        return true;
    };
    // Every frame keyed is the dense pose: step 1 is within any tolerance.
    keysEvery(1);
    int good = 1, bad = 0;
    for (int step = 2; good < n - 1; step *= 2) {
        const int capped = std::min(step, n - 1);
        if (!keysEvery(capped)) {
            bad = capped;
            break;
        }
        good = capped;
    }
    while (bad > good + 1) {
        const int step = (good + bad) / 2;
        if (keysEvery(step)) good = step;
        else bad = step;
        if (options.progress) options.progress(1.0 - static_cast<double>(bad - good) / n);
    }
    // The search ends on a failed step: the keys found are the last good one's.
    return out;
}

std::vector<std::vector<AnimKey>> denseKeys(std::span<const double> frames,
                                            const std::vector<std::vector<double>>& dense, TangentType tangent)
{
    std::vector<std::vector<AnimKey>> keys(dense.empty() ? 0 : dense.front().size());
    for (std::size_t f = 0; f < dense.size(); ++f)
        for (std::size_t p = 0; p < keys.size(); ++p) keys[p].push_back({frames[f], dense[f][p], tangent, tangent});
    return keys;
}

}  // namespace rig
