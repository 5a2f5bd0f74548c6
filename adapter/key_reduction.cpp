#include "adapter/key_reduction.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>
#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "core/error.h"
#include "core/rotation_math.h"
#include "inversion/solve/jacobian.h"

namespace rig {
namespace {

constexpr double infinite = std::numeric_limits<double>::infinity();
// The bounds, in tolerances of the predicted joint errors, at which keys are taken out: raised by steps so that
// every curve gets its share; the last one leaves the linear model's few percent to the real rig's check.
const std::vector<double> bounds{0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.99};
constexpr int maxMoveRounds = 8;

Eigen::Index eigenIndex(std::size_t n) { return static_cast<Eigen::Index>(n); }

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

    FrameError measure(std::size_t frame, std::span<const double> values)
    {
        rig_.evaluate(values, worlds_);
        ++evaluations;
        FrameError e;
        for (std::size_t o = 0; o < worlds_.size(); ++o) {
            double p = (worlds_[o].block<3, 1>(0, 3) - positions_[frame][o]).norm();
            double r =
                orientationAngle(worlds_[o].topLeftCorner<3, 3>(), rotations_[frame][o]) * 180.0 / std::numbers::pi;
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

    long long evaluations = 0;

private:
    RigBinding& rig_;
    const KeyReductionOptions& options_;
    std::vector<Eigen::Matrix4d> worlds_;
    std::vector<std::vector<Eigen::Vector3d>> positions_;  // [frame][output], dense
    std::vector<std::vector<Eigen::Matrix3d>> rotations_;
};

// The joints' errors as a linear function of the controls' offsets from the dense values, per frame: the
// approximation's analytic Jacobian there, rows scaled so that a joint is within the tolerance when its three
// position rows and its three rotation rows each have a norm of at most 1. The errors keys make are a hundredth
// of a joint's reach, so the linear model predicts the real rig's to a few percent (which measures anyway).
class LinearErrors {
public:
    LinearErrors(const Approximation& approximation, const std::vector<std::vector<double>>& dense,
                 const KeyReductionOptions& options)
        : reach_(approximation.reach()), outputs_(approximation.outputs.size())
    {
        for (const auto& outputs : reach_) {
            offset_.push_back(stride_);
            stride_ += jointTargetRows * outputs.size();
        }
        columns_.resize(stride_ * dense.size());
        std::vector<int> parameters(approximation.parameters.size()), outputs(approximation.outputs.size());
        for (std::size_t p = 0; p < parameters.size(); ++p) parameters[p] = static_cast<int>(p);
        for (std::size_t o = 0; o < outputs.size(); ++o) outputs[o] = static_cast<int>(o);
        const ResidualStructure structure(approximation, parameters, outputs);
        ResidualWorkspace workspace(structure);
        workspace.holdParameters(approximation.defaults());
        Eigen::VectorXd residuals(structure.rows());
        Eigen::MatrixXd jacobian(structure.rows(), structure.columnCount());
        std::vector<Eigen::Matrix4d> worlds;
        const double toleranceRad = options.toleranceDeg * std::numbers::pi / 180.0;
        for (std::size_t f = 0; f < dense.size(); ++f) {
            // Targets on the approximation's own pose: the rotation rows are then the joints' angular velocities.
            approximation.evaluate(dense[f], worlds);
            for (std::size_t o = 0; o < outputs.size(); ++o) {
                const JointTarget target{true, worlds[o], 1.0 / options.toleranceCm, 1.0 / toleranceRad};
                PreparedTarget prepared;  // (weights 0 where a joint has no orientation: the rig measures it)
                if (!prepareTarget(target, 1.0, prepared)) prepared = PreparedTarget{};
                workspace.setTarget(static_cast<int>(o), prepared);
            }
            workspace.jacobian(dense[f], JacobianMethod::analytic, 0.0, false, residuals, jacobian);
            float* out = columns_.data() + f * stride_;
            for (std::size_t p = 0; p < reach_.size(); ++p)
                for (const int o : reach_[p])
                    for (int i = 0; i < jointTargetRows; ++i)
                        *out++ = static_cast<float>(jacobian(structure.rowOffset(o) + i, static_cast<int>(p)));
        }
    }

    std::size_t outputs() const { return outputs_; }
    // The outputs control p moves, increasing.
    const std::vector<int>& reach(std::size_t p) const { return reach_[p]; }
    // Its column at frame f: six rows per output of reach(p).
    std::span<const float> column(std::size_t f, std::size_t p) const
    {
        return {columns_.data() + f * stride_ + offset_[p], jointTargetRows * reach_[p].size()};
    }
    // How far output o moves (in tolerances) per unit of control p at frame f.
    double effect(std::size_t f, std::size_t p, int o) const
    {
        const auto& outputs = reach_[p];
        const auto at = std::lower_bound(outputs.begin(), outputs.end(), o);
        if (at == outputs.end() || *at != o) return 0.0;
        const auto rows = column(f, p).subspan(jointTargetRows * static_cast<std::size_t>(at - outputs.begin()), 6);
        const auto norm = [&](std::size_t i) {
            return std::sqrt(double(rows[i]) * rows[i] + double(rows[i + 1]) * rows[i + 1] +
                             double(rows[i + 2]) * rows[i + 2]);
        };
        return std::max(norm(0), norm(3));
    }

private:
    std::vector<std::vector<int>> reach_;
    std::size_t outputs_;
    std::vector<std::size_t> offset_;  // per control: where its rows start in a frame's block
    std::size_t stride_ = 0;           // a frame's block
    std::vector<float> columns_;
};

bool isConstant(const std::vector<std::vector<double>>& dense, std::size_t p)
{
    return std::all_of(dense.begin(), dense.end(), [&](const auto& row) { return row[p] == dense[0][p]; });
}

// Keys whose values are fitted to the joints rather than placed on the dense values, so that a curve through
// jittery values keeps to their middle. It starts with a key on every frame (the dense pose) and edits one key
// at a time, taking it out or moving it to another frame, each time fitting the values of the keys around it
// to the joints' predicted errors (LinearErrors) with the other curves as they are: one curve can make up for
// another on a joint. An edit is kept when every joint it changes stays within a bound at every frame.
class KeyFit {
public:
    KeyFit(const LinearErrors& linear, std::span<const double> frames, const std::vector<std::vector<double>>& dense,
           const std::vector<RigParameter>& parameters, TangentType tangent)
        : linear_(linear), frames_(frames), dense_(dense), parameters_(parameters)
    {
        keys.resize(parameters.size());
        for (std::size_t p = 0; p < parameters.size(); ++p) {
            const std::size_t count = isConstant(dense, p) ? 1 : frames.size();
            for (std::size_t f = 0; f < count; ++f) keys[p].push_back({frames[f], dense[f][p], tangent, tangent});
        }
        delta_.assign(parameters.size(), std::vector<double>(frames.size(), 0.0));
        errors_.assign(frames.size(), std::vector<double>(jointTargetRows * linear.outputs(), 0.0));
    }

    // One pass over every inner key of every curve that `removable(p, x)` allows (all when empty): each taken
    // out where its fit keeps the joints within `bound` tolerances. Returns how many went.
    std::size_t takeOut(double bound, const std::function<bool(std::size_t, double)>& removable = {});
    // One pass moving each inner key by up to two frames where the fit lowers the worst joint it changes.
    void move();

    std::size_t keyCount() const
    {
        std::size_t n = 0;
        for (const auto& k : keys) n += k.size();
        return n;
    }

    std::vector<std::vector<AnimKey>> keys;  // [parameter]

private:
    // Key k of curve p taken out, or moved to frame number `x`, and the keys around it fitted.
    struct Edit {
        std::size_t p = 0, k = 0;
        bool takeOut = true;
        double x = 0.0;
    };
    struct Proposal {
        Edit edit;
        std::size_t firstKey = 0;    // where `local` starts in the keys after the edit
        std::vector<AnimKey> local;  // the keys around k after the edit and the fit
        std::size_t firstFrame = 0;  // where `delta` starts
        Eigen::VectorXd delta;       // the curve minus the dense values over the frames the edit changes
        double worst = infinite;     // the worst joint there after the edit (infinite out of the limits)
        double worstBefore = 0.0;    // and before
    };
    // What a proposal fits over: the free keys [lo, hi] (indices into the keys after the edit), the keys from
    // firstKey and the frames from firstFrame that they change, and per joint and frame there the quadratics of
    // the joint's errors in curve p's offset.
    struct Window {
        std::size_t p = 0, lo = 0, hi = 0, firstKey = 0, firstFrame = 0, frameCount = 0;
        std::array<Eigen::ArrayXXd, 2> aa, ag, gg;  // [position, rotation](joint, frame)
    };
    // The fit stops once within `bound`.
    Proposal propose(const Edit& edit, double bound) const;
    // The window of an edit (without its quadratics), and the keys from its firstKey after the edit into `local`.
    Window window(const Edit& edit, std::vector<AnimKey>& local) const;
    void fillQuadratics(Window& w) const;
    // The curve through `curveKeys` (the window's keys) minus the dense values over the window's frames.
    void offsets(const Window& w, const std::vector<AnimKey>& curveKeys, Eigen::VectorXd& delta) const;
    // The worst joint under the offsets `delta` (infinite out of the control's limits), its errors per frame in
    // `jointErrors`.
    double worst(const Window& w, const Eigen::VectorXd& delta, Eigen::ArrayXXd& jointErrors) const;
    // The offsets' derivatives in the free keys' values (a column per free key) about the `edited` keys.
    Eigen::MatrixXd basis(const Window& w, const std::vector<AnimKey>& edited, const Eigen::VectorXd& placed) const;
    // Fits the free keys' values into `out` where they lower its worst joint.
    void refit(const Window& w, const std::vector<AnimKey>& edited, const Eigen::VectorXd& placed, double bound,
               Eigen::ArrayXXd& jointErrors, Proposal& out) const;
    void apply(const Proposal& proposal);

    std::size_t frameIndex(double x) const
    {
        return static_cast<std::size_t>(std::lower_bound(frames_.begin(), frames_.end(), x) - frames_.begin());
    }

    const LinearErrors& linear_;
    std::span<const double> frames_;
    const std::vector<std::vector<double>>& dense_;
    const std::vector<RigParameter>& parameters_;
    std::vector<std::vector<double>> delta_;   // [parameter][frame]: keyed minus dense
    std::vector<std::vector<double>> errors_;  // [frame]: the joints' predicted errors, six rows per output
};

KeyFit::Window KeyFit::window(const Edit& edit, std::vector<AnimKey>& local) const
{
    // Free keys either side of the edited one: enough, on CMU clips, that more makes no fewer keys.
    constexpr std::ptrdiff_t radius = 2;
    Window w;
    w.p = edit.p;
    const std::vector<AnimKey>& before = keys[edit.p];
    // Indices are into the keys after the edit (m of them).
    const auto k = static_cast<std::ptrdiff_t>(edit.k);
    const auto m = static_cast<std::ptrdiff_t>(before.size()) - (edit.takeOut ? 1 : 0);
    const auto index = [&](std::ptrdiff_t j) {
        return static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(j, 0, m - 1));
    };
    w.lo = index(k - radius);
    w.hi = index(k + radius - (edit.takeOut ? 1 : 0));
    // A key's value moves its own slope and its neighbours': the curve changes from two keys before the free
    // ones to two after, and the slopes there depend on one key further out.
    w.firstKey = index(static_cast<std::ptrdiff_t>(w.lo) - 3);
    const std::size_t lastKey = index(static_cast<std::ptrdiff_t>(w.hi) + 3);
    for (std::size_t j = w.firstKey; j <= lastKey; ++j)
        local.push_back(before[edit.takeOut && j >= edit.k ? j + 1 : j]);
    if (!edit.takeOut) local[edit.k - w.firstKey].x = edit.x;
    const auto keyAt = [&](std::ptrdiff_t j) { return local[index(j) - w.firstKey].x; };
    w.firstFrame = frameIndex(keyAt(static_cast<std::ptrdiff_t>(w.lo) - 2));
    w.frameCount = frameIndex(keyAt(static_cast<std::ptrdiff_t>(w.hi) + 2)) - w.firstFrame + 1;
    return w;
}

void KeyFit::fillQuadratics(Window& w) const
{
    // Per joint and frame, the error without control p (a) and its rows (g): the error's position and rotation
    // norms are quadratics in the control's offset d, |a + g d|^2 = aa + 2 ag d + gg d^2.
    const auto& reach = linear_.reach(w.p);
    for (std::size_t kind = 0; kind < 2; ++kind) {
        w.aa[kind].resize(eigenIndex(reach.size()), eigenIndex(w.frameCount));
        w.ag[kind].resizeLike(w.aa[kind]);
        w.gg[kind].resizeLike(w.aa[kind]);
    }
    for (std::size_t i = 0; i < w.frameCount; ++i) {
        const std::size_t f = w.firstFrame + i;
        const auto column = linear_.column(f, w.p);
        for (std::size_t o = 0; o < reach.size(); ++o) {
            const double* error = errors_[f].data() + jointTargetRows * static_cast<std::size_t>(reach[o]);
            const float* g = column.data() + jointTargetRows * o;
            for (std::size_t kind = 0; kind < 2; ++kind) {
                double sumAA = 0.0, sumAG = 0.0, sumGG = 0.0;
                for (std::size_t r = 3 * kind; r < 3 * kind + 3; ++r) {
                    const double without = error[r] - g[r] * delta_[w.p][f];
                    sumAA += without * without;
                    sumAG += without * g[r];
                    sumGG += double(g[r]) * g[r];
                }
                w.aa[kind](eigenIndex(o), eigenIndex(i)) = sumAA;
                w.ag[kind](eigenIndex(o), eigenIndex(i)) = sumAG;
                w.gg[kind](eigenIndex(o), eigenIndex(i)) = sumGG;
            }
        }
    }
}

void KeyFit::offsets(const Window& w, const std::vector<AnimKey>& curveKeys, Eigen::VectorXd& delta) const
{
    const AnimCurve curve = AnimCurve::build(curveKeys);
    delta.resize(static_cast<Eigen::Index>(w.frameCount));
    for (std::size_t i = 0; i < w.frameCount; ++i)
        delta[i] = curve.evaluate(frames_[w.firstFrame + i]) - dense_[w.firstFrame + i][w.p];
}

double KeyFit::worst(const Window& w, const Eigen::VectorXd& delta, Eigen::ArrayXXd& jointErrors) const
{
    const RigParameter& parameter = parameters_[w.p];
    for (std::size_t i = 0; i < w.frameCount; ++i) {
        const double d = delta[eigenIndex(i)];
        const double v = dense_[w.firstFrame + i][w.p] + d;
        if (parameter.limited && (v < parameter.min || v > parameter.max)) return infinite;
        const auto at = [&](std::size_t kind) {
            return w.aa[kind].col(eigenIndex(i)) +
                   d * (2.0 * w.ag[kind].col(eigenIndex(i)) + d * w.gg[kind].col(eigenIndex(i)));
        };
        // (Rounding can take a square a hair below zero.)
        jointErrors.col(eigenIndex(i)) = at(0).max(at(1)).max(0.0).sqrt();
    }
    return jointErrors.rows() == 0 ? 0.0 : jointErrors.maxCoeff();
}

Eigen::MatrixXd KeyFit::basis(const Window& w, const std::vector<AnimKey>& edited, const Eigen::VectorXd& placed) const
{
    const std::size_t freeCount = w.hi - w.lo + 1;
    Eigen::MatrixXd basis(w.frameCount, freeCount);
    for (std::size_t j = 0; j < freeCount; ++j) {
        std::vector<AnimKey> moved = edited;
        AnimKey& key = moved[w.lo + j - w.firstKey];
        const double h = 1e-6 * std::max(1.0, std::abs(key.y));
        key.y += h;
        Eigen::VectorXd delta;
        offsets(w, moved, delta);
        basis.col(static_cast<Eigen::Index>(j)) = (delta - placed) / h;
    }
    return basis;
}

void KeyFit::refit(const Window& w, const std::vector<AnimKey>& edited, const Eigen::VectorXd& placed, double bound,
                   Eigen::ArrayXXd& jointErrors, Proposal& out) const
{
    // Reweighted least squares towards the smallest worst joint: enough, on CMU clips, that more iterations make
    // no fewer keys.
    constexpr int iterations = 6;
    const RigParameter& parameter = parameters_[w.p];
    const Eigen::MatrixXd basis = this->basis(w, edited, placed);
    // The least squares' data per joint and frame: |g|^2 and g . a over the six rows.
    const Eigen::ArrayXXd squares = w.gg[0] + w.gg[1], products = w.ag[0] + w.ag[1];
    Eigen::ArrayXXd weights = Eigen::ArrayXXd::Ones(squares.rows(), squares.cols());
    double bestFit = infinite;
    for (int iteration = 0; iteration < iterations; ++iteration) {
        const Eigen::VectorXd q = (weights * squares).colwise().sum().transpose().matrix();
        const Eigen::VectorXd s = (weights * products).colwise().sum().transpose().matrix();
        Eigen::MatrixXd normal = basis.transpose() * q.asDiagonal() * basis;
        const Eigen::VectorXd rhs = -basis.transpose() * (s + q.cwiseProduct(placed));
        // (A control that moves no joint has nothing to fit.)
        const double scale = normal.diagonal().maxCoeff();
        if (!(scale > 0.0)) break;
        normal.diagonal().array() += 1e-12 * scale;
        const Eigen::VectorXd step = normal.ldlt().solve(rhs);
        std::vector<AnimKey> trial = edited;
        for (Eigen::Index j = 0; j < step.size(); ++j) {
            AnimKey& key = trial[w.lo + static_cast<std::size_t>(j) - w.firstKey];
            key.y += step[j];
            if (parameter.limited) key.y = std::clamp(key.y, parameter.min, parameter.max);
        }
        Eigen::VectorXd trialDelta;
        offsets(w, trial, trialDelta);
        const double trialWorst = worst(w, trialDelta, jointErrors);
        bestFit = std::min(bestFit, trialWorst);
        if (trialWorst < out.worst) {
            out.local = std::move(trial);
            out.delta = std::move(trialDelta);
            out.worst = trialWorst;
        }
        if (bestFit <= bound || trialWorst > 2.0 * bound) break;
        // Lawson's weights: the least squares leans towards the joints furthest out, towards the smallest worst.
        weights *= jointErrors;
        const double largest = weights.maxCoeff();
        if (!(largest > 0.0)) break;
        weights /= largest;
    }
}

KeyFit::Proposal KeyFit::propose(const Edit& edit, double bound) const
{
    Proposal out;
    out.edit = edit;
    Window w = window(edit, out.local);
    out.firstKey = w.firstKey;
    out.firstFrame = w.firstFrame;
    fillQuadratics(w);
    // The joints' errors per frame (worst()'s, read by refit()'s weights).
    Eigen::ArrayXXd jointErrors(w.aa[0].rows(), eigenIndex(w.frameCount));
    Eigen::VectorXd current(w.frameCount);
    for (std::size_t i = 0; i < w.frameCount; ++i) current[i] = delta_[w.p][w.firstFrame + i];
    out.worstBefore = worst(w, current, jointErrors);

    // The edited keys as they are, then fitted: the curve is linear in the free values (piecewise so for the
    // tangent types that flatten at extrema), so least squares on the joints' rows is a small linear system.
    const std::vector<AnimKey> edited = out.local;
    Eigen::VectorXd placed;
    offsets(w, edited, placed);
    out.delta = placed;
    out.worst = worst(w, placed, jointErrors);
    refit(w, edited, placed, bound, jointErrors, out);
    return out;
}

void KeyFit::apply(const Proposal& proposal)
{
    const std::size_t p = proposal.edit.p;
    std::vector<AnimKey>& curveKeys = keys[p];
    if (proposal.edit.takeOut) curveKeys.erase(curveKeys.begin() + static_cast<std::ptrdiff_t>(proposal.edit.k));
    std::copy(proposal.local.begin(), proposal.local.end(),
              curveKeys.begin() + static_cast<std::ptrdiff_t>(proposal.firstKey));
    const auto& reach = linear_.reach(p);
    for (std::size_t i = 0; i < static_cast<std::size_t>(proposal.delta.size()); ++i) {
        const std::size_t f = proposal.firstFrame + i;
        const auto g = linear_.column(f, p);
        const double change = proposal.delta[static_cast<Eigen::Index>(i)] - delta_[p][f];
        delta_[p][f] = proposal.delta[static_cast<Eigen::Index>(i)];
        for (std::size_t o = 0; o < reach.size(); ++o)
            for (std::size_t r = 0; r < jointTargetRows; ++r)
                errors_[f][jointTargetRows * static_cast<std::size_t>(reach[o]) + r] +=
                    g[jointTargetRows * o + r] * change;
    }
}

std::size_t KeyFit::takeOut(double bound, const std::function<bool(std::size_t, double)>& removable)
{
    std::size_t removed = 0;
    for (std::size_t p = 0; p < keys.size(); ++p)
        for (std::size_t k = 1; k + 1 < keys[p].size();) {
            if (removable && !removable(p, keys[p][k].x)) {
                ++k;
                continue;
            }
            const Proposal proposal = propose({p, k, true, 0.0}, bound);
            if (proposal.worst > bound) {
                ++k;
                continue;
            }
            apply(proposal);
            ++removed;
        }
    return removed;
}

void KeyFit::move()
{
    for (std::size_t p = 0; p < keys.size(); ++p)
        for (std::size_t k = 1; k + 1 < keys[p].size(); ++k) {
            const std::size_t f = frameIndex(keys[p][k].x);
            Proposal best;
            for (const std::ptrdiff_t step : {-2, -1, 1, 2}) {
                const auto to = static_cast<std::ptrdiff_t>(f) + step;
                if (to < 0 || to >= static_cast<std::ptrdiff_t>(frames_.size())) continue;
                const double x = frames_[static_cast<std::size_t>(to)];
                if (!(x > keys[p][k - 1].x && x < keys[p][k + 1].x)) continue;
                Proposal proposal = propose({p, k, false, x}, 0.0);
                if (proposal.worst < best.worst) best = std::move(proposal);
            }
            // (A move must gain something: moves back and forth for rounding's sake would never end.)
            if (best.worst < best.worstBefore - 1e-3) apply(best);
        }
}

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

std::vector<RigParameter> parametersOf(const RigBinding& rig)
{
    std::vector<RigParameter> out;
    for (const auto& m : rig.approximation().parameters) out.push_back(m.parameter);
    return out;
}

// Keys, the keyed values of every curve at every frame and the real rig's errors under them, kept up to date as
// curves are put back on their dense values.
class KeyedState {
public:
    KeyedState(Comparison& comparison, std::span<const double> frames, const std::vector<std::vector<double>>& dense,
               const RigBinding& rig, TangentType tangent)
        : comparison_(comparison), frames_(frames), dense_(dense), tangent_(tangent), parameters_(parametersOf(rig))
    {
        values = dense;
        errors.resize(frames.size());
    }

    std::size_t frameCount() const { return frames_.size(); }

    // Sets every curve's keys, then measures every frame.
    void reset(std::vector<std::vector<AnimKey>> curveKeys)
    {
        keys = std::move(curveKeys);
        for (std::size_t p = 0; p < keys.size(); ++p) {
            keepWithinLimits(p);
            const AnimCurve curve = AnimCurve::build(keys[p]);
            for (std::size_t f = 0; f < frameCount(); ++f) values[f][p] = curve.evaluate(frames_[f]);
        }
        for (std::size_t f = 0; f < frameCount(); ++f) errors[f] = comparison_.measure(f, values[f]);
    }

    // Curve p on its dense value at frame f: a key there (or the key there moved), and the frames that changes
    // measured again.
    void pin(std::size_t p, std::size_t f)
    {
        auto& curveKeys = keys[p];
        const auto place = std::lower_bound(curveKeys.begin(), curveKeys.end(), frames_[f],
                                            [](const AnimKey& key, double x) { return key.x < x; });
        const auto index = static_cast<std::size_t>(place - curveKeys.begin());
        if (place != curveKeys.end() && place->x == frames_[f]) place->y = dense_[f][p];
        else curveKeys.insert(place, {frames_[f], dense_[f][p], tangent_, tangent_});
        // A key moves the slopes of its neighbours, so the curve changes from two keys before it to two after;
        // before the first key or past the last one it is held, so it changes there too.
        const std::size_t from = index < 2 ? 0 : frameIndex(curveKeys[index - 2].x);
        const std::size_t to = index + 2 >= curveKeys.size() ? frameCount() - 1 : frameIndex(curveKeys[index + 2].x);
        if (keepWithinLimits(p)) update(p, 0, frameCount() - 1);
        else update(p, from, to);
    }

    std::vector<std::vector<AnimKey>> keys;  // [parameter]
    std::vector<std::vector<double>> values;
    std::vector<FrameError> errors;

private:
    std::size_t frameIndex(double x) const
    {
        return static_cast<std::size_t>(std::lower_bound(frames_.begin(), frames_.end(), x) - frames_.begin());
    }

    // A control with limits keeps them between its keys too (a spline can overshoot): a key on the dense value
    // at the frame furthest out, until none is. True when keys were added.
    bool keepWithinLimits(std::size_t p)
    {
        const RigParameter& parameter = parameters_[p];
        if (!parameter.limited) return false;
        bool added = false;
        while (true) {
            const AnimCurve c = AnimCurve::build(keys[p]);
            double furthest = 0.0;
            std::size_t frame = frameCount();
            for (std::size_t f = 0; f < frameCount(); ++f) {
                const double v = c.evaluate(frames_[f]);
                const double out = std::max(parameter.min - v, v - parameter.max);
                if (out > furthest) {
                    furthest = out;
                    frame = f;
                }
            }
            if (frame == frameCount()) return added;
            const auto place = std::lower_bound(keys[p].begin(), keys[p].end(), frames_[frame],
                                                [](const AnimKey& key, double x) { return key.x < x; });
            if (place != keys[p].end() && place->x == frames_[frame]) place->y = dense_[frame][p];
            else keys[p].insert(place, {frames_[frame], dense_[frame][p], tangent_, tangent_});
            added = true;
        }
    }

    void update(std::size_t p, std::size_t from, std::size_t to)
    {
        const AnimCurve c = AnimCurve::build(keys[p]);
        for (std::size_t f = from; f <= to; ++f) {
            const double value = c.evaluate(frames_[f]);
            if (value == values[f][p]) continue;
            values[f][p] = value;
            errors[f] = comparison_.measure(f, values[f]);
        }
    }

    Comparison& comparison_;
    std::span<const double> frames_;
    const std::vector<std::vector<double>>& dense_;
    TangentType tangent_;
    std::vector<RigParameter> parameters_;
};

bool allWithin(const std::vector<FrameError>& errors)
{
    return std::all_of(errors.begin(), errors.end(), [](const FrameError& e) { return e.normalized <= 1.0; });
}

}  // namespace

void KeyReductionOptions::validate() const
{
    if (!(toleranceCm >= minToleranceCm) || !std::isfinite(toleranceCm))
        throw Error(fmt::format("toleranceCm must be a number of at least {}, got {}", minToleranceCm, toleranceCm));
    if (!(toleranceDeg >= minToleranceDeg) || !std::isfinite(toleranceDeg))
        throw Error(fmt::format("toleranceDeg must be a number of at least {}, got {}", minToleranceDeg, toleranceDeg));
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
    const std::size_t parameters = dense.front().size();
    const std::vector<RigParameter> limits = parametersOf(rig);
    const LinearErrors linear(rig.approximation(), dense, options);
    report(0.05);

    // Keys taken out while the predicted errors allow, the bound raised by steps so that the tolerance is
    // shared by the curves rather than spent by the first ones; then keys moved to where they serve better and
    // more taken out, while that takes out one key in a hundred.
    KeyFit fit(linear, frames, dense, limits, options.tangent);
    for (std::size_t b = 0; b < bounds.size(); ++b) {
        fit.takeOut(bounds[b]);
        report(0.05 + 0.5 * static_cast<double>(b + 1) / static_cast<double>(bounds.size()));
    }
    for (int round = 0; round < maxMoveRounds; ++round) {
        fit.move();
        const std::size_t removed = fit.takeOut(bounds.back());
        report(0.55 + 0.4 * static_cast<double>(round + 1) / maxMoveRounds);
        if (removed * 100 < fit.keyCount()) break;
    }

    // Then the real rig decides: while a frame is over the tolerance, the control that moves its worst joint
    // most there goes back to its dense value at that frame.
    Comparison comparison(rig, dense, options);
    KeyedState state(comparison, frames, dense, rig, options.tangent);
    state.reset(std::move(fit.keys));
    while (true) {
        const auto worst =
            std::max_element(state.errors.begin(), state.errors.end(),
                             [](const FrameError& a, const FrameError& b) { return a.normalized < b.normalized; });
        if (worst->normalized <= 1.0) break;
        const auto f = static_cast<std::size_t>(worst - state.errors.begin());
        std::size_t chosen = parameters;
        double largest = -1.0;
        for (std::size_t p = 0; p < parameters; ++p) {
            const double miss = std::abs(state.values[f][p] - dense[f][p]);
            if (miss == 0.0) continue;
            // A control the linear model misses still counts, below every one it sees.
            const double effect = std::max(linear.effect(f, p, worst->worstNormalized) * miss, miss * 1e-12);
            if (effect > largest) {
                largest = effect;
                chosen = p;
            }
        }
        // Every control on its dense value is the dense pose, whose error is none.
        if (chosen == parameters) throw internalError("reduceKeys: a frame on the dense values is off the tolerance");
        state.pin(chosen, f);
    }
    report(1.0);

    KeyedCurves out;
    out.keys = std::move(state.keys);
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
    const std::vector<RigParameter> limits = parametersOf(rig);
    const LinearErrors linear(rig.approximation(), dense, options);
    Comparison comparison(rig, dense, options);
    KeyedState state(comparison, frames, dense, rig, options.tangent);
    const std::size_t n = frames.size();
    UniformKeys out;
    // The keys every `step` frames fitted as reduceKeys fits its own: every other key taken out, or the step
    // fails.
    const auto keysEvery = [&](std::size_t step) {
        KeyFit fit(linear, frames, dense, limits, options.tangent);
        const auto offStep = [&](std::size_t, double x) {
            const auto f = static_cast<std::size_t>(std::lower_bound(frames.begin(), frames.end(), x) - frames.begin());
            return f % step != 0 && f + 1 != n;
        };
        std::size_t left = 0;
        for (const double bound : bounds) fit.takeOut(bound, offStep);
        // Once the others have gone, a key that had to stay may go too.
        while (fit.takeOut(bounds.back(), offStep) > 0) {
        }
        for (std::size_t p = 0; p < fit.keys.size(); ++p)
            for (const AnimKey& key : fit.keys[p]) left += offStep(p, key.x) ? 1 : 0;
        if (left > 0) return false;
        state.reset(std::move(fit.keys));
        if (!allWithin(state.errors)) return false;
        out.step = static_cast<int>(step);
        out.keyCount = 0;
        out.constantCurves = 0;
        for (const auto& k : state.keys) {
            out.keyCount += k.size();
            out.constantCurves += k.size() == 1 ? 1 : 0;
        }
        out.error = summarize(state.errors);
        return true;
    };
    // Every frame keyed is the dense pose: step 1 is within any tolerance.
    keysEvery(1);
    std::size_t good = 1, bad = 0;
    for (std::size_t step = 2; good + 1 < n; step *= 2) {
        const std::size_t capped = std::min(step, n - 1);
        if (!keysEvery(capped)) {
            bad = capped;
            break;
        }
        good = capped;
    }
    while (bad > good + 1) {
        const std::size_t step = (good + bad) / 2;
        if (keysEvery(step)) good = step;
        else bad = step;
        if (options.progress) options.progress(1.0 - static_cast<double>(bad - good) / static_cast<double>(n));
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
