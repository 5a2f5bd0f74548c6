#include "inversion/learn/classifier.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include <fmt/format.h>
#include <Eigen/Dense>

#include "core/error.h"
#include "core/rotation_math.h"

namespace rig {

RigProbe::RigProbe(RigFunction& rig) : rig_(rig)
{
    for (const auto& p : rig.parameters()) defaults_.push_back(p.defaultValue);
    values_ = defaults_;
    rig_.evaluate(values_, rest_);
}

const std::vector<Eigen::Matrix4d>& RigProbe::at(int i, double a)
{
    values_ = defaults_;
    if (i >= 0) values_[static_cast<std::size_t>(i)] += a;
    rig_.evaluate(values_, worlds_);
    return worlds_;
}

const std::vector<Eigen::Matrix4d>& RigProbe::atValues(const std::vector<double>& values)
{
    rig_.evaluate(values, worlds_);
    return worlds_;
}

Eigen::Matrix4d RigProbe::inFrame(int k, const Eigen::Matrix4d& world, const Eigen::Matrix4d& parentWorld) const
{
    const int p = parentOf(k);
    if (p < 0) return world;
    // F_p(0) W_p^-1 W_k, with the affine inverse of W_p.
    const Eigen::Matrix3d inverse = parentWorld.block<3, 3>(0, 0).inverse();
    Eigen::Matrix4d local = Eigen::Matrix4d::Identity();
    local.block<3, 3>(0, 0) = inverse * world.block<3, 3>(0, 0);
    local.block<3, 1>(0, 3) = inverse * (world.block<3, 1>(0, 3) - parentWorld.block<3, 1>(0, 3));
    return rest_[static_cast<std::size_t>(p)] * local;
}

Eigen::Matrix4d RigProbe::inFrame(int k, const std::vector<Eigen::Matrix4d>& worlds) const
{
    return inFrame(k, [&](int j) -> const Eigen::Matrix4d& { return worlds[static_cast<std::size_t>(j)]; });
}

std::vector<int> RigProbe::frameInputs(int k) const
{
    if (const auto c = constraints.find(k); c != constraints.end()) {
        std::vector<int> inputs;
        for (const int i : c->second.frameInputs())
            if (i >= 0) inputs.push_back(i);
        return inputs;
    }
    const int p = parentOf(k);
    return p < 0 ? std::vector<int>{} : std::vector<int>{p};
}

Eigen::Matrix4d RigProbe::inConstraintFrame(const ConstraintBase& base, const Eigen::Matrix4d& world,
                                            const Eigen::Matrix4d& anchorWorld, const Eigen::Matrix4d& secondWorld,
                                            const Eigen::Matrix4d& thirdWorld, const Eigen::Matrix4d& orientWorld) const
{
    const auto motion = [&](int i, const Eigen::Matrix4d& world) -> Eigen::Matrix4d {
        return i < 0 ? Eigen::Matrix4d(Eigen::Matrix4d::Identity())
                     : Eigen::Matrix4d(world * rest_[static_cast<std::size_t>(i)].inverse());
    };
    const Eigen::Matrix4d b = constraintBase(base, motion(base.anchor, anchorWorld), secondWorld, thirdWorld,
                                             motion(base.orient, orientWorld));
    Eigen::Matrix4d inverse = Eigen::Matrix4d::Identity();  // b is rigid (or not finite: the sample says so)
    inverse.block<3, 3>(0, 0) = b.block<3, 3>(0, 0).transpose();
    inverse.block<3, 1>(0, 3) = -inverse.block<3, 3>(0, 0) * b.block<3, 1>(0, 3);
    return inverse * world;
}

const Eigen::Matrix4d& ParameterSamples::world(int k, double a, const std::vector<Eigen::Matrix4d>& rest) const
{
    const auto it = std::lower_bound(moved.begin(), moved.end(), k);
    if (it == moved.end() || *it != k) return rest[static_cast<std::size_t>(k)];
    return worlds.at(a)[static_cast<std::size_t>(it - moved.begin())];
}

namespace {

constexpr double structureTolerance = 1e-8;

// A candidate model of a parameter: operators and, per affected output, which one.
struct Candidate {
    std::vector<Operator> operators;
    std::vector<int> operatorOfOutput;
    std::string form;
};

struct Context {
    RigProbe& probe;
    int index;
    const LearnOptions& options;
    ParameterSamples& store;
    std::vector<int> outputs;           // affected outputs (in their frames)
    std::vector<Eigen::Matrix4d> rest;  // their rest matrices
    std::vector<Eigen::Matrix4d> restInverse;
    std::map<double, std::vector<Eigen::Matrix4d>> framed;  // offset -> affected outputs in their frames
    std::vector<double> initial;  // the first, evenly spread offsets: every curve's first knots
    bool nonFinite = false;       // a sample gave a non-finite matrix
    // Offsets beyond which the control is saturated (Operator::low, high): fits use the range between.
    double low = -std::numeric_limits<double>::infinity();
    double high = std::numeric_limits<double>::infinity();
    // The ends of the flat stretches inside the range (a foot roll's heel keyed below 0, its toe above 5: nothing
    // moves between): kinks that every curve of the parameter takes as breaks (CubicSpline) instead of rounding.
    std::vector<double> breaks{};

    bool acting(double a) const { return a >= low && a <= high; }
    std::vector<double> acting(const std::vector<double>& offsets) const
    {
        std::vector<double> inside;
        for (double a : offsets)
            if (acting(a)) inside.push_back(a);
        return inside;
    }
    void hold(Operator& op) const
    {
        op.low = low;
        op.high = high;
    }

    // The affected outputs in their frames at offset a: from the stored raw sample, or a new one.
    const std::vector<Eigen::Matrix4d>& sample(double a)
    {
        auto it = framed.find(a);
        if (it != framed.end()) return it->second;
        if (!store.worlds.contains(a)) {
            const auto& all = probe.at(index, a);
            std::vector<Eigen::Matrix4d> raw;
            for (int k : store.moved) raw.push_back(all[static_cast<std::size_t>(k)]);
            store.worlds.emplace(a, std::move(raw));
        }
        const auto& rigRest = probe.rest();
        std::vector<Eigen::Matrix4d> mine;
        for (int k : outputs) {
            mine.push_back(
                probe.inFrame(k, [&](int j) -> const Eigen::Matrix4d& { return store.world(j, a, rigRest); }));
            nonFinite = nonFinite || !mine.back().allFinite();
        }
        return framed.emplace(a, std::move(mine)).first->second;
    }
    // Every sample so far, in the frames.
    const std::map<double, std::vector<Eigen::Matrix4d>>& all()
    {
        for (const auto& entry : store.worlds) sample(entry.first);
        return framed;
    }
    bool has(double a) const { return store.worlds.contains(a); }
    Eigen::Matrix4d delta(double a, std::size_t e) { return sample(a)[e] * restInverse[e]; }
    int sampleCount() const { return static_cast<int>(store.worlds.size()); }
};

// `count` offsets spread over [lo, hi], split between the two sides of the rest value. An angle is
// sampled at least every 90 degrees, so that rotation angles can be unwrapped along the samples
// (neighbouring samples less than half a turn apart) when its range is wider than +-180 degrees.
std::vector<double> initialOffsets(double lo, double hi, int count, bool angular)
{
    const double step = std::numbers::pi / 2;
    auto atLeast = [&](int n, double span) {
        return angular ? std::max(n, static_cast<int>(std::ceil(std::abs(span) / step))) : n;
    };
    std::vector<double> offsets;
    if (lo < 0 && hi > 0) {
        const int negative = atLeast(std::max(1, count / 2), lo);
        const int positive = atLeast(std::max(1, count - count / 2), hi);
        for (int j = negative; j >= 1; --j) offsets.push_back(lo * j / negative);
        for (int j = 1; j <= positive; ++j) offsets.push_back(hi * j / positive);
    } else {
        const double end = hi > 0 ? hi : lo;
        const int n = atLeast(count, end);
        for (int j = 1; j <= n; ++j) offsets.push_back(end * j / n);
    }
    return offsets;
}

// Rotation angles of samples sorted by offset, unwrapped outward from 0 (where the angle is 0): each
// is moved by whole turns to be closest to its neighbour nearer the rest value. A rotation vector
// only gives angles in [-pi, pi]; a driven joint may turn further.
void unwrapAngles(std::map<double, double>& angles)
{
    double previous = 0.0;
    for (auto it = angles.lower_bound(0.0); it != angles.end(); ++it)
        previous = it->second = nearestTurn(it->second, previous);
    previous = 0.0;
    for (auto it = std::make_reverse_iterator(angles.lower_bound(0.0)); it != angles.rend(); ++it)
        previous = it->second = nearestTurn(it->second, previous);
}

Eigen::Matrix3d linearPart(const Eigen::Matrix4d& m) { return m.block<3, 3>(0, 0); }

// Which analytic kinds the deltas allow.
std::vector<OperatorKind> plausibleKinds(Context& c, const std::vector<std::size_t>& entries)
{
    bool identity = true, rigid = true, symmetric = true;
    for (const auto& [a, worlds] : c.all())
        for (std::size_t e : entries) {
            const Eigen::Matrix3d l = linearPart(worlds[e] * c.restInverse[e]);
            identity = identity && (l - Eigen::Matrix3d::Identity()).norm() < structureTolerance;
            rigid = rigid && (l.transpose() * l - Eigen::Matrix3d::Identity()).norm() < structureTolerance &&
                    l.determinant() > 0;
            symmetric = symmetric && (l - l.transpose()).norm() < structureTolerance;
        }
    if (identity) return {OperatorKind::translation};
    std::vector<OperatorKind> kinds;
    if (rigid) kinds.push_back(OperatorKind::rotation);
    if (symmetric) kinds.insert(kinds.end(), {OperatorKind::uniformScale, OperatorKind::axisScale});
    return kinds;
}

// The sample offset of largest magnitude (the clearest view of the structure).
double largestOffset(const Context& c)
{
    double best = 0.0;
    for (const auto& entry : c.store.worlds)
        if (std::abs(entry.first) > std::abs(best)) best = entry.first;
    return best;
}

// Least-squares solution of stacked rows (A_j p = b_j), minimum norm, then moved along the null space
// (the rotation axis, or the plane a scale leaves alone) as close as possible to `near`.
Eigen::Vector3d solvePivot(const std::vector<Eigen::Matrix3d>& a, const std::vector<Eigen::Vector3d>& b,
                           const Eigen::Vector3d& near)
{
    Eigen::MatrixXd m(3 * a.size(), 3);
    Eigen::VectorXd r(3 * a.size());
    for (std::size_t j = 0; j < a.size(); ++j) {
        m.block<3, 3>(static_cast<Eigen::Index>(3 * j), 0) = a[j];
        r.segment<3>(static_cast<Eigen::Index>(3 * j)) = b[j];
    }
    const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> solver(m);
    const Eigen::Vector3d p0 = solver.solve(r);
    // Project `near - p0` onto the null space of m.
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(m, Eigen::ComputeFullV);
    Eigen::Vector3d shift = Eigen::Vector3d::Zero();
    const double top = svd.singularValues().size() ? svd.singularValues()[0] : 0.0;
    for (int k = 0; k < 3; ++k)
        if (svd.singularValues()[k] <= 1e-9 * std::max(1.0, top)) {
            const Eigen::Vector3d v = svd.matrixV().col(k);
            shift += v * v.dot(near - p0);
        }
    return p0 + shift;
}

// The pivot a linear map L about it leaves fixed, from every sample of these outputs: the least-squares solution
// of (I - L_j) p = t_j, moved along what the rows leave free toward `near`.
Eigen::Vector3d fitPivot(Context& c, const std::vector<std::size_t>& entries, const Eigen::Vector3d& near)
{
    std::vector<Eigen::Matrix3d> rows;
    std::vector<Eigen::Vector3d> rhs;
    for (const auto& entry : c.all())
        for (std::size_t e : entries) {
            const Eigen::Matrix4d de = c.delta(entry.first, e);
            rows.push_back(Eigen::Matrix3d::Identity() - linearPart(de));
            rhs.push_back(de.block<3, 1>(0, 3));
        }
    return solvePivot(rows, rhs, near);
}

// A translation's axis from the widest sample of output e0, and its magnitudes along it.
bool fitTranslation(Context& c, std::size_t e0, double widest, Operator& op, std::map<double, double>& magnitudes)
{
    const Eigen::Vector3d t = c.delta(widest, e0).block<3, 1>(0, 3);
    if (t.norm() < 1e-12) return false;
    op.axis = t.normalized() * (widest < 0 ? -1.0 : 1.0);
    for (const auto& entry : c.all()) magnitudes[entry.first] = c.delta(entry.first, e0).block<3, 1>(0, 3).dot(op.axis);
    return true;
}

// A rotation's axis from the sample of largest angle short of half a turn, where the rotation vector's direction
// is unambiguous (at half a turn its sign is arbitrary); its magnitude has the sign of its offset. Angles
// unwrapped; the pivot from every output.
bool fitRotation(Context& c, const std::vector<std::size_t>& entries, const Eigen::Vector3d& near, Operator& op,
                 std::map<double, double>& magnitudes)
{
    const std::size_t e0 = entries.front();
    double reference = 0.0, referenceAngle = -1.0;
    Eigen::Vector3d r = Eigen::Vector3d::Zero();
    for (const auto& entry : c.all()) {
        const Eigen::Vector3d v = rotationVector(linearPart(c.delta(entry.first, e0)));
        const double angle = v.norm();
        const bool better = angle <= 0.9 * std::numbers::pi
                                ? (referenceAngle > 0.9 * std::numbers::pi || angle > referenceAngle)
                                : referenceAngle < 0.0;
        if (better) {
            reference = entry.first;
            referenceAngle = angle;
            r = v;
        }
    }
    if (r.norm() < 1e-12) return false;
    op.axis = r.normalized() * (reference < 0 ? -1.0 : 1.0);
    for (const auto& entry : c.all())
        magnitudes[entry.first] = rotationVector(linearPart(c.delta(entry.first, e0))).dot(op.axis);
    unwrapAngles(magnitudes);
    op.pivot = fitPivot(c, entries, near);
    return true;
}

// An axis scale's axis: the eigenvector of the widest sample's largest stretch; the pivot from every output.
bool fitAxisScale(Context& c, const std::vector<std::size_t>& entries, double widest, const Eigen::Vector3d& near,
                  Operator& op, std::map<double, double>& magnitudes)
{
    const std::size_t e0 = entries.front();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(linearPart(c.delta(widest, e0)) -
                                                             Eigen::Matrix3d::Identity());
    int k = 0;
    eig.eigenvalues().cwiseAbs().maxCoeff(&k);
    if (std::abs(eig.eigenvalues()[k]) < 1e-12) return false;
    op.axis = eig.eigenvectors().col(k).normalized();
    for (const auto& entry : c.all())
        magnitudes[entry.first] =
            op.axis.dot((linearPart(c.delta(entry.first, e0)) - Eigen::Matrix3d::Identity()) * op.axis);
    op.pivot = fitPivot(c, entries, near);
    return true;
}

// A uniform scale's magnitude from the trace; the pivot from every output.
bool fitUniformScale(Context& c, const std::vector<std::size_t>& entries, double widest, const Eigen::Vector3d& near,
                     Operator& op, std::map<double, double>& magnitudes)
{
    for (const auto& entry : c.all())
        magnitudes[entry.first] = linearPart(c.delta(entry.first, entries.front())).trace() / 3.0 - 1.0;
    if (std::abs(magnitudes[widest]) < 1e-12) return false;
    op.pivot = fitPivot(c, entries, near);
    return true;
}

// Structure (axis, pivot) of an analytic kind from all samples of these outputs, and the magnitude
// at each offset. Returns false when the data do not determine it.
bool fitStructure(Context& c, OperatorKind kind, const std::vector<std::size_t>& entries, Operator& op,
                  std::map<double, double>& magnitudes)
{
    op = Operator{};
    op.kind = kind;
    const double widest = largestOffset(c);
    const Eigen::Vector3d near = c.rest[entries.front()].block<3, 1>(0, 3);
    switch (kind) {
        case OperatorKind::translation:
            return fitTranslation(c, entries.front(), widest, op, magnitudes);
        case OperatorKind::rotation:
            return fitRotation(c, entries, near, op, magnitudes);
        case OperatorKind::axisScale:
            return fitAxisScale(c, entries, widest, near, op, magnitudes);
        case OperatorKind::uniformScale:
            return fitUniformScale(c, entries, widest, near, op, magnitudes);
        default:
            return false;
    }
}

// Worst error over the samples at these offsets, per unit of the parameter.
// The worst error per unit moved at `offsets`; into `failing`, the offsets where it is over epsilon or the frame
// error itself over the absolute tolerance (LearnOptions::absoluteTolerance).
double errorAt(Context& c, const Candidate& candidate, const std::vector<std::size_t>& entries,
               const std::vector<double>& offsets, std::vector<double>* failing = nullptr)
{
    double worst = 0.0;
    for (double a : offsets) {
        if (a == 0.0) continue;
        double here = 0.0, absolute = 0.0;
        for (std::size_t e : entries) {
            const Operator& op = candidate.operators[static_cast<std::size_t>(candidate.operatorOfOutput[e])];
            const Eigen::Matrix4d predicted = op.matrix(a) * c.rest[e];
            const double error = matrixError(predicted, c.sample(a)[e], c.options.frameRadius);
            here = std::max(here, error / std::abs(a));
            absolute = std::max(absolute, error);
        }
        if (failing && (here > c.options.epsilon || absolute > c.options.absoluteTolerance)) failing->push_back(a);
        worst = std::max(worst, here);
    }
    return worst;
}

std::vector<double> sampledOffsets(const Context& c)
{
    std::vector<double> offsets;
    for (const auto& entry : c.store.worlds) offsets.push_back(entry.first);
    return offsets;
}

// Midpoints between consecutive knots (0 included) that have not been sampled yet.
std::vector<double> midpoints(const std::vector<double>& knots)
{
    std::vector<double> sorted = knots;
    sorted.push_back(0.0);
    std::sort(sorted.begin(), sorted.end());
    sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
    std::vector<double> mids;
    for (std::size_t j = 1; j < sorted.size(); ++j) mids.push_back(0.5 * (sorted[j - 1] + sorted[j]));
    return mids;
}

using Builder = std::function<bool(const std::vector<double>& knots, Candidate&)>;

// Fits with `build` on the knots, checks every sample and the midpoints between knots, and refines
// by turning failing samples into knots until it validates or nothing new can be learned. A curve
// starts from the initial offsets as knots, whatever earlier fits sampled: their samples are checks
// that cost nothing, and new samples are taken only around this fit's own failures. The budget is per
// parameter: midpoints are sampled only while the parameter has used fewer than maxSamples (beyond
// that only samples already taken are checked), so fitting many outputs one by one cannot multiply
// the rig evaluations.
// `curved` false: a form without knots (linear), checked on the samples only.
bool refineAndValidate(Context& c, const std::vector<std::size_t>& entries, bool curved, const Builder& build,
                       Candidate& best, double& bestError)
{
    std::vector<double> knots = curved ? c.initial : sampledOffsets(c);
    std::sort(knots.begin(), knots.end());
    while (true) {
        Candidate candidate;
        if (!build(knots, candidate)) return false;
        std::vector<double> checks = sampledOffsets(c);
        if (curved)
            for (double m : midpoints(knots)) {
                if (c.has(m)) continue;  // already among the checks
                if (c.sampleCount() >= c.options.maxSamples) break;
                c.sample(m);
                checks.push_back(m);
            }
        std::vector<double> failing;
        const double error = errorAt(c, candidate, entries, checks, &failing);
        if (error < bestError) {
            bestError = error;
            best = candidate;
        }
        // Within epsilon, a curve is refined on to the absolute tolerance while every check that misses it lies between
        // knots (new checks sampled while the budget allows); a miss at a knot is the form's, which knots cannot help.
        const auto isKnot = [&](double a) { return std::find(knots.begin(), knots.end(), a) != knots.end(); };
        const bool atKnot = std::any_of(failing.begin(), failing.end(), isKnot);
        if (error <= c.options.epsilon && (!curved || failing.empty() || atKnot)) return true;
        if (!curved) return false;
        // A curve goes through its knots: missing at one, the form itself misses (a pivot that moves,
        // an axis that turns), and more knots cannot help. Give up before spending the budget.
        if (atKnot) return false;
        knots.insert(knots.end(), failing.begin(), failing.end());
        std::sort(knots.begin(), knots.end());
    }
}

// The spline through (x, y), x increasing, with a break at each knot of `breaks` inside its ends.
template <int D>
CubicSpline<D> withBreaks(const std::vector<double>& x, const std::vector<typename CubicSpline<D>::Vector>& y,
                          const std::vector<double>& breaks)
{
    std::vector<double> xs;
    std::vector<typename CubicSpline<D>::Vector> ys;
    for (std::size_t j = 0; j < x.size(); ++j) {
        const bool inside = j > 0 && j + 1 < x.size();
        const int copies = inside && std::find(breaks.begin(), breaks.end(), x[j]) != breaks.end() ? 2 : 1;
        for (int k = 0; k < copies; ++k) {
            xs.push_back(x[j]);
            ys.push_back(y[j]);
        }
    }
    return CubicSpline<D>(std::move(xs), std::move(ys));
}

CubicSpline<1> magnitudeCurve(const std::map<double, double>& magnitudes, const std::vector<double>& knots,
                              const std::vector<double>& breaks)
{
    std::vector<double> x{0.0};
    std::vector<CubicSpline<1>::Vector> y{CubicSpline<1>::Vector::Zero()};
    for (double a : knots) {
        x.push_back(a);
        y.push_back(CubicSpline<1>::Vector(magnitudes.at(a)));
    }
    std::vector<std::size_t> order(x.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::size_t p, std::size_t q) { return x[p] < x[q]; });
    std::vector<double> xs;
    std::vector<CubicSpline<1>::Vector> ys;
    for (std::size_t i : order) {
        xs.push_back(x[i]);
        ys.push_back(y[i]);
    }
    return withBreaks<1>(xs, ys, breaks);
}

// An analytic operator shared by `entries`, linear then with a curve magnitude.
bool tryAnalytic(Context& c, OperatorKind kind, const std::vector<std::size_t>& entries, Candidate& best,
                 double& bestError, std::string& form)
{
    auto makeCandidate = [&](const Operator& op) {
        Candidate candidate;
        candidate.operators = {op};
        candidate.operatorOfOutput.assign(c.outputs.size(), 0);
        return candidate;
    };
    const Builder linear = [&](const std::vector<double>&, Candidate& candidate) {
        Operator op;
        std::map<double, double> m;
        if (!fitStructure(c, kind, entries, op, m)) return false;
        double num = 0.0, den = 0.0;
        for (const auto& [a, value] : m)
            if (c.acting(a)) {
                num += value * a;
                den += a * a;
            }
        op.slope = num / den;
        c.hold(op);
        candidate = makeCandidate(op);
        return true;
    };
    if (refineAndValidate(c, entries, false, linear, best, bestError)) {
        form = std::string(operatorKindName(kind));
        return true;
    }
    const Builder curve = [&](const std::vector<double>& knots, Candidate& candidate) {
        Operator op;
        std::map<double, double> m;
        if (!fitStructure(c, kind, entries, op, m)) return false;
        op.curve = magnitudeCurve(m, c.acting(knots), c.breaks);
        c.hold(op);
        candidate = makeCandidate(op);
        return true;
    };
    if (refineAndValidate(c, entries, true, curve, best, bestError)) {
        form = fmt::format("{} (curve)", operatorKindName(kind));
        return true;
    }
    return false;
}

// A sampled operator of one output: rigid (rotation vector and translation) or affine.
bool trySampled(Context& c, std::size_t e, bool rigid, Candidate& best, double& bestError)
{
    const std::vector<std::size_t> entries{e};
    const Builder build = [&](const std::vector<double>& knots, Candidate& candidate) {
        std::vector<double> xs = c.acting(knots);
        xs.push_back(0.0);
        std::sort(xs.begin(), xs.end());
        Operator op;
        op.kind = rigid ? OperatorKind::sampledRigid : OperatorKind::sampledAffine;
        if (rigid) {
            // Rotation vectors unwrapped outward from 0, so the curve does not jump at 180 degrees.
            std::vector<CubicSpline<6>::Vector> ys(xs.size());
            const auto zero = std::find(xs.begin(), xs.end(), 0.0) - xs.begin();
            auto value = [&](std::ptrdiff_t i, const Eigen::Vector3d& previous) {
                CubicSpline<6>::Vector v = CubicSpline<6>::Vector::Zero();
                if (xs[static_cast<std::size_t>(i)] == 0.0) return v;
                const Eigen::Matrix4d d = c.delta(xs[static_cast<std::size_t>(i)], e);
                Eigen::Vector3d r = rotationVector(linearPart(d));
                if (r.norm() > 1e-12) {
                    const Eigen::Vector3d other = r - 2.0 * std::numbers::pi * r.normalized();
                    if ((other - previous).norm() < (r - previous).norm()) r = other;
                }
                v.head<3>() = r;
                v.tail<3>() = d.block<3, 1>(0, 3);
                return v;
            };
            ys[static_cast<std::size_t>(zero)] = CubicSpline<6>::Vector::Zero();
            for (auto i = zero + 1; i < static_cast<std::ptrdiff_t>(xs.size()); ++i)
                ys[static_cast<std::size_t>(i)] = value(i, ys[static_cast<std::size_t>(i - 1)].head<3>());
            for (auto i = zero - 1; i >= 0; --i)
                ys[static_cast<std::size_t>(i)] = value(i, ys[static_cast<std::size_t>(i + 1)].head<3>());
            op.rigid = withBreaks<6>(xs, ys, c.breaks);
        } else {
            std::vector<CubicSpline<12>::Vector> ys;
            for (double a : xs) {
                CubicSpline<12>::Vector v = CubicSpline<12>::Vector::Zero();
                if (a != 0.0) {
                    const Eigen::Matrix4d d = c.delta(a, e) - Eigen::Matrix4d::Identity();
                    for (int r = 0; r < 3; ++r)
                        for (int col = 0; col < 4; ++col) v[4 * r + col] = d(r, col);
                }
                ys.push_back(v);
            }
            op.affine = withBreaks<12>(xs, ys, c.breaks);
        }
        c.hold(op);
        candidate.operators = {op};
        candidate.operatorOfOutput.assign(c.outputs.size(), 0);
        return true;
    };
    return refineAndValidate(c, entries, true, build, best, bestError);
}

// Bisection steps to a flat range's end: from the neighbouring samples' distance to 1/256 of it where the range
// reaches an end of the parameter's range (the operators are held beyond, as they always were), and to 2^-24 of it
// (1.5e-7 of a 2.5-unit spacing: 1.5e-5 cm at 100 cm per unit, negligible against the solver's 1e-3 cm) where the
// range is inside it, since its ends become breaks of the curves and a break found off the kink leaves the curve off
// by the slope times the distance (tests/inversion/learn/learner_test.cpp's foot: its toe moves the ankle 2.8 cm per
// unit of roll, 0.04 cm at 1/256 of the 3.3-unit spacing). Each such range costs up to 32 more rig evaluations.
constexpr int heldEndBisections = 8;
constexpr int breakBisections = 24;

// Ranges of offsets between neighbouring samples (0 included) over which no output moves: where the
// control is saturated, or a stretch in the middle of its range where it does nothing (a foot roll between the
// heel's keys and the toe's). Their ends are found by bisection (above); lo and hi are the parameter's range.
std::vector<std::pair<double, double>> flatRanges(Context& c, const std::vector<Eigen::Matrix4d>& restFramed, double lo,
                                                  double hi)
{
    // References stay valid: the samples are kept in a std::map, which never moves its elements.
    auto worldsAt = [&](double a) -> const std::vector<Eigen::Matrix4d>& {
        return a == 0.0 ? restFramed : c.sample(a);
    };
    auto same = [&](double a, double b) {
        const auto& wa = worldsAt(a);
        const auto& wb = worldsAt(b);
        for (std::size_t e = 0; e < wa.size(); ++e)
            if (matrixError(wa[e], wb[e], c.options.frameRadius) > c.options.effectTolerance) return false;
        return true;
    };
    std::vector<double> xs = c.initial;
    xs.push_back(0.0);
    std::sort(xs.begin(), xs.end());
    std::vector<std::pair<double, double>> ranges;
    for (std::size_t j = 0; j + 1 < xs.size(); ++j) {
        if (!same(xs[j], xs[j + 1])) continue;
        if (!ranges.empty() && ranges.back().second == xs[j]) ranges.back().second = xs[j + 1];
        else ranges.emplace_back(xs[j], xs[j + 1]);
    }
    // Where the movement stops, between a moving sample and the flat range's end `flat`, flat as `other` (its other
    // end) is: a sampled offset, so that a curve's knot can be there.
    auto bisect = [&](double moving, double flat, double other, int steps) {
        for (int step = 0; step < steps; ++step) {
            const double mid = 0.5 * (moving + flat);
            (same(mid, other) ? flat : moving) = mid;
        }
        return flat;
    };
    // A flat range that starts after a moving stretch: bisect where the movement stops (and likewise
    // at its other end).
    for (auto& [from, to] : ranges) {
        const int steps = (from == lo && from < 0.0) || (to == hi && to > 0.0) ? heldEndBisections : breakBisections;
        const auto below = std::find(xs.begin(), xs.end(), from);
        const auto above = std::find(xs.begin(), xs.end(), to);
        if (below != xs.begin()) from = bisect(*(below - 1), from, to, steps);
        if (above + 1 != xs.end()) to = bisect(*(above + 1), to, from, steps);
    }
    return ranges;
}

}  // namespace

void takeFirstSamples(RigFunction& rig, int index, const std::vector<Eigen::Matrix4d>& rest,
                      const LearnOptions& options, ParameterSamples& samples)
{
    const RigParameter& parameter = rig.parameters()[static_cast<std::size_t>(index)];
    const double lo = parameter.min - parameter.defaultValue;
    const double hi = parameter.max - parameter.defaultValue;
    if (!(hi > lo) || (lo == 0.0 && hi == 0.0)) return;
    std::vector<double> values;
    for (const auto& p : rig.parameters()) values.push_back(p.defaultValue);
    std::map<double, std::vector<Eigen::Matrix4d>> all;
    for (double a : initialOffsets(lo, hi, options.samples, parameter.angular)) {
        values[static_cast<std::size_t>(index)] = parameter.defaultValue + a;
        rig.evaluate(values, all[a]);
    }
    values[static_cast<std::size_t>(index)] = parameter.defaultValue;
    std::vector<Eigen::Matrix4d> restAfter;
    rig.evaluate(values, restAfter);
    // Most outputs of a large rig are the rest world bit for bit (not recomputed): told by comparing, before measuring.
    auto atRest = [&](const Eigen::Matrix4d& world, std::size_t k) { return world == rest[k] && world.allFinite(); };
    for (std::size_t k = 0; k < rest.size(); ++k)
        if (const double moved =
                atRest(restAfter[k], k) ? 0.0 : matrixError(restAfter[k], rest[k], options.frameRadius);
            moved > options.effectTolerance)
            samples.restMoved.emplace_back(static_cast<int>(k), moved);
    samples.taken = true;
    for (std::size_t k = 0; k < rest.size(); ++k)
        for (const auto& [a, worlds] : all)
            if (!atRest(worlds[k], k) &&
                !(matrixError(worlds[k], rest[k], options.frameRadius) <= options.effectTolerance)) {
                samples.moved.push_back(static_cast<int>(k));
                break;
            }
    for (const auto& [a, worlds] : all) {
        std::vector<Eigen::Matrix4d> raw;
        for (int k : samples.moved) raw.push_back(worlds[static_cast<std::size_t>(k)]);
        samples.worlds.emplace(a, std::move(raw));
    }
}

namespace {

// Phase 1 of classifying a parameter, from its first samples: the outputs they show history-dependent
// (marked in `state`), then its reach and largest raw effect. False, with the reason, when the rig gives
// a non-finite matrix.
bool measureEffect(RigProbe& probe, const RigParameter& parameter, const std::vector<double>& offsets, RigState& state,
                   ParameterSamples& samples, const LearnOptions& options, Classification& result)
{
    const auto& outputNames = probe.rig().outputs();
    const auto& rest = probe.rest();
    for (const auto& [k, moved] : samples.restMoved) {
        if (state.unreliable[static_cast<std::size_t>(k)]) continue;
        // Its value depends on earlier evaluations: no parameter can be modelled on it.
        state.unreliable[static_cast<std::size_t>(k)] = 1;
        if (samples.historyDependent.empty())
            samples.historyDependent = fmt::format(
                "history-dependent: after sampling it, the rest pose of {} moved by {:.3g} cm "
                "(its outputs depend on earlier evaluations, not on the parameters alone)",
                outputNames[static_cast<std::size_t>(k)], moved);
    }

    for (const int kk : samples.moved) {
        const auto k = static_cast<std::size_t>(kk);
        double raw = 0.0;
        for (double a : offsets) {
            if (!samples.world(kk, a, rest).allFinite()) {
                result.reason = fmt::format(
                    "the rig gives a non-finite matrix for {} at {} = {:g}{} (a zero scale or a "
                    "singular matrix?); give it a range where the rig is defined",
                    outputNames[k], parameter.name,
                    parameter.angular ? (parameter.defaultValue + a) * 180.0 / std::numbers::pi
                                      : parameter.defaultValue + a,
                    parameter.angular ? " degrees" : "");
                return false;
            }
            raw = std::max(raw, matrixError(samples.world(kk, a, rest), rest[k], options.frameRadius));
        }
        result.effect = std::max(result.effect, raw);
        ++result.reach;
    }
    return true;
}

// Phase 2: the outputs it moves in their frames (into `c`), the sample that the order tests use, and the
// ranges where it stops acting (the operators are held there). False, with the reason, when it moves none.
bool frameOutputs(RigProbe& probe, Context& c, double lo, double hi, const RigState& state,
                  const ParameterSamples& samples, const LearnOptions& options, Classification& result)
{
    const RigParameter& parameter = result.model.parameter;
    const auto& rest = probe.rest();
    const std::vector<double>& offsets = c.initial;
    // The affected outputs in their frames: a relative output moves when its parent-relative transform does. One
    // whose raw world and parent's stay at rest stays at rest in its frame (to rounding, far below effectTolerance):
    // only what the parameter moves, their children and the constraints' outputs are framed, not a whole crowd.
    std::vector<char> moved(rest.size(), 0);
    for (const int k : samples.moved) moved[static_cast<std::size_t>(k)] = 1;
    for (std::size_t k = 0; k < rest.size(); ++k) {
        const int kk = static_cast<int>(k);
        if (state.unreliable[k] || state.idle[k]) continue;
        const int parent = probe.parentOf(kk);
        if (!moved[k] && (parent < 0 || !moved[static_cast<std::size_t>(parent)]) && !probe.constraints.contains(kk))
            continue;
        // In a constraint's frame, what the shape's fit leaves (within its share of epsilon per unit moved) is not an
        // effect: a root that carries the chain moves nothing there.
        const double slack = probe.constraints.contains(kk) ? constraintFitShare * options.epsilon : 0.0;
        bool acts = false;
        for (double a : offsets) {
            const Eigen::Matrix4d framed =
                probe.inFrame(kk, [&](int j) -> const Eigen::Matrix4d& { return samples.world(j, a, rest); });
            acts = acts ||
                   matrixError(framed, rest[k], options.frameRadius) > options.effectTolerance + slack * std::abs(a);
        }
        if (acts) {
            c.outputs.push_back(kk);
            c.rest.push_back(rest[k]);
            c.restInverse.push_back(rest[k].inverse());
        }
    }
    if (c.outputs.empty()) {
        result.reason = !samples.historyDependent.empty()
                            ? samples.historyDependent
                            : "no effect: no output moves when it alone changes (the others at their rest values)";
        return false;
    }
    result.orderOffset = largestOffset(c);
    result.orderWorlds = c.sample(result.orderOffset);
    result.model.noEffect = flatRanges(c, c.rest, lo, hi);
    // Flat to the end of its range: the operators are held from where the effect stops, and fitted on
    // the range where the control acts (a spline would have to bend round the kink).
    for (const auto& [from, to] : result.model.noEffect) {
        if (from == lo && from < 0.0) c.low = to;
        if (to == hi && to > 0.0) c.high = from;
    }
    if (c.low > c.high) c.low = c.high = 0.0;  // flat everywhere it was sampled: nothing left to fit
    // Flat in the middle: the curves break at its ends inside the fitted range, where the effect starts or stops with
    // a kink that a natural spline through samples on both sides would round (0.2 cm off beside a foot roll's keys).
    for (const auto& [from, to] : result.model.noEffect)
        for (const double end : {from, to})
            if (end > std::max(lo, c.low) && end < std::min(hi, c.high)) c.breaks.push_back(end);
    // Every curve's first knots hold the ends where the effect stops: sampled (bisection), so the curves are exact
    // there. The rest offset 0 is a knot of every curve already.
    std::vector<double> ends{c.low, c.high};
    ends.insert(ends.end(), c.breaks.begin(), c.breaks.end());
    for (const double end : ends)
        if (std::isfinite(end) && end != 0.0 && std::find(c.initial.begin(), c.initial.end(), end) == c.initial.end())
            c.initial.push_back(end);
    for (auto& [from, to] : result.model.noEffect) {
        from += parameter.defaultValue;
        to += parameter.defaultValue;
    }
    return true;
}

// One operator for output e alone: the first analytic kind that fits, else a sampled one (rigid where the deltas
// are). False when none fits, with `error` the sampled fit's best.
bool fitOneOutput(Context& c, std::size_t e, Candidate& found, double& error, std::string& how)
{
    const std::vector<std::size_t> one{e};
    for (OperatorKind kind : plausibleKinds(c, one)) {
        Candidate candidate;
        double candidateError = std::numeric_limits<double>::infinity();
        if (tryAnalytic(c, kind, one, candidate, candidateError, how)) {
            found = candidate;
            error = candidateError;
            return true;
        }
    }
    // Asked again: the analytic fits may have taken more samples.
    const std::vector<OperatorKind> kinds = plausibleKinds(c, one);
    const bool rigid = std::any_of(kinds.begin(), kinds.end(), [](OperatorKind k) { return operatorTraits(k).rigid; });
    Candidate candidate;
    double candidateError = std::numeric_limits<double>::infinity();
    const bool ok = (rigid && trySampled(c, e, true, candidate, candidateError)) ||
                    trySampled(c, e, false, candidate, candidateError);
    error = candidateError;
    if (!ok) return false;
    found = candidate;
    how = std::string(operatorKindName(candidate.operators.front().kind));
    return true;
}

// Phase 3: the simplest operators that validate: one analytic operator for every output, else one per
// output (analytic where one fits, sampled otherwise). Sets `result` either way.
void fitOperators(Context& c, const std::vector<std::string>& outputNames, const LearnOptions& options,
                  Classification& result)
{
    const RigParameter parameter = result.model.parameter;
    std::vector<std::size_t> everyOutput(c.outputs.size());
    for (std::size_t e = 0; e < everyOutput.size(); ++e) everyOutput[e] = e;
    Candidate best;
    double bestError = std::numeric_limits<double>::infinity();
    std::string form;
    auto accept = [&](const Candidate& candidate, std::string how) {
        result.modelled = true;
        result.model.outputs = c.outputs;
        result.model.operators = candidate.operators;
        result.model.operatorOfOutput = candidate.operatorOfOutput;
        result.model.form = std::move(how);
        result.model.samples = c.sampleCount();
    };

    // 1. One analytic operator for every affected output.
    for (OperatorKind kind : plausibleKinds(c, everyOutput)) {
        Candidate candidate;
        double error = std::numeric_limits<double>::infinity();
        if (tryAnalytic(c, kind, everyOutput, candidate, error, form)) {
            result.model.fitError = error;
            accept(candidate, form);
            return;
        }
        if (error < bestError) bestError = error;
    }

    // 2. One operator per output: analytic where one fits, sampled otherwise.
    Candidate perOutput;
    perOutput.operatorOfOutput.assign(c.outputs.size(), 0);
    std::map<std::string, int> forms;
    double worst = 0.0;
    for (std::size_t e = 0; e < c.outputs.size(); ++e) {
        Candidate found;
        double error = std::numeric_limits<double>::infinity();
        std::string how;
        if (!fitOneOutput(c, e, found, error, how)) {
            const std::string& output = outputNames[static_cast<std::size_t>(c.outputs[e])];
            result.reason = c.nonFinite ? fmt::format(
                                              "the rig gives a non-finite matrix for {} within its range (a zero scale "
                                              "or a singular matrix?); give it a range where the rig is defined",
                                              output)
                                        : fmt::format(
                                              "no operator fits within epsilon {:g}: the best error is {:.3g} cm per "
                                              "unit on {} after {} samples",
                                              options.epsilon, std::min(bestError, error), output, c.sampleCount());
            result.failedOutput = c.outputs[e];
            result.model = ModelledParameter{};
            result.model.parameter = parameter;
            return;
        }
        perOutput.operatorOfOutput[e] = static_cast<int>(perOutput.operators.size());
        perOutput.operators.push_back(found.operators.front());
        ++forms[how];
        worst = std::max(worst, error);
    }
    std::string description = "per output:";
    for (const auto& [how, count] : forms) description += fmt::format(" {} {}", count, how);
    result.model.fitError = worst;
    accept(perOutput, description);
}

}  // namespace

Classification classifyParameter(RigProbe& probe, int index, RigState& state, ParameterSamples& samples,
                                 const LearnOptions& options)
{
    const RigParameter& parameter = probe.rig().parameters()[static_cast<std::size_t>(index)];
    Classification result;
    result.index = index;
    result.model.parameter = parameter;
    const double lo = parameter.min - parameter.defaultValue;
    const double hi = parameter.max - parameter.defaultValue;
    if (!(hi > lo) || (lo == 0.0 && hi == 0.0)) {
        result.reason = "its range is empty (min = max = its rest value)";
        return result;
    }
    if (!samples.taken) throw internalError(fmt::format("classifyParameter: {} has no first samples", parameter.name));
    const std::vector<double> offsets = initialOffsets(lo, hi, options.samples, parameter.angular);
    if (!measureEffect(probe, parameter, offsets, state, samples, options, result)) return result;
    Context c{probe, index, options, samples, {}, {}, {}, {}, offsets};
    if (!frameOutputs(probe, c, lo, hi, state, samples, options, result)) return result;
    fitOperators(c, probe.rig().outputs(), options, result);
    return result;
}

}  // namespace rig
