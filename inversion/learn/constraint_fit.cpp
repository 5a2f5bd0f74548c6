#include "inversion/learn/constraint_fit.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <numbers>
#include <random>

#include <fmt/format.h>
#include <Eigen/Dense>

namespace rig {
namespace {

// A shape's knots: at most this many, refined until every midpoint is within a share of epsilon per unit of the goal's
// parameters that move it one centimetre, wherever the reach is: an absolute bound, since a solve asks the joints
// for 1e-3 cm at any reach (a bound growing with the reach left 5 of 300 random IK biped poses at 1-2e-3 cm). A
// chain's reach has a kink where it straightens, which the refinement resolves with knots close around it.
constexpr int maxShapeKnots = 1024;

// Random poses that give the range of reaches a shape is swept over, and check it.
constexpr int rangePoses = 64;

// The shape reaches down to this share of the rest reach, whatever the poses' reaches: a goal nearer the root than
// the shape's knots gets their straight extension, not the rig's bend (a floor at a fifth of the rest reach left
// random IK limbs' goals within it 0.002-0.013 cm per unit off). Not zero: at the root the chain's line is undefined.
constexpr double nearestReach = 1e-3;

// A chain within this share of epsilon is the rig's own plane, its error the shape's rounding (1e-6 measured on the
// bundled rigs' chains and aims), and is taken at once; the others within epsilon only if no exact one follows.
constexpr double exactShare = 1e-2;

// Two readings of a driver's twist whose worst misses on the poses differ by less than this (radians) fit alike: their
// difference is rounding (1e-16 measured).
constexpr double sameTwist = 1e-10;

// The refinement of an up direction (Levenberg-Marquardt on the sphere) stops after this many steps. A pattern search
// before it found the exact ups in at most 456 moves of 4 misfits each, and crawled along the misfit's curved valleys
// for 5,000 (its cap) where there was none: 83% of learning Grunt_Rig.ma went there.
constexpr int maxUpSteps = 50;

// Poses that check a candidate: the same for every candidate and sample count, apart from those it was fitted on.
constexpr int checkPoses = 8;

// A point off the chain's line at rest, carried by the anchor: the plane of a chain without a pole object. Any
// such point will do, since the shape absorbs the constant turn from this plane to the chain's.
Eigen::Vector3d fixedPole(const Eigen::Vector3d& root, const Eigen::Vector3d& goal)
{
    const Eigen::Vector3d x = (goal - root).normalized();
    Eigen::Index axis = 0;
    x.cwiseAbs().minCoeff(&axis);
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(axis);
    return root + std::max(1.0, (goal - root).norm()) * (e - e.dot(x) * x).normalized();
}

// The base's shape through knots (t -> reach offset, G), rotation vectors unwrapped outward from the rest knot so
// that the curve does not jump at half a turn. False when the reach does not grow with t or a value is not finite.
bool setShape(const std::map<double, std::pair<double, Eigen::Matrix4d>>& knots, ConstraintBase& base)
{
    std::vector<double> xs;
    std::vector<std::pair<double, Eigen::Matrix4d>> ordered;
    for (const auto& [t, knot] : knots) ordered.push_back(knot);
    for (std::size_t i = 1; i < ordered.size(); ++i)
        if (!(ordered[i].first > ordered[i - 1].first)) return false;
    const auto z =
        std::find_if(ordered.begin(), ordered.end(), [](const auto& k) { return k.first == 0.0; }) - ordered.begin();
    const auto value = [](const Eigen::Matrix4d& g, const Eigen::Vector3d& previous) {
        CubicSpline<6>::Vector v;
        Eigen::Vector3d r = rotationVector(g.block<3, 3>(0, 0));
        if (r.norm() > 1e-12) {
            const Eigen::Vector3d other = r - 2.0 * std::numbers::pi * r.normalized();
            if ((other - previous).norm() < (r - previous).norm()) r = other;
        }
        v << r, g.block<3, 1>(0, 3);
        return v;
    };
    std::vector<CubicSpline<6>::Vector> ys(ordered.size(), CubicSpline<6>::Vector::Zero());
    for (auto i = z + 1; i < static_cast<std::ptrdiff_t>(ordered.size()); ++i)
        ys[static_cast<std::size_t>(i)] =
            value(ordered[static_cast<std::size_t>(i)].second, ys[static_cast<std::size_t>(i - 1)].head<3>());
    for (auto i = z - 1; i >= 0; --i)
        ys[static_cast<std::size_t>(i)] =
            value(ordered[static_cast<std::size_t>(i)].second, ys[static_cast<std::size_t>(i + 1)].head<3>());
    for (const auto& k : ordered) xs.push_back(k.first);
    if (xs.size() < 2 || !std::all_of(ys.begin(), ys.end(), [](const auto& y) { return y.allFinite(); })) return false;
    base.shape = Operator{};
    base.shape.kind = OperatorKind::sampledRigid;
    base.shape.rigid = CubicSpline<6>(std::move(xs), std::move(ys));
    return true;
}

// A minimalTurn chain's line turn before it is fitted: none (a rotation about the rest normal by zero).
Operator lineTurnAt(const Eigen::Vector3d& root, const Eigen::Vector3d& normal)
{
    Operator turn;
    turn.kind = OperatorKind::rotation;
    turn.axis = normal;
    turn.pivot = root;
    return turn;
}

}  // namespace

ConstraintFitter::ConstraintFitter(RigProbe& probe, const std::vector<ParameterSamples>& samples,
                                   std::vector<int> hierarchy, std::vector<char> helper, const LearnOptions& options)
    : probe_(probe), samples_(samples), hierarchy_(std::move(hierarchy)), helper_(std::move(helper)), options_(options)
{
}

bool ConstraintFitter::modelled(int a, const RigState& state) const
{
    const auto i = static_cast<std::size_t>(a);
    return !state.nonCompositional[i] && !state.unreliable[i];
}

bool ConstraintFitter::below(int h, int k) const
{
    int up = hierarchy_[static_cast<std::size_t>(h)];
    for (std::size_t steps = 0; up >= 0 && steps < hierarchy_.size(); ++steps) {
        if (up == k) return true;
        up = hierarchy_[static_cast<std::size_t>(up)];
    }
    return false;
}

int ConstraintFitter::effectorOf(int goal, int root) const
{
    // Maya's handle tool gives the handle its effector's orientation: the output below the root (or the root) turned
    // as the goal at rest.
    const auto& rest = probe_.rest();
    const Eigen::Matrix3d turn = polarRotation(rest[static_cast<std::size_t>(goal)].block<3, 3>(0, 0));
    for (std::size_t o = 0; o < rest.size(); ++o) {
        const int oo = static_cast<int>(o);
        if (oo == goal || (oo != root && !below(oo, root))) continue;
        if ((polarRotation(rest[o].block<3, 3>(0, 0)) - turn).norm() < 1e-6) return oo;
    }
    return root;
}

bool ConstraintFitter::oneBoneTurnedByGoal(const ConstraintBase& base, int root) const
{
    return base.goalTurns && effectorOf(base.goal, root) == root;
}

bool ConstraintFitter::usableAnchor(int a, const RigState& state) const
{
    return modelled(a, state) && !probe_.constraints.contains(a);
}

std::vector<int> ConstraintFitter::moversOf(int k) const
{
    std::vector<int> movers;
    for (std::size_t i = 0; i < samples_.size(); ++i)
        if (std::binary_search(samples_[i].moved.begin(), samples_[i].moved.end(), k) &&
            !held_.contains(static_cast<int>(i)))
            movers.push_back(static_cast<int>(i));
    return movers;
}

bool ConstraintFitter::turnedBy(int i, int o) const
{
    // A turn well above rounding (1e-15) at any first sample.
    constexpr double turn = 1e-9;
    const ParameterSamples& sample = samples_[static_cast<std::size_t>(i)];
    if (!std::binary_search(sample.moved.begin(), sample.moved.end(), o)) return false;
    const auto& rest = probe_.rest();
    const Eigen::Matrix3d restTurn = polarRotation(rest[static_cast<std::size_t>(o)].block<3, 3>(0, 0));
    return std::any_of(sample.worlds.begin(), sample.worlds.end(), [&](const auto& entry) {
        const Eigen::Matrix3d moved = polarRotation(sample.world(o, entry.first, rest).template block<3, 3>(0, 0));
        return (moved - restTurn).norm() > turn;
    });
}

std::vector<int> ConstraintFitter::ownMovers(int k, const ConstraintBase& base) const
{
    std::vector<int> inputMovers;
    for (const int input : base.frameInputs())
        if (input >= 0)
            for (const int i : moversOf(input)) inputMovers.push_back(i);
    std::sort(inputMovers.begin(), inputMovers.end());
    std::vector<int> own;
    for (const int i : moversOf(k))
        if (!std::binary_search(inputMovers.begin(), inputMovers.end(), i)) own.push_back(i);
    return own;
}

std::vector<int> ConstraintFitter::stretchingAnchorMovers(int k, const std::vector<int>& varied, int anchor) const
{
    // A rigid motion keeps the Gram matrix L^T L of k's linear part; rounding moves it by about 1e-15.
    constexpr double rigid = 1e-9;
    const auto& rest = probe_.rest();
    const Eigen::Matrix3d restLinear = rest[static_cast<std::size_t>(k)].block<3, 3>(0, 0);
    const Eigen::Matrix3d restGram = restLinear.transpose() * restLinear;
    std::vector<int> stretching;
    for (const int i : varied) {
        const ParameterSamples& sample = samples_[static_cast<std::size_t>(i)];
        const auto moves = [&](int o) { return std::binary_search(sample.moved.begin(), sample.moved.end(), o); };
        if (anchor < 0 || !moves(anchor)) continue;
        const bool stretches = std::any_of(sample.worlds.begin(), sample.worlds.end(), [&](const auto& entry) {
            const Eigen::Matrix3d linear = sample.world(k, entry.first, rest).template block<3, 3>(0, 0);
            return (linear.transpose() * linear - restGram).norm() > rigid * std::max(1.0, restGram.norm());
        });
        if (stretches) stretching.push_back(i);
    }
    return stretching;
}

const std::vector<ConstraintFitter::Pose>& ConstraintFitter::poses(const std::vector<int>& varied, int set, int count)
{
    std::vector<Pose>& poses = poses_[{varied, set}];
    const auto& parameters = probe_.rig().parameters();
    while (static_cast<int>(poses.size()) < count) {
        std::mt19937 rng(options_.seed * 7919u + static_cast<std::uint32_t>(set) * 104729u +
                         static_cast<std::uint32_t>(poses.size()));
        Pose pose;
        std::vector<double> values = probe_.defaults();
        for (const int i : varied) {
            const RigParameter& p = parameters[static_cast<std::size_t>(i)];
            const double value = std::uniform_real_distribution<double>(p.min, p.max)(rng);
            pose.offsets.push_back(value - p.defaultValue);
            values[static_cast<std::size_t>(i)] = value;
        }
        pose.worlds = probe_.atValues(values);
        ++evaluations_;
        poses.push_back(std::move(pose));
    }
    return poses;
}

ChainPoints ConstraintFitter::pointsAt(const ConstraintBase& base, const std::vector<Eigen::Matrix4d>& worlds) const
{
    const Eigen::Matrix4d identity = Eigen::Matrix4d::Identity();
    const Eigen::Matrix4d motion =
        base.anchor < 0 ? identity
                        : Eigen::Matrix4d(worlds[static_cast<std::size_t>(base.anchor)] *
                                          probe_.rest()[static_cast<std::size_t>(base.anchor)].inverse());
    return chainPoints(base, motion, worlds[static_cast<std::size_t>(base.goal)],
                       base.pole < 0 ? identity : worlds[static_cast<std::size_t>(base.pole)]);
}

Eigen::Matrix4d ConstraintFitter::baseAt(const ConstraintBase& base, const std::vector<Eigen::Matrix4d>& worlds) const
{
    const Eigen::Matrix4d identity = Eigen::Matrix4d::Identity();
    const auto [anchor, second, third, orient, unused] = base.frameInputs();
    const auto world = [&](int i) { return i < 0 ? identity : worlds[static_cast<std::size_t>(i)]; };
    const auto motion = [&](int i) -> Eigen::Matrix4d {
        return i < 0 ? identity : Eigen::Matrix4d(world(i) * probe_.rest()[static_cast<std::size_t>(i)].inverse());
    };
    return constraintBase(base, motion(anchor), world(second), world(third), motion(orient));
}

Eigen::Matrix4d ConstraintFitter::predicted(int k, const ConstraintBase& base,
                                            const std::vector<Eigen::Matrix4d>& worlds) const
{
    return baseAt(base, worlds) * probe_.rest()[static_cast<std::size_t>(k)];
}

bool ConstraintFitter::shapeAt(int k, const ConstraintBase& base, const std::vector<Eigen::Matrix4d>& worlds, double& x,
                               Eigen::Matrix4d& g) const
{
    const auto& rest = probe_.rest();
    const ChainPoints points = pointsAt(base, worlds);
    Eigen::Matrix4d frame;
    if (!chainFrame(points, base.restPlane, frame) || !worlds[static_cast<std::size_t>(k)].allFinite()) return false;
    x = (points.goal - points.root).norm() - base.restReach;
    g = frame.inverse() * worlds[static_cast<std::size_t>(k)] * rest[static_cast<std::size_t>(k)].inverse() *
        base.restFrame;
    return true;
}

bool ConstraintFitter::sweepFor(const ConstraintBase& base, const std::vector<int>& varied, int anchorOrPole,
                                Sweep*& sweep)
{
    const auto found = sweeps_.find({base.goal, anchorOrPole});
    if (found != sweeps_.end()) {
        sweep = &found->second;
        return !sweep->parameters.empty();
    }
    Sweep& made = sweeps_[{base.goal, anchorOrPole}];
    sweep = &made;
    // Each parameter's first-order effect on the goal, from its smallest first sample. Those that carry the goal
    // without turning it (its control's translations) are swept alone where they span the line: a turn of a control
    // whose pivot is away from the goal moves it further per unit, so that a least-norm sweep would take the turn,
    // and the goal would leave the line and come round.
    const auto& rest = probe_.rest();
    const Eigen::Vector3d restGoal = rest[static_cast<std::size_t>(base.goal)].block<3, 1>(0, 3);
    const Eigen::Matrix3d restTurn = rest[static_cast<std::size_t>(base.goal)].block<3, 3>(0, 0);
    std::vector<Eigen::Vector3d> columns;
    std::vector<char> turns;
    for (const int i : varied) {
        const ParameterSamples& sample = samples_[static_cast<std::size_t>(i)];
        if (!std::binary_search(sample.moved.begin(), sample.moved.end(), base.goal)) continue;
        if (base.anchor >= 0 && std::binary_search(sample.moved.begin(), sample.moved.end(), base.anchor)) continue;
        // A control with limits (a foot roll that also moves the goal) cannot go wherever the line goes.
        if (probe_.rig().parameters()[static_cast<std::size_t>(i)].limited) continue;
        double smallest = 0.0;
        for (const auto& [a, worlds] : sample.worlds)
            if (a != 0.0 && (smallest == 0.0 || std::abs(a) < std::abs(smallest))) smallest = a;
        if (smallest == 0.0) continue;
        made.parameters.push_back(i);
        const Eigen::Matrix4d& moved = sample.world(base.goal, smallest, rest);
        columns.push_back((moved.block<3, 1>(0, 3) - restGoal) / smallest);
        turns.push_back((moved.block<3, 3>(0, 0) - restTurn).norm() > 1e-9 * std::abs(smallest));
    }
    if (made.parameters.empty()) return false;
    const Eigen::Vector3d along = (restGoal - base.root).normalized();
    for (const bool withTurns : {false, true}) {
        Eigen::MatrixXd j = Eigen::MatrixXd::Zero(3, static_cast<Eigen::Index>(columns.size()));
        for (std::size_t c = 0; c < columns.size(); ++c)
            if (withTurns || !turns[c]) j.col(static_cast<Eigen::Index>(c)) = columns[c];
        made.direction = j.completeOrthogonalDecomposition().solve(along);
        if ((j * made.direction - along).norm() < 1e-6) return true;
    }
    made.parameters.clear();
    return false;
}

const std::vector<Eigen::Matrix4d>& ConstraintFitter::sweepAt(Sweep& sweep, double t)
{
    const auto found = sweep.worlds.find(t);
    if (found != sweep.worlds.end()) return found->second;
    std::vector<double> values = probe_.defaults();
    for (std::size_t p = 0; p < sweep.parameters.size(); ++p)
        values[static_cast<std::size_t>(sweep.parameters[p])] += t * sweep.direction[static_cast<Eigen::Index>(p)];
    ++evaluations_;
    return sweep.worlds.emplace(t, probe_.atValues(values)).first->second;
}

bool ConstraintFitter::makeBase(int k, int rootOutput, Sweep& sweep, double lo, double hi, ConstraintBase& base)
{
    std::map<double, std::pair<double, Eigen::Matrix4d>> knots{{0.0, {0.0, Eigen::Matrix4d::Identity()}}};
    std::map<double, std::pair<double, double>> turns{{0.0, {0.0, 0.0}}};  // t -> the reach offset, the line's turn
    // The line's turn is read from the chain's start joint, or for a plane the goal turns from the effector's joint
    // (ConstraintBase::goalTurns).
    const int turning = base.goalTurns ? effectorOf(base.goal, rootOutput) : rootOutput;
    const bool oneBone = base.goalTurns && turning == rootOutput;
    const Eigen::Matrix3d rootRest = polarRotation(probe_.rest()[static_cast<std::size_t>(turning)].block<3, 3>(0, 0));
    const auto add = [&](double t) {
        if (knots.contains(t)) return true;
        std::pair<double, Eigen::Matrix4d> knot;
        const std::vector<Eigen::Matrix4d>& worlds = sweepAt(sweep, t);
        if (!shapeAt(k, base, worlds, knot.first, knot.second)) return false;
        knots.emplace(t, knot);
        // Along the line at rest the chain's start joint (its root output) turns about the rest normal alone, from
        // the line to its end as it bent with the start joint unturned back onto the goal's: that turn's opposite.
        const Eigen::Matrix3d turn =
            polarRotation(worlds[static_cast<std::size_t>(turning)].block<3, 3>(0, 0)) * rootRest.transpose();
        turns.emplace(t, std::pair{knot.first, -rotationVector(turn).dot(base.restNormal)});
        return true;
    };
    // A minimalTurn chain's line turn through the knots so far (the shape's frame at a knot does not depend on it:
    // along the line at rest the plane is the rest plane, whatever the turn).
    const auto setTurn = [&] {
        // One bone turned by its goal does not bend: its line does not turn (and a sweep that turns the goal would
        // read the goal's own turn as the line's).
        if (!base.minimalTurn || oneBone) return true;
        std::vector<double> xs;
        std::vector<CubicSpline<1>::Vector> ys;
        for (const auto& [t, turn] : turns) {
            if (!xs.empty() && !(turn.first > xs.back())) return false;
            xs.push_back(turn.first);
            ys.push_back(CubicSpline<1>::Vector::Constant(turn.second));
        }
        if (xs.size() < 2) return false;
        base.lineTurn.curve = CubicSpline<1>(std::move(xs), std::move(ys));
        return true;
    };
    constexpr int firstKnots = 9;
    for (int i = 0; i < firstKnots; ++i)
        if (!add(lo + (hi - lo) * i / (firstKnots - 1))) return false;
    // Halve every interval whose midpoint the spline misses by more than its share of epsilon (maxShapeKnots).
    while (true) {
        if (!setShape(knots, base) || !setTurn()) return false;
        std::vector<double> missed;
        for (auto a = knots.begin(), b = std::next(a); b != knots.end(); ++a, ++b) {
            const double t = 0.5 * (a->first + b->first);
            const std::vector<Eigen::Matrix4d>& worlds = sweepAt(sweep, t);
            const double e =
                matrixError(predicted(k, base, worlds), worlds[static_cast<std::size_t>(k)], options_.frameRadius);
            const double moved = sweep.direction.lpNorm<1>();
            if (!(e <= constraintFitShare * options_.epsilon * moved)) missed.push_back(t);
        }
        if (missed.empty() || static_cast<int>(knots.size() + missed.size()) > maxShapeKnots) return true;
        for (const double t : missed)
            if (!add(t)) return false;
    }
}

double ConstraintFitter::error(int k, const ConstraintBase& base, const std::vector<Pose>& poses) const
{
    double worst = 0.0;
    for (const Pose& pose : poses) {
        double moved = 0.0;
        for (const double a : pose.offsets) moved += std::abs(a);
        const Eigen::Matrix4d p = predicted(k, base, pose.worlds);
        const double e = matrixError(p, pose.worlds[static_cast<std::size_t>(k)], options_.frameRadius);
        if (!std::isfinite(e)) return std::numeric_limits<double>::infinity();
        worst = std::max(worst, e <= 1e-12 ? 0.0 : e / std::max(moved, 1e-300));
    }
    return worst;
}

double ConstraintFitter::tryCandidate(int k, int rootOutput, const std::vector<int>& varied, bool fixedGoal,
                                      ConstraintBase& base)
{
    const Eigen::Vector3d restGoal = probe_.rest()[static_cast<std::size_t>(base.goal)].block<3, 1>(0, 3);
    const double failed = std::numeric_limits<double>::infinity();
    if (!base.prepare(restGoal)) return failed;
    // The shape covers the reaches of the random poses, and a quarter as much again on either side.
    const std::vector<Pose>& fitPoses = poses(varied, 0, rangePoses);
    double lo = 0.0, hi = 0.0;
    for (const Pose& pose : fitPoses) {
        double x = 0.0;
        Eigen::Matrix4d g;
        if (!shapeAt(k, base, pose.worlds, x, g)) continue;
        lo = std::min(lo, x);
        hi = std::max(hi, x);
    }
    const double span = hi - lo;
    lo = std::max(lo - 0.25 * span, (nearestReach - 1.0) * base.restReach);
    hi += 0.25 * span;
    // One bone turned by its goal (an ikSCsolver's start joint aimed at its handle) does not bend either.
    if (fixedGoal || (rootOutput == k && oneBoneTurnedByGoal(base, rootOutput))) {
        // An aim at a fixed point: what the output does cannot depend on its distance from it. G = I throughout.
        std::map<double, std::pair<double, Eigen::Matrix4d>> flat{{lo, {lo, Eigen::Matrix4d::Identity()}},
                                                                  {hi, {hi, Eigen::Matrix4d::Identity()}}};
        if (!(hi > lo) || !setShape(flat, base)) return failed;
    } else {
        Sweep* sweep = nullptr;
        if (!sweepFor(base, varied, base.anchor, sweep) || !makeBase(k, rootOutput, *sweep, lo, hi, base))
            return failed;
    }
    return std::max(error(k, base, fitPoses), error(k, base, poses(varied, 1, checkPoses)));
}

bool ConstraintFitter::bestShare(const std::vector<Pose>& poses, const std::vector<double>& theta,
                                 ConstraintBase& base) const
{
    const auto world = [&](const Pose& pose, int i) -> Eigen::Matrix3d {
        return i < 0 ? Eigen::Matrix3d::Identity()
                     : polarRotation(pose.worlds[static_cast<std::size_t>(i)].block<3, 3>(0, 0));
    };
    std::vector<Eigen::Matrix3d> relative;
    for (const Pose& pose : poses)
        relative.push_back(world(pose, base.driverParent).transpose() * world(pose, base.driver));
    const auto& rest = probe_.rest();
    const auto restRotation = [&](int i) -> Eigen::Matrix3d {
        return i < 0 ? Eigen::Matrix3d::Identity() : polarRotation(rest[static_cast<std::size_t>(i)].block<3, 3>(0, 0));
    };
    base.driverRest = restRotation(base.driverParent).transpose() * restRotation(base.driver);
    double best = std::numeric_limits<double>::infinity();
    ConstraintBase candidate = base;
    constexpr std::array orders{RotateOrder::xyz, RotateOrder::yzx, RotateOrder::zxy,
                                RotateOrder::xzy, RotateOrder::yxz, RotateOrder::zyx};
    for (int axis = 0; axis < 3; ++axis)
        for (const RotateOrder read : orders)
            for (const RotateOrder twist : orders) {
                // The same order is the plain swing-twist whichever it is: tried once.
                if (read == twist && read != RotateOrder::xyz) continue;
                candidate.twistAxis = axis;
                candidate.readOrder = read;
                candidate.twistOrder = twist;
                double tt = 0.0, ttheta = 0.0;
                std::vector<double> tau;
                for (const Eigen::Matrix3d& r : relative) {
                    tau.push_back(driverTwist(candidate, r));
                    tt += tau.back() * tau.back();
                    ttheta += tau.back() * theta[tau.size() - 1];
                }
                if (!(tt > 1e-12)) continue;
                candidate.share = ttheta / tt;
                double miss = 0.0;
                for (std::size_t i = 0; i < tau.size(); ++i)
                    miss = std::max(miss, std::abs(theta[i] - candidate.share * tau[i]));
                // Readings that agree to rounding are the same twist (but at their own gimbal locks): the first is
                // kept, the plain swing-twist before the reorderings, not one rounding picks (the creature's IK roll
                // joints, a swing-twist in the rig, were reported as xyz angles read in yzx, 1e-16 closer).
                if (miss < best - sameTwist) {
                    best = miss;
                    base = candidate;
                }
            }
    return std::isfinite(best);
}

bool ConstraintFitter::turnsOf(int k, const std::vector<Pose>& poses, ConstraintBase& base,
                               std::vector<double>& theta) const
{
    const auto& rest = probe_.rest();
    // k's turn relative to what its anchor's rotation carries: D = R_k0^T Q_a^T R_k, about one axis for a share.
    const Eigen::Matrix3d restK = polarRotation(rest[static_cast<std::size_t>(k)].block<3, 3>(0, 0));
    std::vector<Eigen::Quaterniond> turns;
    double largest = 0.0;
    Eigen::Vector3d local = Eigen::Vector3d::UnitX();
    for (const Pose& pose : poses) {
        const auto a = static_cast<std::size_t>(base.anchor);
        const Eigen::Matrix3d q =
            base.anchor < 0 ? Eigen::Matrix3d::Identity()
                            : polarRotation(pose.worlds[a].block<3, 3>(0, 0) * rest[a].block<3, 3>(0, 0).inverse());
        turns.emplace_back(Eigen::Matrix3d(restK.transpose() * q.transpose() *
                                           polarRotation(pose.worlds[static_cast<std::size_t>(k)].block<3, 3>(0, 0))));
        const Eigen::AngleAxisd angleAxis(turns.back());
        if (std::abs(angleAxis.angle()) > largest) {
            largest = std::abs(angleAxis.angle());
            local = angleAxis.axis();
        }
    }
    if (!(largest > 1e-6)) return false;
    theta.clear();
    for (Eigen::Quaterniond& q : turns) {
        if (q.w() < 0) q.coeffs() = -q.coeffs();
        theta.push_back(2.0 * std::atan2(q.vec().dot(local), q.w()));
    }
    base.root = rest[static_cast<std::size_t>(k)].block<3, 1>(0, 3);
    base.axis = restK * local;
    return true;
}

std::optional<ConstraintBase> ConstraintFitter::twistShare(int k, const RigState& state)
{
    Closest closest;
    return fitTwist(k, moversOf(k), state, true, closest);
}

std::optional<ConstraintBase> ConstraintFitter::fitTwist(int k, const std::vector<int>& movers, const RigState& state,
                                                         bool constraintInputs, Closest& closest)
{
    const auto& names = probe_.rig().outputs();
    const auto usable = [&](int i) { return constraintInputs ? modelled(i, state) : usableAnchor(i, state); };
    ConstraintBase base;
    base.kind = ConstraintKind::twistShare;
    // With constraint inputs, a roll joint under an IK forearm turns with the forearm: its motion M_a carries the roll
    // joint's rest origin wherever the chain puts it.
    base.anchor = hierarchy_[static_cast<std::size_t>(k)];
    while (base.anchor >= 0 && !usable(base.anchor)) base.anchor = hierarchy_[static_cast<std::size_t>(base.anchor)];
    const auto movedBy = [&](const std::vector<int>& m) {
        return std::any_of(m.begin(), m.end(),
                           [&](int i) { return std::binary_search(movers.begin(), movers.end(), i); });
    };
    std::vector<double> theta;
    for (std::size_t d = 0; d < hierarchy_.size(); ++d) {
        const int driver = static_cast<int>(d), parent = hierarchy_[d];
        const std::vector<int> driverMovers = moversOf(driver);
        if (driver == k || !usable(driver) || !movedBy(driverMovers)) continue;
        if (parent >= 0 && !usable(parent)) continue;
        // The poses also vary what turns the driver without moving k alone: a turn about an axis across the twist's
        // changes the twist only together with the others.
        std::vector<int> varied;
        std::set_union(movers.begin(), movers.end(), driverMovers.begin(), driverMovers.end(),
                       std::back_inserter(varied));
        const std::vector<Pose>& fitPoses = poses(varied, 0, rangePoses);
        base.driver = driver;
        base.driverParent = parent;
        if (!turnsOf(k, fitPoses, base, theta) || !bestShare(fitPoses, theta, base)) continue;
        const double e = std::max(error(k, base, fitPoses), error(k, base, poses(varied, 1, checkPoses)));
        if (e <= options_.epsilon) return base;
        if (e < closest.error) {
            closest.error = e;
            closest.what = fmt::format("a twist share ({:.3g} of {}'s twist about {})", base.share, names[d],
                                       "xyz"[base.twistAxis]);
        }
    }
    return std::nullopt;
}

namespace {

// How far the planes through the aims A_i and the up direction u turn from the one at rest by the output's turns D_i:
// r_i = n(A_i, u) - D_i n(A_0, u) with n(A, u) = A x u / |A x u| (for an up that is right, D_i carries the rest plane
// onto each pose's), three residuals per pose into `r`. False where a plane is undefined (u along an aim).
bool upResiduals(const Eigen::Vector3d& u, const std::vector<Eigen::Vector3d>& aims,
                 const std::vector<Eigen::Matrix3d>& turns, const Eigen::Vector3d& restAim, Eigen::VectorXd& r)
{
    const Eigen::Vector3d n0 = restAim.cross(u);
    if (!(n0.norm() > 1e-9)) return false;
    const Eigen::Vector3d plane = n0.normalized();
    for (std::size_t i = 0; i < aims.size(); ++i) {
        const Eigen::Vector3d n = aims[i].cross(u);
        if (!(n.norm() > 1e-9)) return false;
        r.segment<3>(static_cast<Eigen::Index>(3 * i)) = n.normalized() - turns[i] * plane;
    }
    return true;
}

// Their sum of squares, stopped once past `bound` (most directions of the sphere are, after a few poses: the scan only
// asks whether a direction beats the best so far, and one so stopped is not taken).
double upMisfit(const Eigen::Vector3d& u, const std::vector<Eigen::Vector3d>& aims,
                const std::vector<Eigen::Matrix3d>& turns, const Eigen::Vector3d& restAim, double bound)
{
    const Eigen::Vector3d n0 = restAim.cross(u);
    if (!(n0.norm() > 1e-9)) return std::numeric_limits<double>::infinity();
    const Eigen::Vector3d plane = n0.normalized();
    double sum = 0.0;
    for (std::size_t i = 0; i < aims.size() && sum < bound; ++i) {
        const Eigen::Vector3d n = aims[i].cross(u);
        if (!(n.norm() > 1e-9)) return std::numeric_limits<double>::infinity();
        sum += (n.normalized() - turns[i] * plane).squaredNorm();
    }
    return sum;
}

// Levenberg-Marquardt over the sphere from `up` (steps in its tangent plane, the Jacobian by central differences):
// the misfit at the end.
double refineUp(Eigen::Vector3d& up, const std::vector<Eigen::Vector3d>& aims,
                const std::vector<Eigen::Matrix3d>& turns, const Eigen::Vector3d& restAim)
{
    const auto rows = static_cast<Eigen::Index>(3 * aims.size());
    Eigen::VectorXd r(rows), plus(rows), minus(rows);
    Eigen::MatrixXd jacobian(rows, 2);
    if (!upResiduals(up, aims, turns, restAim, r)) return std::numeric_limits<double>::infinity();
    double cost = r.squaredNorm(), lambda = 1e-3;
    constexpr double h = 1e-6;
    for (int step = 0; step < maxUpSteps && cost > 1e-30; ++step) {
        const Eigen::Vector3d t1 = up.unitOrthogonal(), t2 = up.cross(t1);
        for (int c = 0; c < 2; ++c) {
            const Eigen::Vector3d t = c == 0 ? t1 : t2;
            if (!upResiduals((up + h * t).normalized(), aims, turns, restAim, plus) ||
                !upResiduals((up - h * t).normalized(), aims, turns, restAim, minus))
                return cost;
            jacobian.col(c) = (plus - minus) / (2.0 * h);
        }
        const Eigen::Matrix2d normal = jacobian.transpose() * jacobian;
        const Eigen::Vector2d gradient = jacobian.transpose() * r;
        bool moved = false;
        for (; !moved && lambda < 1e12; lambda *= 10.0) {
            Eigen::Matrix2d damped = normal;
            damped.diagonal() += lambda * normal.diagonal() + Eigen::Vector2d::Constant(1e-15);
            const Eigen::Vector2d d = -damped.ldlt().solve(gradient);
            const Eigen::Vector3d u = (up + d[0] * t1 + d[1] * t2).normalized();
            if (upResiduals(u, aims, turns, restAim, plus) && plus.squaredNorm() < cost) {
                up = u;
                r.swap(plus);
                cost = r.squaredNorm();
                moved = true;
            }
        }
        if (!moved) break;
        lambda = std::max(lambda / 100.0, 1e-12);  // the loop's last *10 undone, and one step bolder
    }
    return cost;
}

}  // namespace

bool ConstraintFitter::fittedUp(int k, int anchor, const Eigen::Vector3d& root, int goal,
                                const std::vector<Pose>& poses, int carrier, Eigen::Vector3d& up) const
{
    const auto& rest = probe_.rest();
    const auto at = [](const std::vector<Eigen::Matrix4d>& w, int i) { return w[static_cast<std::size_t>(i)]; };
    const Eigen::Vector3d restAim = (rest[static_cast<std::size_t>(goal)].block<3, 1>(0, 3) - root).normalized();
    std::vector<Eigen::Vector3d> aims;
    std::vector<Eigen::Matrix3d> turns;
    for (const Pose& pose : poses) {
        const Eigen::Matrix4d motion =
            anchor < 0 ? Eigen::Matrix4d(Eigen::Matrix4d::Identity())
                       : Eigen::Matrix4d(at(pose.worlds, anchor) * rest[static_cast<std::size_t>(anchor)].inverse());
        const Eigen::Matrix3d frame =
            carrier < 0 ? Eigen::Matrix3d::Identity()
                        : polarRotation(at(pose.worlds, carrier).block<3, 3>(0, 0) *
                                        rest[static_cast<std::size_t>(carrier)].block<3, 3>(0, 0).inverse());
        const Eigen::Vector3d r = motion.block<3, 3>(0, 0) * root + motion.block<3, 1>(0, 3);
        aims.push_back(frame.transpose() * (at(pose.worlds, goal).block<3, 1>(0, 3) - r).normalized());
        turns.push_back(frame.transpose() *
                        polarRotation(at(pose.worlds, k).block<3, 3>(0, 0) *
                                      rest[static_cast<std::size_t>(k)].block<3, 3>(0, 0).inverse()));
    }
    // The best of directions spread over the sphere, then refined on it.
    double best = std::numeric_limits<double>::infinity();
    constexpr int directions = 500;
    for (int i = 0; i < directions; ++i) {
        const double z = 1.0 - (2.0 * i + 1.0) / directions, ring = std::sqrt(1.0 - z * z);
        const double angle = i * std::numbers::pi * (3.0 - std::sqrt(5.0));
        const Eigen::Vector3d u(ring * std::cos(angle), ring * std::sin(angle), z);
        const double e = upMisfit(u, aims, turns, restAim, best);
        if (e < best) {
            best = e;
            up = u;
        }
    }
    if (!std::isfinite(best)) return false;
    return refineUp(up, aims, turns, restAim) < 1e-12 * static_cast<double>(poses.size());
}

std::optional<ConstraintBase> ConstraintFitter::fitChain(int k, int anchor, int root, const std::vector<int>& varied,
                                                         const std::vector<int>& helpers, const std::vector<int>& goals,
                                                         Closest& closest, int orient)
{
    const auto& rest = probe_.rest();
    const auto& names = probe_.rig().outputs();
    const Eigen::Vector3d rootRest = rest[static_cast<std::size_t>(root)].block<3, 1>(0, 3);
    // Three passes over the goals: first the poles the rig shows (helpers, points along the anchor's axes), then, only
    // where none fits to rounding, the up directions fitted from the poses and the rest planes, and last the poles
    // turned by a helper (poleCarriers). A candidate within epsilon but not to rounding is the rig's plane
    // approximated (a point along a world axis a degree off a pole-less chain's rest normal: 2e-4 cm per unit): the
    // closest such is kept in case no later one is exact.
    std::optional<std::pair<ConstraintBase, double>> within;
    // An exact candidate whose goal keeps its distance from the root (a control chain's knee for a bound thigh) is an
    // aim at a point the root carries: kept, in case no goal whose reach varies is exact too, which explains the chain
    // by what moves it (the reverse foot) rather than by another helper's frame, learned with its own error.
    std::optional<ConstraintBase> fixedReach;
    for (int pass = 0; pass < 3; ++pass)
        for (const int goal : goals) {
            // Each candidate made and checked: the first exact one returned, the closest kept.
            for (ConstraintBase base : poleCandidates(pass, k, anchor, root, goal, varied, helpers)) {
                const int pole = base.pole;
                base.anchor = anchor;
                base.goal = goal;
                base.root = rootRest;
                base.orient = orient;
                base.origin = rest[static_cast<std::size_t>(k)].block<3, 1>(0, 3);
                const double e = tryCandidate(k, root, varied, moversOf(goal).empty(), base);
                const auto& knots = base.shape.rigid.knots();
                const bool fixed =
                    knots.empty() || knots.back() - knots.front() <= 1e-6 * std::max(1.0, base.restReach);
                if (e <= exactShare * options_.epsilon && !fixed) return base;
                if (e <= exactShare * options_.epsilon && !fixedReach) fixedReach = base;
                if (e <= options_.epsilon && !(within && within->second <= e)) within.emplace(base, e);
                if (!(e < closest.error)) continue;
                closest.error = e;
                const std::string fixedTo = anchor < 0 ? "the world" : names[static_cast<std::size_t>(anchor)];
                closest.what =
                    fmt::format("a planar chain (goal {}, pole {}{})", names[static_cast<std::size_t>(goal)],
                                base.goalTurns     ? "none (the rest plane turned by the goal, then minimally)"
                                : base.minimalTurn ? "none (the rest plane of " + fixedTo + " turned minimally)"
                                : base.restPlane   ? "none (the rest plane of " + fixedTo + ")"
                                : base.worldUp     ? std::string("a world up")
                                : pole < 0         ? "fixed to " + fixedTo
                                : base.poleTurns   ? "turned by " + names[static_cast<std::size_t>(pole)]
                                                   : names[static_cast<std::size_t>(pole)],
                                orient < 0 ? "" : ", turning as " + names[static_cast<std::size_t>(orient)]);
            }
        }
    if (fixedReach) return fixedReach;
    if (within) return within->first;
    return std::nullopt;
}

std::vector<ConstraintBase> ConstraintFitter::poleCandidates(int pass, int k, int anchor, int root, int goal,
                                                             const std::vector<int>& varied,
                                                             const std::vector<int>& helpers)
{
    const auto& rest = probe_.rest();
    const Eigen::Vector3d rootRest = rest[static_cast<std::size_t>(root)].block<3, 1>(0, 3);
    const Eigen::Vector3d restGoal = rest[static_cast<std::size_t>(goal)].block<3, 1>(0, 3);
    // Poles: a helper's origin, a point carried by the anchor, or none (the rest plane kept, its normal from the
    // chain's joints at rest).
    std::vector<ConstraintBase> poles;
    const auto choice = [&](int pole, const Eigen::Vector3d& point, const Eigen::Vector3d& normal, bool worldUp = false,
                            bool turns = false) {
        ConstraintBase base;
        base.worldUp = worldUp;
        base.pole = pole;
        base.poleTurns = turns;
        if (turns) base.poleRest = rest[static_cast<std::size_t>(pole)].block<3, 3>(0, 0);
        base.restPole = point;
        base.restPlane = normal.squaredNorm() > 0.0;
        base.restNormal = normal;
        poles.push_back(base);
    };
    if (pass == 0) {
        for (const int pole : helpers)
            if (pole != goal)
                choice(pole, rest[static_cast<std::size_t>(pole)].block<3, 1>(0, 3), Eigen::Vector3d::Zero());
        for (const Eigen::Vector3d& point : fixedPoles(anchor, rootRest, restGoal))
            choice(-1, point, Eigen::Vector3d::Zero());
        return poles;
    }
    const double length = std::max(1.0, (restGoal - rootRest).norm());
    const std::vector<Eigen::Vector3d> normals = restNormals(root, rootRest, restGoal);
    if (pass == 1) {
        // An up vector the poses show (an aim's up in the anchor's axes, or fixed in the world: scene or vector up),
        // and the rest plane.
        for (const bool inWorld : {false, true}) {
            Eigen::Vector3d up;
            if (fittedUp(k, anchor, rootRest, goal, poses(varied, 0, rangePoses), inWorld ? -1 : anchor, up))
                choice(-1, rootRest + length * up, Eigen::Vector3d::Zero(), inWorld);
        }
        for (const Eigen::Vector3d& normal : normals) choice(-1, rootRest, normal);
        // Maya's ikSCsolver: no pole, the rest plane turned minimally onto the goal's line (any plane through the line
        // of a chain straight at rest: its shape takes the constant turn from it).
        const Eigen::Vector3d x0 = (restGoal - rootRest).normalized();
        // Then as Maya solves it, the plane turned by the goal's rotation as well (the handle's orientation, which
        // the chain turns toward about its line: a handle under a reverse foot's pivot turns the foot).
        for (const bool goalTurns : {false, true})
            for (const Eigen::Vector3d& normal : normals.empty() ? std::vector{x0.unitOrthogonal()} : normals) {
                choice(-1, rootRest, normal);
                poles.back().minimalTurn = true;
                poles.back().lineTurn = lineTurnAt(rootRest, normal);
                poles.back().goalTurns = goalTurns;
                poles.back().goalRest = rest[static_cast<std::size_t>(goal)].block<3, 3>(0, 0);
            }
        return poles;
    }
    // A pole vector in the axes of the goal or of a helper moved with it (a mayaIkHandle's, kept in the space of the
    // foot it hangs under): fitted from the poses, or across the line in a rest plane. Last, as the up's fit from the
    // poses costs most of a chain's fit.
    const Eigen::Vector3d x0 = (restGoal - rootRest).normalized();
    for (const int carrier : poleCarriers(k, goal, varied, helpers)) {
        Eigen::Vector3d up;
        if (fittedUp(k, anchor, rootRest, goal, poses(varied, 0, rangePoses), carrier, up))
            choice(carrier, rootRest + length * up, Eigen::Vector3d::Zero(), false, true);
        for (const Eigen::Vector3d& normal : normals)
            choice(carrier, rootRest + length * normal.cross(x0), Eigen::Vector3d::Zero(), false, true);
    }
    return poles;
}

std::vector<int> ConstraintFitter::poleCarriers(int k, int goal, const std::vector<int>& varied,
                                                const std::vector<int>& helpers) const
{
    // A carrier must turn on the fit's poses, and nothing may turn it without moving k (a turn of an ikHandle's goal
    // control that the chain ignores would move the pole). Without the second check a helper the fit's poses never
    // turn passed them as a pole fixed in the world, and the validation, which turns it, found the chain centimetres
    // off (FK/IK blends' thighs, issue #46); trying every moved helper also made learning the creature ten times
    // slower.
    const std::vector<int> kMovers = moversOf(k);
    const auto carries = [&](int h) {
        const auto turned = [&](int i) { return turnedBy(i, h); };
        const std::vector<int> hMovers = moversOf(h);
        return std::any_of(varied.begin(), varied.end(), turned) &&
               std::none_of(hMovers.begin(), hMovers.end(),
                            [&](int i) { return !std::binary_search(kMovers.begin(), kMovers.end(), i) && turned(i); });
    };
    std::vector<int> carriers;
    if (carries(goal)) carriers.push_back(goal);
    for (const int h : helpers)
        if (h != goal && carries(h)) carriers.push_back(h);
    return carriers;
}

std::optional<ConstraintBase> ConstraintFitter::fit(int k, const RigState& state, std::string& why)
{
    int root = k, anchor = hierarchy_[static_cast<std::size_t>(k)];
    while (anchor >= 0 && !usableAnchor(anchor, state)) {
        root = anchor;
        anchor = hierarchy_[static_cast<std::size_t>(anchor)];
    }
    Closest closest;
    if (std::optional<ConstraintBase> twist = fitTwist(k, moversOf(k), state, false, closest)) return twist;
    bool candidates = false;
    if (std::optional<ConstraintBase> chain = fitAnchored(k, anchor, root, state, closest, candidates)) return chain;
    for (const int carrier : rootCarriers(k, anchor, root, state))
        if (std::optional<ConstraintBase> chain = fitAnchored(k, carrier, root, state, closest, candidates))
            return chain;
    // A chain that starts at k itself under a parent another constraint frames (an ikSCsolver's ankle under an IK
    // knee): rooted at k, carried by that parent.
    if (root != k) {
        int parent = hierarchy_[static_cast<std::size_t>(k)];
        while (parent >= 0 && !modelled(parent, state)) parent = hierarchy_[static_cast<std::size_t>(parent)];
        if (parent >= 0)
            if (std::optional<ConstraintBase> chain = fitAnchored(k, parent, k, state, closest, candidates))
                return chain;
    }
    if (std::optional<ConstraintBase> oriented = fitOriented(k, state, closest)) return oriented;
    if (std::optional<ConstraintBase> aimed = fitAimed(k, state, closest)) return aimed;
    if (!candidates) {
        // Without any helper frame (rig-learn --no-helpers) only twist shares were tried: say so only if one came
        // close.
        const bool anyHelper = std::any_of(helper_.begin(), helper_.end(), [](char h) { return h != 0; });
        why = anyHelper ? "no helper frame is moved by what moves it apart from its anchor (rig-learn --helpers)" : "";
        if (std::isfinite(closest.error))
            why += fmt::format("{}the closest constraint, {}, is {:.3g} cm per unit off, over epsilon {:g}",
                               why.empty() ? "" : "; ", closest.what, closest.error, options_.epsilon);
        return std::nullopt;
    }
    why = std::isfinite(closest.error)
              ? fmt::format("the closest constraint, {}, is {:.3g} cm per unit off, over epsilon {:g}", closest.what,
                            closest.error, options_.epsilon)
              : "no planar chain spans a plane from its helper frames";
    return std::nullopt;
}

std::optional<ConstraintBase> ConstraintFitter::fitAnchored(int k, int anchor, int root, const RigState& state,
                                                            Closest& closest, bool& candidates)
{
    const std::vector<int> movers = moversOf(k), anchorMovers = anchor >= 0 ? moversOf(anchor) : std::vector<int>{};
    const auto movesAnchor = [&](int i) { return std::binary_search(anchorMovers.begin(), anchorMovers.end(), i); };
    const auto moves = [&](int i, int h) {
        const auto& moved = samples_[static_cast<std::size_t>(i)].moved;
        return std::binary_search(moved.begin(), moved.end(), h);
    };
    // Goals and poles: helpers moved by what moves k apart from its anchor; fixed ones (no parameter moves them)
    // are goals too, aim targets.
    std::vector<int> helpers, fixed;
    for (std::size_t h = 0; h < helper_.size(); ++h) {
        const int hh = static_cast<int>(h);
        if (!helper_[h] || hh == k || hh == anchor || below(hh, k) || !usableAnchor(hh, state)) continue;
        if (std::any_of(movers.begin(), movers.end(), [&](int i) { return !movesAnchor(i) && moves(i, hh); }))
            helpers.push_back(hh);
        else if (moversOf(hh).empty()) fixed.push_back(hh);
    }
    if (helpers.empty() && fixed.empty()) return std::nullopt;
    candidates = true;
    // The poses vary what moves k through its inputs; its own parameters stay at rest.
    std::vector<int> varied;
    for (const int i : movers)
        if (movesAnchor(i) || std::any_of(helpers.begin(), helpers.end(), [&](int h) { return moves(i, h); }))
            varied.push_back(i);
    std::vector<int> goals = helpers;
    goals.insert(goals.end(), fixed.begin(), fixed.end());
    if (std::optional<ConstraintBase> chain = fitVaried(k, anchor, root, varied, helpers, goals, closest)) return chain;
    // Where none fits, the anchor's movers that stretch k are held at rest and the chain fitted on the others (a
    // spider's legs under a body whose control's scale channels shear them: 0.076 to 0.155 cm per unit off with them).
    const std::vector<int> stretching = stretchingAnchorMovers(k, varied, anchor);
    if (stretching.empty()) return std::nullopt;
    std::vector<int> rigid;
    std::set_difference(varied.begin(), varied.end(), stretching.begin(), stretching.end(), std::back_inserter(rigid));
    Closest without;
    std::optional<ConstraintBase> chain = fitVaried(k, anchor, root, rigid, helpers, goals, without);
    if (!chain) return std::nullopt;
    const auto& names = probe_.rig().outputs();
    for (const int i : stretching)
        hold(i, fmt::format("it scales or shears {} (moving its chain's anchor {}), which a planar chain, a rigid "
                            "motion, cannot carry; it is held at its rest value",
                            names[static_cast<std::size_t>(k)], names[static_cast<std::size_t>(anchor)]));
    return chain;
}

std::optional<ConstraintBase> ConstraintFitter::fitVaried(int k, int anchor, int root, const std::vector<int>& varied,
                                                          const std::vector<int>& helpers,
                                                          const std::vector<int>& goals, Closest& closest)
{
    if (std::optional<ConstraintBase> chain = fitChain(k, anchor, root, varied, helpers, goals, closest)) return chain;
    for (const int orient : orientSources(k, varied, helpers))
        if (std::optional<ConstraintBase> chain = fitChain(k, anchor, root, varied, helpers, goals, closest, orient))
            return chain;
    return std::nullopt;
}

ConstraintFitter::Carried ConstraintFitter::carried(int k, const RigState& state, bool fixedHelpers) const
{
    Carried c;
    // The nearest modelled ancestor, whatever models it (a ball under an ankle that is itself a chain's end).
    c.anchor = hierarchy_[static_cast<std::size_t>(k)];
    while (c.anchor >= 0 && !modelled(c.anchor, state)) c.anchor = hierarchy_[static_cast<std::size_t>(c.anchor)];
    const std::vector<int> movers = moversOf(k);
    const auto moves = [&](int i, int o) {
        const auto& moved = samples_[static_cast<std::size_t>(i)].moved;
        return o >= 0 && std::binary_search(moved.begin(), moved.end(), o);
    };
    for (std::size_t h = 0; h < helper_.size(); ++h) {
        const int hh = static_cast<int>(h);
        if (helper_[h] && hh != k && hh != c.anchor && !below(hh, k) && modelled(hh, state) &&
            ((fixedHelpers && moversOf(hh).empty()) ||
             std::any_of(movers.begin(), movers.end(), [&](int i) { return moves(i, hh); })))
            c.helpers.push_back(hh);
    }
    // The poses vary what moves k through its anchor or a helper; its own parameters compose after the base.
    for (const int i : movers)
        if (moves(i, c.anchor) || std::any_of(c.helpers.begin(), c.helpers.end(), [&](int h) { return moves(i, h); }))
            c.varied.push_back(i);
    return c;
}

std::optional<ConstraintBase> ConstraintFitter::fitOriented(int k, const RigState& state, Closest& closest)
{
    // Its position carried by its nearest modelled ancestor, and its rotation a helper's that what moves k moves.
    const auto [anchor, sources, varied] = carried(k, state, false);
    const auto& names = probe_.rig().outputs();
    for (const int orient : orientSources(k, varied, sources)) {
        ConstraintBase base;
        base.kind = ConstraintKind::oriented;
        base.anchor = anchor;
        base.orient = orient;
        base.origin = probe_.rest()[static_cast<std::size_t>(k)].block<3, 1>(0, 3);
        const double e =
            std::max(error(k, base, poses(varied, 0, rangePoses)), error(k, base, poses(varied, 1, checkPoses)));
        if (e <= options_.epsilon) return base;
        if (!(e < closest.error)) continue;
        closest.error = e;
        closest.what = fmt::format("an oriented base (carried by {}, turning as {})",
                                   anchor < 0 ? "the world" : names[static_cast<std::size_t>(anchor)],
                                   names[static_cast<std::size_t>(orient)]);
    }
    return std::nullopt;
}

std::optional<ConstraintBase> ConstraintFitter::fitAimed(int k, const RigState& state, Closest& closest)
{
    // Its origin carried by its nearest modelled ancestor (an ankle under an IK knee), and its line from there turned
    // minimally onto a helper that what moves k moves, or a fixed one.
    const auto [anchor, goals, varied] = carried(k, state, true);
    const auto& rest = probe_.rest();
    const auto& names = probe_.rig().outputs();
    const Eigen::Vector3d root = rest[static_cast<std::size_t>(k)].block<3, 1>(0, 3);
    // Turned minimally from the anchor's turn, or (Maya's ikSCsolver) from the goal's: the handle's orientation, which
    // the bone turns toward about its line.
    for (const bool goalTurns : {false, true})
        for (const int goal : goals) {
            ConstraintBase base;
            base.anchor = anchor;
            base.goal = goal;
            base.root = root;
            base.restPlane = base.minimalTurn = true;
            base.goalTurns = goalTurns;
            base.goalRest = rest[static_cast<std::size_t>(goal)].block<3, 3>(0, 0);
            base.restNormal =
                (rest[static_cast<std::size_t>(goal)].block<3, 1>(0, 3) - root).normalized().unitOrthogonal();
            base.lineTurn = lineTurnAt(root, base.restNormal);
            base.origin = root;
            // One bone does not bend: its shape is constant, as an aim's at a fixed point.
            const double e = tryCandidate(k, k, varied, true, base);
            if (e <= options_.epsilon) return base;
            if (!(e < closest.error)) continue;
            closest.error = e;
            closest.what = fmt::format("a one-bone chain (carried by {}, turned {} onto {})",
                                       anchor < 0 ? "the world" : names[static_cast<std::size_t>(anchor)],
                                       goalTurns ? "by its goal, then minimally," : "minimally",
                                       names[static_cast<std::size_t>(goal)]);
        }
    return std::nullopt;
}

std::vector<int> ConstraintFitter::rootCarriers(int k, int anchor, int root, const RigState& state)
{
    // The root's origin where the helper's motion takes it, to rounding, and moving on some pose.
    constexpr double carried = 1e-7;
    const auto& rest = probe_.rest();
    const Eigen::Vector3d root0 = rest[static_cast<std::size_t>(root)].block<3, 1>(0, 3);
    const std::vector<Pose>& checks = poses(moversOf(k), 0, rangePoses);
    const auto origin = [&](int o, const Pose& pose) -> Eigen::Vector3d {
        return pose.worlds[static_cast<std::size_t>(o)].block<3, 1>(0, 3);
    };
    std::vector<int> carriers;
    if (std::none_of(checks.begin(), checks.end(),
                     [&](const Pose& pose) { return (origin(root, pose) - root0).norm() > 1e3 * carried; }))
        return carriers;
    for (std::size_t h = 0; h < helper_.size(); ++h) {
        const int hh = static_cast<int>(h);
        if (!helper_[h] || hh == k || hh == anchor || below(hh, k) || !usableAnchor(hh, state)) continue;
        const Eigen::Matrix4d restInverse = rest[h].inverse();
        if (std::all_of(checks.begin(), checks.end(), [&](const Pose& pose) {
                const Eigen::Matrix4d motion = pose.worlds[h] * restInverse;
                const Eigen::Vector3d moved = motion.block<3, 3>(0, 0) * root0 + motion.block<3, 1>(0, 3);
                return (moved - origin(root, pose)).norm() <= carried * std::max(1.0, root0.norm());
            }))
            carriers.push_back(hh);
    }
    return carriers;
}

std::vector<int> ConstraintFitter::orientSources(int k, const std::vector<int>& varied, const std::vector<int>& helpers)
{
    // Rotations agree (their difference's Frobenius norm, about the angle between them in radians, well under what
    // epsilon allows at a frame's radius), and k turns (by a thousand times as much).
    constexpr double sameTurn = 1e-6;
    const auto& rest = probe_.rest();
    const auto turn = [&](int o, const Pose& pose) -> Eigen::Matrix3d {
        return polarRotation(pose.worlds[static_cast<std::size_t>(o)].block<3, 3>(0, 0)) *
               polarRotation(rest[static_cast<std::size_t>(o)].block<3, 3>(0, 0)).transpose();
    };
    const std::vector<Pose>& checks = poses(varied, 0, rangePoses);
    const bool turns = std::any_of(checks.begin(), checks.end(), [&](const Pose& pose) {
        return (turn(k, pose) - Eigen::Matrix3d::Identity()).norm() > 1e3 * sameTurn;
    });
    std::vector<int> sources;
    if (!turns) return sources;
    for (const int h : helpers)
        if (std::all_of(checks.begin(), checks.end(),
                        [&](const Pose& pose) { return (turn(k, pose) - turn(h, pose)).norm() < sameTurn; }))
            sources.push_back(h);
    return sources;
}

std::vector<Eigen::Vector3d> ConstraintFitter::restNormals(int chainRoot, const Eigen::Vector3d& root,
                                                           const Eigen::Vector3d& goal) const
{
    // The chain's rest plane through its line and a joint off it: one below the chain's root output, in rig order,
    // each plane once.
    // Then the plane through its line and the sum of the offsets from the root of the joints between it and the
    // chain's end (the joint nearest the goal): the side a chain of three bones or more turns to its pole vector
    // (mayaIkHandle's plane step; for two bones the mid joint's plane again).
    std::vector<Eigen::Vector3d> normals;
    const Eigen::Vector3d x = (goal - root).normalized();
    const auto add = [&](const Eigen::Vector3d& n) {
        if (!(n.norm() > 1e-6)) return;
        const Eigen::Vector3d unit = n.normalized();
        if (std::none_of(normals.begin(), normals.end(),
                         [&](const Eigen::Vector3d& m) { return (m - unit).norm() < 1e-9; }))
            normals.push_back(unit);
    };
    const auto origin = [&](int j) -> Eigen::Vector3d {
        return probe_.rest()[static_cast<std::size_t>(j)].block<3, 1>(0, 3);
    };
    int end = -1;
    for (std::size_t j = 0; j < hierarchy_.size(); ++j) {
        int up = static_cast<int>(j);
        while (up >= 0 && up != chainRoot) up = hierarchy_[static_cast<std::size_t>(up)];
        if (up != chainRoot) continue;
        add(x.cross(origin(static_cast<int>(j)) - root));
        if (end < 0 || (origin(static_cast<int>(j)) - goal).norm() < (origin(end) - goal).norm())
            end = static_cast<int>(j);
    }
    Eigen::Vector3d side = Eigen::Vector3d::Zero();
    for (int j = end < 0 ? -1 : hierarchy_[static_cast<std::size_t>(end)]; j >= 0 && j != chainRoot;
         j = hierarchy_[static_cast<std::size_t>(j)])
        side += origin(j) - root;
    add(x.cross(side));
    return normals;
}

std::vector<Eigen::Vector3d> ConstraintFitter::fixedPoles(int anchor, const Eigen::Vector3d& root,
                                                          const Eigen::Vector3d& goal) const
{
    // A point off the chain's line carried by the anchor: along one of the anchor's axes at rest (an aim's up
    // vector, a rotate-plane default), or any other when none is off the line.
    std::vector<Eigen::Vector3d> points;
    const double length = std::max(1.0, (goal - root).norm());
    const Eigen::Vector3d x = (goal - root).normalized();
    if (anchor >= 0)
        for (int axis = 0; axis < 3; ++axis) {
            const Eigen::Vector3d a = probe_.rest()[static_cast<std::size_t>(anchor)].block<3, 1>(0, axis).normalized();
            if ((a - a.dot(x) * x).norm() > 1e-3) points.push_back(root + length * a);
        }
    points.push_back(fixedPole(root, goal));
    return points;
}

std::optional<BlendFit> fitBlendRule(const std::vector<BlendSample>& samples, double tolerance, double frameRadius,
                                     BlendFit* closest)
{
    std::vector<BlendRule> rules;
    for (int order = 0; order < 6; ++order) rules.push_back({BlendMode::eulerChannels, *rotateOrderFromIndex(order)});
    rules.push_back({BlendMode::slerp, RotateOrder::xyz});
    BlendFit best{rules.front(), std::numeric_limits<double>::infinity()};
    for (const BlendRule& rule : rules) {
        double worst = 0.0;
        for (const BlendSample& s : samples) {
            const double e = matrixError(blendLocal(rule, s.weight, s.ik, s.fk), s.blended, frameRadius);
            worst = std::isfinite(e) ? std::max(worst, e) : std::numeric_limits<double>::infinity();
            if (worst > tolerance) break;
        }
        if (worst <= tolerance) return BlendFit{rule, worst};
        if (worst < best.error) best = {rule, worst};
    }
    if (closest) *closest = best;
    return std::nullopt;
}

}  // namespace rig
