#include "inversion/solve/pole_hold.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <set>

#include <Eigen/Dense>

namespace rig {
namespace {

// Below this distance from the chain's line the plane is not defined: the pole is left where it is.
constexpr double degenerateAcross = 1e-6;

Eigen::Matrix4d worldOf(const Approximation& a, int k, std::span<const double> values,
                        const std::vector<int>* controls = nullptr, Eigen::MatrixXd* columns = nullptr);

// A chain's points at `values`: its anchor's motion carries the root.
ChainPoints pointsAt(const Approximation& a, const ConstraintBase& c, std::span<const double> values)
{
    const Eigen::Matrix4d identity = Eigen::Matrix4d::Identity();
    const Eigen::Matrix4d anchor = c.anchor < 0
                                       ? identity
                                       : Eigen::Matrix4d(worldOf(a, c.anchor, values) *
                                                         a.outputs[static_cast<std::size_t>(c.anchor)].rest.inverse());
    return chainPoints(c, anchor, worldOf(a, c.goal, values), c.pole < 0 ? identity : worldOf(a, c.pole, values));
}

// Output k's world at `values`, evaluating only what it reads (its parents, its base's inputs). With `columns`, the
// pole's own translations' columns d(origin)/da are set there as they are met (their operators' axes through the
// product before them), in the order of `controls`.
Eigen::Matrix4d worldOf(const Approximation& a, int k, std::span<const double> values, const std::vector<int>* controls,
                        Eigen::MatrixXd* columns)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    for (std::size_t p = 0; p < a.parameters.size(); ++p) {
        const ModelledParameter& mp = a.parameters[p];
        const auto e = std::find(mp.outputs.begin(), mp.outputs.end(), k);
        if (e == mp.outputs.end()) continue;
        const Operator& op = mp.operators[static_cast<std::size_t>(
            mp.operatorOfOutput[static_cast<std::size_t>(e - mp.outputs.begin())])];
        const double offset = values[p] - mp.parameter.defaultValue;
        if (controls) {
            const auto c = std::find(controls->begin(), controls->end(), static_cast<int>(p));
            if (c != controls->end())
                columns->col(c - controls->begin()) = m.block<3, 3>(0, 0) * (op.magnitudeDerivative(offset) * op.axis);
        }
        m = m * op.matrix(offset);
    }
    const ApproximationOutput& output = a.outputs[static_cast<std::size_t>(k)];
    if (output.constraint >= 0) {
        const ConstraintBase& c = a.constraints[static_cast<std::size_t>(output.constraint)];
        const Eigen::Matrix4d orient =
            c.orient < 0 ? Eigen::Matrix4d::Identity()
                         : Eigen::Matrix4d(worldOf(a, c.orient, values) *
                                           a.outputs[static_cast<std::size_t>(c.orient)].rest.inverse());
        m = orientedBase(c, constraintBase(c, pointsAt(a, c, values)), orient) * m;
    } else if (output.parent >= 0) {
        m = worldOf(a, output.parent, values) * a.outputs[static_cast<std::size_t>(output.parent)].rest.inverse() * m;
    }
    return m * output.rest;
}

// The controls of a helper that are translations moving it alone, free of limits: where a cold start or a hold
// may put it. With `helpersToo`, those moving other helpers along with it too (no joint): where a cold start may
// put a goal whose control is also the frame an ankle's orient constraint reads (only its rotation counts there).
std::vector<int> ownTranslations(const Approximation& approximation, int helper, bool helpersToo = false)
{
    std::vector<int> controls;
    for (std::size_t p = 0; p < approximation.parameters.size(); ++p) {
        const ModelledParameter& m = approximation.parameters[p];
        const bool moves = std::find(m.outputs.begin(), m.outputs.end(), helper) != m.outputs.end();
        const bool alone =
            m.outputs.size() == 1 || (helpersToo && std::all_of(m.outputs.begin(), m.outputs.end(), [&](int k) {
                                          return approximation.outputs[static_cast<std::size_t>(k)].helper;
                                      }));
        if (!moves || !alone || m.parameter.limited) continue;
        if (std::all_of(m.operators.begin(), m.operators.end(), [](const Operator& op) {
                return op.kind == OperatorKind::translation && op.linear() && !op.held();
            }))
            controls.push_back(static_cast<int>(p));
    }
    return controls;
}

// Moves `controls` (translations of helper k alone) so that k's origin is at `wanted`, as near as they can.
void place(const Approximation& approximation, int k, const std::vector<int>& controls, const Eigen::Vector3d& wanted,
           std::span<double> values)
{
    Eigen::MatrixXd j(3, static_cast<Eigen::Index>(controls.size()));
    const Eigen::Vector3d now = worldOf(approximation, k, values, &controls, &j).block<3, 1>(0, 3);
    const Eigen::VectorXd step = j.completeOrthogonalDecomposition().solve(wanted - now);
    for (std::size_t i = 0; i < controls.size(); ++i)
        values[static_cast<std::size_t>(controls[i])] += step[static_cast<Eigen::Index>(i)];
}

// Where a cold start puts a chain's goal for a straight target (below).
Eigen::Vector3d pastKink(const Approximation& approximation, const ConstraintBase& c, std::span<const double> values,
                         const Eigen::Vector3d& goal);

// Whether output k is learned relative to `ancestor`, through its parent outputs.
bool under(const Approximation& approximation, int k, int ancestor)
{
    for (int p = approximation.outputs[static_cast<std::size_t>(k)].parent; p >= 0;
         p = approximation.outputs[static_cast<std::size_t>(p)].parent)
        if (p == ancestor) return true;
    return false;
}

// A chain's targeted members: the outputs on a base with its goal and pole. Its end is the one nearest the goal at
// rest, or an output under it nearer still; its middle the member furthest from the root-goal line.
struct ChainMembers {
    int end = -1;  // -1: no member has an active target
    int middle = -1;
    // An output on the goal turning as another output (an ankle orient-constrained to its foot: its own base, whose
    // pole is that foot), whose target the guess turns the foot to.
    bool turnedOutput = false;
};

ChainMembers chainMembers(const Approximation& approximation, const ConstraintBase& c,
                          std::span<const JointTarget> targets)
{
    const auto origin = [&](std::size_t k) -> Eigen::Vector3d {
        return approximation.outputs[k].rest.block<3, 1>(0, 3);
    };
    const Eigen::Vector3d restGoal = origin(static_cast<std::size_t>(c.goal));
    const Eigen::Vector3d x0 = (restGoal - c.root).normalized();
    ChainMembers members;
    double nearest = 0.0, furthest = 0.0;
    for (std::size_t k = 0; k < approximation.outputs.size(); ++k) {
        const int b = approximation.outputs[k].constraint;
        if (b < 0) continue;
        const ConstraintBase& m = approximation.constraints[static_cast<std::size_t>(b)];
        members.turnedOutput = members.turnedOutput || (m.goal == c.goal && m.orient >= 0 && targets[k].active);
        if (m.goal != c.goal || m.pole != c.pole || !targets[k].active) continue;
        const Eigen::Vector3d o = origin(k) - c.root;
        const double toGoal = (origin(k) - restGoal).norm();
        const double across = (o - o.dot(x0) * x0).norm();
        if (members.end < 0 || toGoal < nearest) members.end = static_cast<int>(k), nearest = toGoal;
        if (members.middle < 0 || across > furthest) members.middle = static_cast<int>(k), furthest = across;
    }
    if (members.end < 0) return members;
    // The chain's effector may be no member: an ankle that the IK handle does not turn, a child of the knee (a space
    // switch's leg). Placing the goal by the knee's target left such legs bent the wrong way from every start.
    const int nearestMember = members.end;
    for (std::size_t k = 0; k < approximation.outputs.size(); ++k) {
        if (!targets[k].active || !under(approximation, static_cast<int>(k), nearestMember)) continue;
        const double toGoal = (origin(k) - restGoal).norm();
        if (toGoal < nearest) members.end = static_cast<int>(k), nearest = toGoal;
    }
    return members;
}

// Where the chain's end target puts its goal (with the goal's rest offset from the end): none without an end target.
std::optional<Eigen::Vector3d> goalByEnd(const Approximation& approximation, const ConstraintBase& c,
                                         std::span<const JointTarget> targets)
{
    const int end = chainMembers(approximation, c, targets).end;
    if (end < 0) return std::nullopt;
    const auto origin = [&](int k) -> Eigen::Vector3d {
        return approximation.outputs[static_cast<std::size_t>(k)].rest.block<3, 1>(0, 3);
    };
    return Eigen::Vector3d(targets[static_cast<std::size_t>(end)].world.block<3, 1>(0, 3) +
                           (origin(c.goal) - origin(end)));
}

}  // namespace

std::vector<PoleHold> poleHolds(const Approximation& approximation)
{
    std::vector<PoleHold> holds;
    std::set<int> poles;
    for (std::size_t i = 0; i < approximation.constraints.size(); ++i) {
        const ConstraintBase& c = approximation.constraints[i];
        // A pole its output's rotation carries (poleTurns) sits at a set distance from the root: nothing to hold.
        if (c.kind != ConstraintKind::planarChain || c.pole < 0 || c.poleTurns || !poles.insert(c.pole).second)
            continue;
        PoleHold hold;
        hold.constraint = static_cast<int>(i);
        hold.parameters = ownTranslations(approximation, c.pole);
        if (hold.parameters.empty()) continue;
        const Eigen::Vector3d x =
            (approximation.outputs[static_cast<std::size_t>(c.goal)].rest.block<3, 1>(0, 3) - c.root).normalized();
        const Eigen::Vector3d offset = c.restPole - c.root;
        hold.along = offset.dot(x);
        hold.across = (offset - hold.along * x).norm();
        holds.push_back(std::move(hold));
    }
    return holds;
}

void holdPoles(const Approximation& approximation, std::span<const PoleHold> holds, std::span<double> values)
{
    for (const PoleHold& hold : holds) {
        const ConstraintBase& c = approximation.constraints[static_cast<std::size_t>(hold.constraint)];
        const ChainPoints points = pointsAt(approximation, c, values);
        const Eigen::Vector3d x = (points.goal - points.root).normalized();
        const Eigen::Vector3d offset = points.pole - points.root;
        const Eigen::Vector3d w = offset - offset.dot(x) * x;
        if (!(w.norm() > degenerateAcross) || !x.allFinite()) continue;
        place(approximation, c.pole, hold.parameters, points.root + hold.along * x + hold.across * w.normalized(),
              values);
    }
}

void placeChain(const Approximation& approximation, int constraint, std::span<const PoleHold> holds,
                std::span<const JointTarget> targets, std::span<const int> free, std::span<double> values)
{
    const auto freeOf = [&](std::vector<int> controls) {
        std::erase_if(controls, [&](int p) { return !std::binary_search(free.begin(), free.end(), p); });
        return controls;
    };
    const ConstraintBase& c = approximation.constraints[static_cast<std::size_t>(constraint)];
    const auto origin = [&](int k) -> Eigen::Vector3d {
        return approximation.outputs[static_cast<std::size_t>(k)].rest.block<3, 1>(0, 3);
    };
    const ChainMembers members = chainMembers(approximation, c, targets);
    const int end = members.end, middle = members.middle;
    if (end < 0) return;
    const Eigen::Vector3d restGoal = origin(c.goal);
    const Eigen::Vector3d x0 = (restGoal - c.root).normalized();
    // The goal's control may move other helpers too (the foot whose frame an ankle's or a ball's orient constraint
    // reads, the pivots under it): their translation changes no rotation a constraint reads. Not for a pole that turns
    // with the foot where no output on the goal turns as the foot: there the foot's rotation, which turns the chain's
    // plane, is left to the step's solve from its rest while its translation is placed, and on random legs (a
    // mayaIkHandle without a pole, the ball orient-constrained, the ankle under its own control) that start stuck 4 of
    // 8 poses (tests/inversion/learn/random_character_test.cpp).
    const bool helpersToo = !c.poleTurns || members.turnedOutput;
    const std::vector<int> goalControls = freeOf(ownTranslations(approximation, c.goal, helpersToo));
    if (!goalControls.empty())
        place(approximation, c.goal, goalControls,
              pastKink(approximation, c, values,
                       targets[static_cast<std::size_t>(end)].world.block<3, 1>(0, 3) + (restGoal - origin(end))),
              values);
    const auto hold = std::find_if(holds.begin(), holds.end(), [&](const PoleHold& h) {
        return approximation.constraints[static_cast<std::size_t>(h.constraint)].pole == c.pole;
    });
    if (hold == holds.end() || middle == end) return;
    const std::vector<int> poleControls = freeOf(hold->parameters);
    if (poleControls.empty()) return;
    const ChainPoints points = pointsAt(approximation, c, values);
    const Eigen::Vector3d root = points.root;
    const Eigen::Vector3d x = (points.goal - root).normalized();
    const Eigen::Vector3d knee = targets[static_cast<std::size_t>(middle)].world.block<3, 1>(0, 3) - root;
    const Eigen::Vector3d w = knee - knee.dot(x) * x;
    if (!(w.norm() > degenerateAcross) || !x.allFinite()) return;
    // The pole on the knee's side of the line, as it is at rest.
    const Eigen::Vector3d restKnee = origin(middle) - c.root, restPole = c.restPole - c.root;
    const double side = (restKnee - restKnee.dot(x0) * x0).dot(restPole - restPole.dot(x0) * x0) < 0.0 ? -1.0 : 1.0;
    place(approximation, c.pole, poleControls, root + hold->along * x + side * hold->across * w.normalized(), values);
}

namespace {

// Knot values this close are the same shape (rotation vector in radians, translation in cm).
constexpr double flatTolerance = 1e-9;
// How far inside the flat reach a held goal sits, as a share of the rest reach: on the bend's side of the last knot
// with a slope, and near enough that the joints do not move (a shape's slope times this is under 1e-6 cm).
constexpr double insideReach = 1e-8;
// A target this near the flat reach (a share of the rest reach) is straight, and a goal placed for it goes this far
// past: far enough that the next frames' steps, which leave the distance of a straight chain's goal where it is, do not
// bring it back onto the kink as the root moves (0.1% of the rest reach: 3882 iterations over the random characters' IK
// clips; 5%: 3550, against 3591 with the goal placed by the knee's target).
constexpr double straightReach = 1e-6;
constexpr double pastReach = 5e-2;
// An end target this far inside the flat reach (a share of the rest reach) bends the chain: a held goal goes there. A
// straight target's end lies between the straightening and the first flat knot, closer than this.
constexpr double bentReach = 1e-4;

// The reach (the root-goal distance, cm) from which a chain's shape stays put: the first of the knots whose values are
// all the same to the end, more than one of them, after knots where it changes; else infinity.
double flatFrom(const ConstraintBase& c)
{
    const auto& knots = c.shape.rigid.knots();
    const auto& y = c.shape.rigid.values();
    if (knots.size() < 3) return std::numeric_limits<double>::infinity();
    std::size_t first = knots.size() - 1;
    while (first > 0 && (y[first - 1] - y.back()).cwiseAbs().maxCoeff() <= flatTolerance) --first;
    // Still changing at its last knot (stretch), or never (an aim: its goal's distance is held by no reach).
    if (first + 1 >= knots.size() || first == 0) return std::numeric_limits<double>::infinity();
    return c.restReach + knots[first];
}

// An aim: a planar chain whose shape is the same at every knot.
bool isAim(const ConstraintBase& c)
{
    const auto& y = c.shape.rigid.values();
    return c.kind == ConstraintKind::planarChain && !y.empty() && std::all_of(y.begin(), y.end(), [&](const auto& v) {
               return (v - y.front()).cwiseAbs().maxCoeff() <= flatTolerance;
           });
}

// The root-goal distance past which every chain on `goal` stays put (the furthest of their flat reaches).
double flatReachOf(const Approximation& approximation, int goal)
{
    double reach = 0.0;
    for (const ConstraintBase& other : approximation.constraints)
        if (other.kind == ConstraintKind::planarChain && other.goal == goal) reach = std::max(reach, flatFrom(other));
    return reach;
}

// A goal placed where a straight target puts it, at the reach where the chain's shape flattens, sits on a kink: the
// bend's slope is unbounded on its inside and zero past it, and steps from there crawl (a character's first frame took
// 30 iterations and was left a best fit). The goal is moved past the kink along the chain's line, where the straight
// shape is exact.
Eigen::Vector3d pastKink(const Approximation& approximation, const ConstraintBase& c, std::span<const double> values,
                         const Eigen::Vector3d& goal)
{
    const double flat = flatReachOf(approximation, c.goal);
    if (!std::isfinite(flat)) return goal;
    const Eigen::Vector3d root = pointsAt(approximation, c, values).root;
    const Eigen::Vector3d line = goal - root;
    const double reach = line.norm();
    if (!(reach > flat - straightReach * c.restReach) || !std::isfinite(reach)) return goal;
    return root + (flat + pastReach * c.restReach) / reach * line;
}

}  // namespace

std::vector<GoalHold> goalHolds(const Approximation& approximation)
{
    std::vector<GoalHold> holds;
    std::set<int> goals;
    for (std::size_t i = 0; i < approximation.constraints.size(); ++i) {
        const ConstraintBase& c = approximation.constraints[i];
        if (c.kind != ConstraintKind::planarChain || !goals.insert(c.goal).second) continue;
        GoalHold hold;
        hold.constraint = static_cast<int>(i);
        hold.parameters = ownTranslations(approximation, c.goal);
        // Every chain on this goal must be flat past the reach held.
        hold.flatReach = flatReachOf(approximation, c.goal);
        if (hold.parameters.empty() || !std::isfinite(hold.flatReach)) continue;
        holds.push_back(std::move(hold));
    }
    return holds;
}

bool holdGoals(const Approximation& approximation, std::span<const GoalHold> holds,
               std::span<const JointTarget> targets, std::span<double> values)
{
    bool moved = false;
    for (const GoalHold& hold : holds) {
        const ConstraintBase& c = approximation.constraints[static_cast<std::size_t>(hold.constraint)];
        const ChainPoints points = pointsAt(approximation, c, values);
        const Eigen::Vector3d line = points.goal - points.root;
        const double reach = line.norm();
        if (!(reach > hold.flatReach) || !std::isfinite(reach)) continue;
        const double held = hold.flatReach - insideReach * c.restReach;
        // Where the end's target bends the chain, the goal goes there: just inside the flat reach the bend's slope is
        // unbounded, and the steps from there crawl (UsdExportEulerFilterTest.ma's second frame, 9 iterations halving
        // their steps; 2 from its end's target).
        const std::optional<Eigen::Vector3d> byEnd = goalByEnd(approximation, c, targets);
        const bool bent = byEnd && (*byEnd - points.root).norm() < hold.flatReach - bentReach * c.restReach;
        place(approximation, c.goal, hold.parameters,
              bent ? *byEnd : Eigen::Vector3d(points.root + held / reach * line), values);
        moved = true;
    }
    return moved;
}

std::vector<AimHold> aimHolds(const Approximation& approximation)
{
    std::vector<AimHold> holds;
    std::set<int> targets;
    for (std::size_t i = 0; i < approximation.constraints.size(); ++i) {
        const ConstraintBase& c = approximation.constraints[i];
        if (c.kind != ConstraintKind::planarChain || !targets.insert(c.goal).second) continue;
        // Every chain on the target an aim from the same point, carried by the same anchor.
        const bool oneEye = std::all_of(approximation.constraints.begin(), approximation.constraints.end(),
                                        [&](const ConstraintBase& other) {
                                            return other.kind != ConstraintKind::planarChain || other.goal != c.goal ||
                                                   (isAim(other) && other.anchor == c.anchor &&
                                                    (other.root - c.root).norm() <= 1e-9 * (1.0 + c.root.norm()));
                                        });
        AimHold hold{static_cast<int>(i), ownTranslations(approximation, c.goal)};
        if (oneEye && !hold.parameters.empty()) holds.push_back(std::move(hold));
    }
    return holds;
}

void aimReaches(const Approximation& approximation, std::span<const AimHold> holds, std::span<const double> values,
                std::vector<double>& reaches)
{
    reaches.resize(holds.size());
    for (std::size_t h = 0; h < holds.size(); ++h) {
        const ConstraintBase& c = approximation.constraints[static_cast<std::size_t>(holds[h].constraint)];
        const ChainPoints points = pointsAt(approximation, c, values);
        reaches[h] = (points.goal - points.root).norm();
    }
}

void holdAims(const Approximation& approximation, std::span<const AimHold> holds, std::span<const double> reaches,
              std::span<double> values)
{
    for (std::size_t h = 0; h < holds.size(); ++h) {
        const ConstraintBase& c = approximation.constraints[static_cast<std::size_t>(holds[h].constraint)];
        const ChainPoints points = pointsAt(approximation, c, values);
        const Eigen::Vector3d line = points.goal - points.root;
        const double reach = line.norm();
        // On the root the line of sight is undefined: left where it is.
        if (!(reach > degenerateAcross) || !std::isfinite(reach) || !std::isfinite(reaches[h]) ||
            !(reaches[h] > degenerateAcross))
            continue;
        place(approximation, c.goal, holds[h].parameters, points.root + reaches[h] / reach * line, values);
    }
}

}  // namespace rig
