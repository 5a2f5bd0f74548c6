// ikHandle: a two-bone rotate-plane IK solver (Maya's ikHandle with the ikRPsolver) as a DG node that
// outputs the start and mid joints' rotate values (and stretched translates). The chain's rest values
// are constant inputs: the node cannot read the joints it drives (no cycles at node level).

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <utility>

#include <Eigen/Geometry>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"
#include "nodes/enum_names.h"
#include "nodes/transform_math.h"

namespace rig {
namespace {

enum Attr : AttrId {
    StartParentMatrix,
    StartInverseScale,
    StartTranslate,
    StartJointOrient,
    StartRotateOrder,
    MidTranslate,
    MidJointOrient,
    MidRotateOrder,
    EndTranslate,
    GoalMatrix,
    PoleVector,
    Twist,
    Stretch,
    Softness,
    BendAxis,
    MidSlide,
    MidSlideQuadratic,
    MidSlideAxis,
    StartRotate,
    MidRotate,
    OutMidTranslate,
    OutEndTranslate
};

// Relative tolerances: a direction whose length is below this fraction of the lengths it came from
// is treated as undefined (parallel vectors, a goal at the start).
constexpr double parallelTolerance = 1e-9;

RotateOrder orderOf(int index) { return rotateOrderFromIndex(index).value_or(RotateOrder::xyz); }

// The rotate value for `rotation`, among the equivalent Euler triples the one nearest to zero (a
// knee bending 120 degrees about Y reads (0, 120, 0), not (180, 60, 180)).
Eigen::Vector3d eulerNearZero(const Eigen::Matrix3d& rotation, RotateOrder order)
{
    return closestEuler(matrixToEuler(rotation, order), Eigen::Vector3d::Zero(), order);
}

// A unit vector perpendicular to `direction` (unit), from the first candidate not parallel to it.
Eigen::Vector3d perpendicularFrom(const Eigen::Vector3d& direction, std::initializer_list<Eigen::Vector3d> candidates)
{
    for (const Eigen::Vector3d& c : candidates) {
        const Eigen::Vector3d p = c - c.dot(direction) * direction;
        if (p.norm() > 1e-6 * c.norm()) return p.normalized();
    }
    return direction.unitOrthogonal();
}

// |v| without overflow for far goals. Eigen's stableNorm sums the elements before the first 16-byte aligned one
// apart, so its last bit depends on where v lies in memory: taken on an aligned copy, it is the same wherever the
// caller keeps v (the solution does not change when a refactoring moves a vector into a struct).
double stableNorm(const Eigen::Vector3d& v)
{
    alignas(16) const Eigen::Vector3d copy = v;
    return copy.stableNorm();
}

struct Solution {
    Eigen::Vector3d startRotate = Eigen::Vector3d::Zero();
    Eigen::Vector3d midRotate = Eigen::Vector3d::Zero();
    Eigen::Vector3d midTranslate = Eigen::Vector3d::Zero();
    Eigen::Vector3d endTranslate = Eigen::Vector3d::Zero();
};

struct Inputs {
    Eigen::Matrix4d parent;
    Eigen::Vector3d inverseScale, startTranslate, startOrient, midTranslate, midOrient, endTranslate, pole;
    RotateOrder startOrder, midOrder;
    Eigen::Vector3d goal;
    double twist, softness;
    bool stretch;
    Eigen::Vector3d bendAxis;  // mid joint rotate space; zero = the rest plane's normal
    double slide, slideQuadratic;
    int slideAxis;
};

// A hinge about a given axis whose mid joint slides along the upper bone's frame as it bends (slidingPivot's
// knee), in the start joint's frame before stretch. Positive angles about the axis bend the chain.
struct HingeChain {
    Eigen::Vector3d upper, restLower, axis, slideDirection;
    double slide, slideQuadratic;

    Eigen::Vector3d mid(double angle) const
    {
        return upper + (slide * angle + slideQuadratic * angle * angle) * slideDirection;
    }
    Eigen::Vector3d lower(double angle) const { return Eigen::AngleAxisd(angle, axis) * restLower; }
    double distance(double angle) const { return (mid(angle) + lower(angle)).norm(); }

    // |start -> end|^2 - reach^2 and its derivative in the angle.
    std::pair<double, double> residual(double angle, double reach) const
    {
        const Eigen::Vector3d l = lower(angle);
        const Eigen::Vector3d end = mid(angle) + l;
        const Eigen::Vector3d velocity = (slide + 2.0 * slideQuadratic * angle) * slideDirection + axis.cross(l);
        return {end.squaredNorm() - reach * reach, 2.0 * end.dot(velocity)};
    }

    // Half the slope of the squared distance in the angle, end . velocity, and its own derivative.
    std::pair<double, double> slope(double angle) const
    {
        const Eigen::Vector3d l = lower(angle);
        const Eigen::Vector3d end = mid(angle) + l;
        const Eigen::Vector3d velocity = (slide + 2.0 * slideQuadratic * angle) * slideDirection + axis.cross(l);
        const Eigen::Vector3d acceleration = 2.0 * slideQuadratic * slideDirection + axis.cross(axis.cross(l));
        return {end.dot(velocity), velocity.squaredNorm() + end.dot(acceleration)};
    }

    // upper . lower(angle) = p + m cos(angle - phi) for the rigid hinge: phi is where it is straightest.
    double straightest() const
    {
        const Eigen::Vector3d across = restLower - restLower.dot(axis) * axis;
        return std::atan2(upper.dot(axis.cross(across)), upper.dot(across));
    }

    // The end of the bending branch: the angle past phi, up to phi + pi, where the end is nearest the start. A sliding
    // mid joint can bring the end nearest a little before the fold is complete (the biped's knee, 0.2 degrees before):
    // the branch ends there, so that the distance falls all along it and a goal nearer than any reach clamps to the
    // nearest pose, not to the complete fold, which a goal just past that reach would jump back from.
    double folded(double phi) const
    {
        const auto falling = [&](double angle) { return slope(angle).first < 0.0; };
        double hi = phi + std::numbers::pi;
        if (falling(hi)) return hi;
        // The distance rises at the complete fold: the nearest angle is where its slope changes sign, bracketed by
        // stepping back from the fold to a falling angle, then found by Newton's method inside the bracket (a few
        // steps: the ikHandle solves every evaluation).
        constexpr int steps = 64;
        double lo = hi;
        for (int step = 1; step <= steps && !falling(lo); ++step) lo = hi - std::numbers::pi * step / steps;
        if (!falling(lo)) return hi;
        double x = hi;
        for (int iteration = 0; iteration < 100; ++iteration) {
            const auto [s, ds] = slope(x);
            (s < 0.0 ? lo : hi) = x;
            const double newton = x - s / ds;
            const double next = ds > 0.0 && newton > lo && newton < hi ? newton : 0.5 * (lo + hi);
            const bool done = std::abs(next - x) <= 1e-15 * (1.0 + std::abs(x));
            x = next;
            if (done) break;
        }
        return x;
    }

    // The angle on the bending branch, phi to folded(phi), that puts the end `reach` from the start: Newton from
    // the rigid hinge's closed form, kept inside a shrinking bracket (the distance falls along the branch); a
    // reach beyond the branch's ends clamps to them.
    double angle(double phi, double reach) const
    {
        double lo = phi, hi = folded(phi);
        if (!(residual(lo, reach).first > 0.0)) return lo;
        if (!(residual(hi, reach).first < 0.0)) return hi;
        const Eigen::Vector3d along = restLower.dot(axis) * axis;
        const Eigen::Vector3d across = restLower - along;
        const double m = std::hypot(upper.dot(across), upper.dot(axis.cross(across)));
        const double c =
            (reach * reach - upper.squaredNorm() - restLower.squaredNorm() - 2.0 * upper.dot(along)) / (2.0 * m);
        double x = m > 0.0 ? phi + std::acos(std::clamp(c, -1.0, 1.0)) : 0.5 * (lo + hi);
        for (int iteration = 0; iteration < 100; ++iteration) {
            const auto [f, df] = residual(x, reach);
            if (f == 0.0) break;
            (f > 0.0 ? lo : hi) = x;
            const double newton = x - f / df;
            const double next = df < 0.0 && newton > lo && newton < hi ? newton : 0.5 * (lo + hi);
            const bool done = std::abs(next - x) <= 1e-15 * (1.0 + std::abs(x));
            x = next;
            if (done) break;
        }
        return x;
    }
};

// The rest pose: zero rotations, rest translates.
Solution rest(const Inputs& in)
{
    Solution s;
    s.midTranslate = in.midTranslate;
    s.endTranslate = in.endTranslate;
    return s;
}

// Solve space A: the start joint's frame before its jointOrient and rotate, A = parent * T * IS
// (IS undoes the parent's scale as the joint does with segmentScaleCompensate). In A the start
// joint sits at the origin and its orientation JO * R is a rotation; any affine parent maps the
// solution back exactly (goal reached, plane kept).
struct SolveSpace {
    Eigen::Vector3d goal, pole;  // in A
};

// Empty for a singular parent.
std::optional<SolveSpace> solveSpace(const Inputs& in)
{
    JointInputs frame;
    frame.translate = in.startTranslate;
    frame.inverseScale = in.inverseScale;
    const Eigen::Matrix4d a = in.parent * jointMatrix(frame);
    const Eigen::Matrix3d aLinear = a.topLeftCorner<3, 3>();
    const double columnProduct = aLinear.col(0).norm() * aLinear.col(1).norm() * aLinear.col(2).norm();
    if (!(std::abs(aLinear.determinant()) > 1e-12 * columnProduct)) return std::nullopt;
    const Eigen::Matrix3d aInverse = aLinear.inverse();
    return SolveSpace{aInverse * (in.goal - a.topRightCorner<3, 1>()), aInverse * in.pole};
}

// The chain at rest, in the start joint's frame, and the axis n it bends about.
struct RestChain {
    Eigen::Matrix3d startOrient, midOrient;
    Eigen::Vector3d u;      // start -> mid
    Eigen::Vector3d restB;  // mid -> end, at rest
    double l1, l2, length, tiny;
    bool twoBones;
    Eigen::Vector3d direction;  // along the chain
    Eigen::Vector3d n;
};

// Empty for a chain of zero length.
std::optional<RestChain> restChain(const Inputs& in)
{
    RestChain c;
    c.startOrient = eulerToMatrix(in.startOrient, RotateOrder::xyz);
    c.midOrient = eulerToMatrix(in.midOrient, RotateOrder::xyz);
    c.u = in.midTranslate;
    c.restB = c.midOrient * in.endTranslate;
    c.l1 = c.u.norm();
    c.l2 = in.endTranslate.norm();  // = |restB|, but free of midJointOrient's rounding
    c.length = c.l1 + c.l2;
    if (!(c.length > 0.0)) return std::nullopt;
    c.tiny = 1e-12 * std::max(1.0, c.length);
    c.twoBones = c.l1 > c.tiny && c.l2 > c.tiny;

    // Bend axis n (start joint frame): the normal of the rest chain plane, u x restB. A straight rest
    // chain falls back on the mid joint's Z axis (then Y, then X) made perpendicular to the chain.
    c.direction = (c.l1 > c.tiny ? c.u : c.restB).normalized();
    c.n = c.u.cross(c.restB);
    if (c.twoBones && c.n.norm() > parallelTolerance * c.l1 * c.l2) c.n.normalize();
    else c.n = perpendicularFrom(c.direction, {c.midOrient.col(2), c.midOrient.col(1), c.midOrient.col(0)});
    return c;
}

// How the mid joint bends: about n by the closed form (Maya's rotate-plane solver), or, with a given
// hinge axis or a mid joint that slides as it bends, as a hinge chain whose angle Newton finds. Its
// longest reach is where it is straightest.
struct Bend {
    bool hinge;
    Eigen::Vector3d localAxis;  // in the mid joint's rotate space
    HingeChain chain;
    double phi;      // the hinge chain's straightest angle
    double longest;  // the chain's longest reach
};

Bend bendOf(const Inputs& in, const RestChain& c)
{
    const bool hinge = c.twoBones && (in.bendAxis.squaredNorm() > 0.0 || in.slide != 0.0 || in.slideQuadratic != 0.0);
    const Eigen::Vector3d localAxis =
        in.bendAxis.squaredNorm() > 0.0 ? in.bendAxis.normalized() : Eigen::Vector3d(c.midOrient.transpose() * c.n);
    const HingeChain chain{c.u,      c.restB,          c.midOrient * localAxis, Eigen::Vector3d::Unit(in.slideAxis),
                           in.slide, in.slideQuadratic};
    const double phi = hinge ? chain.straightest() : 0.0;
    return Bend{hinge, localAxis, chain, phi, hinge ? chain.distance(phi) : c.length};
}

// Reach: soft IK eases the distance in over the last `softness` cm; stretch scales both bones by k.
struct Reach {
    double distance, reach, k;
};

Reach reachOf(const Inputs& in, const Eigen::Vector3d& goal, double longest)
{
    const double distance = stableNorm(goal);
    const double soft = std::clamp(in.softness, 0.0, longest);
    double reach = std::min(distance, longest);
    if (soft > 0.0 && distance > longest - soft)
        reach = (longest - soft) + soft * (1.0 - std::exp(-(distance - (longest - soft)) / soft));
    const double k = in.stretch && distance > reach && reach > 0.0 ? distance / reach : 1.0;
    return {distance, reach, k};
}

// The mid joint's rotation about n that puts the end `reach` from the start. theta is the angle from the
// upper bone to the lower one about n (0 = straight), theta0 its rest value.
double bendAngle(const RestChain& c, const Bend& bend, double reach)
{
    if (bend.hinge) return bend.chain.angle(bend.phi, reach);
    if (!c.twoBones) return 0.0;
    // Law of cosines, reach^2 = l1^2 + l2^2 + 2 l1 l2 cos(theta), in its half-angle form
    // sin^2(theta / 2) = (L - reach)(L + reach) / (4 l1 l2): exact at full extension, well
    // conditioned near it, and scale-free (the unscaled lengths cannot overflow).
    const double half = std::sqrt(std::clamp((c.length - reach) * (c.length + reach) / (4.0 * c.l1 * c.l2), 0.0, 1.0));
    const double theta = 2.0 * std::asin(half);
    const double theta0 = std::atan2(c.u.cross(c.restB).dot(c.n), c.u.dot(c.restB));
    return theta - theta0;
}

// The chain bent by `delta` and scaled by k (start joint frame), and its plane's normal.
struct BentChain {
    Eigen::Vector3d upper, lower, normal;
};

BentChain bentChain(const RestChain& c, const Bend& bend, double delta, double k)
{
    BentChain b;
    b.upper = k * (bend.hinge ? bend.chain.mid(delta) : c.u);
    b.lower = bend.hinge ? Eigen::Vector3d(k * bend.chain.lower(delta))
                         : Eigen::Vector3d(Eigen::AngleAxisd(delta, c.n) * (k * c.restB));
    // The plane's normal: the rest plane's, or the bent hinge chain's (on a straight one, the hinge axis made
    // perpendicular to the chain, its limit as the chain starts to bend).
    b.normal = c.n;
    if (bend.hinge) {
        b.normal = b.upper.cross(b.lower);
        const double size = b.normal.norm();
        if (size > parallelTolerance * b.upper.norm() * b.lower.norm()) b.normal /= size;
        else b.normal = perpendicularFrom((b.upper + b.lower).normalized(), {bend.chain.axis, c.n});
    }
    return b;
}

// Chain frame (start joint frame): x1 towards the end, y1 towards the mid joint's side, z1 = -normal.
Eigen::Matrix3d chainFrame(const RestChain& c, const BentChain& b)
{
    const Eigen::Vector3d end = b.upper + b.lower;
    const Eigen::Vector3d x1 = end.norm() > c.tiny ? end.normalized() : perpendicularFrom(b.normal, {c.direction});
    const Eigen::Vector3d y1 = perpendicularFrom(x1, {x1.cross(b.normal), c.direction});
    Eigen::Matrix3d b1;
    b1 << x1, y1, x1.cross(y1);
    return b1;
}

// Goal frame (space A): x2 towards the goal, y2 towards the pole vector, then twisted about x2.
Eigen::Matrix3d goalFrame(const Inputs& in, const RestChain& c, const SolveSpace& space, double distance)
{
    const Eigen::Vector3d restEnd = c.u + c.restB;
    Eigen::Vector3d x2 = c.startOrient * (restEnd.norm() > c.tiny ? restEnd.normalized() : c.direction);
    if (distance > c.tiny) x2 = space.goal / distance;
    const double poleLength = stableNorm(space.pole);
    const Eigen::Vector3d poleDirection = poleLength > 0.0 && std::isfinite(poleLength)
                                              ? Eigen::Vector3d(space.pole / poleLength)
                                              : Eigen::Vector3d::Zero();
    const Eigen::Vector3d polePerpendicular = poleDirection - poleDirection.dot(x2) * x2;
    Eigen::Vector3d y2;
    if (polePerpendicular.norm() > parallelTolerance) y2 = polePerpendicular.normalized();
    else  // no usable pole: keep the rest plane, whose normal is startOrient * n
        y2 = perpendicularFrom(x2, {x2.cross(c.startOrient * c.n), c.startOrient * c.direction});
    const Eigen::Vector3d y2Twisted = std::cos(in.twist) * y2 + std::sin(in.twist) * x2.cross(y2);
    Eigen::Matrix3d b2;
    b2 << x2, y2Twisted, x2.cross(y2Twisted);
    return b2;
}

Solution solve(const Inputs& in)
{
    const std::optional<SolveSpace> space = solveSpace(in);
    if (!space) return rest(in);
    const std::optional<RestChain> c = restChain(in);
    if (!c) return rest(in);
    const Bend bend = bendOf(in, *c);
    const Reach reach = reachOf(in, space->goal, bend.longest);
    const double delta = bendAngle(*c, bend, reach.reach);
    const double k = reach.k;

    // Start joint orientation in A: Q = B2 * B1^T = JO * R.
    const Eigen::Matrix3d q =
        goalFrame(in, *c, *space, reach.distance) * chainFrame(*c, bentChain(*c, bend, delta, k)).transpose();
    Solution s;
    s.startRotate = eulerNearZero(c->startOrient.transpose() * q, in.startOrder);
    // Mid joint: JO_mid * R_mid = bend * JO_mid, so R_mid is the bend about JO_mid^T * n (or the given axis).
    s.midRotate = eulerNearZero(Eigen::AngleAxisd(delta, bend.localAxis).toRotationMatrix(), in.midOrder);
    s.midTranslate = k * (bend.hinge ? bend.chain.mid(delta) : in.midTranslate);
    s.endTranslate = k * in.endTranslate;
    // Overflowing inputs (1e200 cm) must not give NaN: each group falls back on its rest value.
    if (!(s.startRotate.allFinite() && s.midRotate.allFinite())) s.startRotate = s.midRotate = Eigen::Vector3d::Zero();
    if (!(s.midTranslate.allFinite() && s.endTranslate.allFinite())) {
        s.midTranslate = in.midTranslate;
        s.endTranslate = in.endTranslate;
    }
    return s;
}

class IkHandleNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        Inputs in;
        in.parent = c.getMatrix(StartParentMatrix);
        in.inverseScale = c.getVector3(StartInverseScale);
        in.startTranslate = c.getVector3(StartTranslate);
        in.startOrient = c.getVector3(StartJointOrient);
        in.startOrder = orderOf(c.getEnum(StartRotateOrder));
        in.midTranslate = c.getVector3(MidTranslate);
        in.midOrient = c.getVector3(MidJointOrient);
        in.midOrder = orderOf(c.getEnum(MidRotateOrder));
        in.endTranslate = c.getVector3(EndTranslate);
        in.goal = c.getMatrix(GoalMatrix).topRightCorner<3, 1>();
        in.pole = c.getVector3(PoleVector);
        in.twist = c.getDouble(Twist);
        in.stretch = c.getBool(Stretch);
        in.softness = c.getDouble(Softness);
        in.bendAxis = c.getVector3(BendAxis);
        in.slide = c.getDouble(MidSlide);
        in.slideQuadratic = c.getDouble(MidSlideQuadratic);
        const int slideAxis = c.getEnum(MidSlideAxis);
        in.slideAxis = slideAxis >= 0 && slideAxis < 3 ? slideAxis : 1;
        const Solution s = solve(in);
        c.setOutput(StartRotate, s.startRotate);
        c.setOutput(MidRotate, s.midRotate);
        c.setOutput(OutMidTranslate, s.midTranslate);
        c.setOutput(OutEndTranslate, s.endTranslate);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeIkHandleType()
{
    NodeTypeBuilder b("ikHandle");
    b.description(
        "Two-bone rotate-plane IK (Maya's ikHandle with the ikRPsolver) for a chain start -> mid -> end, as a "
        "node whose outputs drive the start and mid joints' rotate (and, when stretching, the mid and end "
        "joints' translate). The chain's rest values are constant inputs (the node must not read the joints "
        "it drives); the joints' rotateAxis must be zero and their scale 1. Solve: in the start joint's "
        "pre-orient frame A = startParentMatrix * T(startTranslate) * IS, the mid joint turns about the rest "
        "chain plane's normal n = midTranslate x (midJointOrient * endTranslate) until |start->end| = reach; "
        "the start joint then aims the end at the goal and turns the chain plane about the start->goal axis "
        "until the mid joint lies on the pole vector's side, then by `twist`. Reach = min(d, L) with d = "
        "|goal - start| and L = |midTranslate| + |endTranslate| (with bendAxis or midSlide, the hinge chain's "
        "distance where it is straightest); with softness s > 0 and d > L - s, reach = "
        "(L - s) + s * (1 - exp(-(d - (L - s)) / s)). With stretch and d > reach both bones scale by d / "
        "reach so the end reaches the goal. Degenerate cases: a goal at the start aims along the rest chain; "
        "a zero pole vector or one parallel to start->goal keeps the rest plane (normal JO * n); a straight "
        "rest chain bends about the mid joint's Z axis; a zero-length chain or singular parent gives the rest "
        "pose. Outputs are never NaN.");
    b.input(StartParentMatrix, "startParentMatrix", ValueType::Matrix4)
        .doc("World matrix of the start joint's parent (connect its worldMatrix; identity for a root joint).");
    b.input(StartInverseScale, "startInverseScale", ValueType::Vector3)
        .defaultValue(Eigen::Vector3d(1, 1, 1))
        .doc(
            "What the start joint's inverseScale receives (connect from the parent's scale) when the start "
            "joint has segmentScaleCompensate on; (1, 1, 1) otherwise. Zero components are ignored.");
    b.input(StartTranslate, "startTranslate", ValueType::Vector3)
        .unit(Unit::Distance)
        .doc("The start joint's translate (constant, cm, in its parent's frame).");
    b.input(StartJointOrient, "startJointOrient", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc("The start joint's jointOrient (constant, xyz order).");
    b.input(StartRotateOrder, "startRotateOrder", ValueType::Enum)
        .enumNames(rotateOrderEnumNames())
        .doc("The start joint's rotateOrder: the order startRotate is written in.");
    b.input(MidTranslate, "midTranslate", ValueType::Vector3)
        .unit(Unit::Distance)
        .doc("The mid joint's rest translate (constant, cm, in the start joint's frame): the upper bone.");
    b.input(MidJointOrient, "midJointOrient", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc("The mid joint's jointOrient (constant, xyz order).");
    b.input(MidRotateOrder, "midRotateOrder", ValueType::Enum)
        .enumNames(rotateOrderEnumNames())
        .doc("The mid joint's rotateOrder: the order midRotate is written in.");
    b.input(EndTranslate, "endTranslate", ValueType::Vector3)
        .unit(Unit::Distance)
        .doc("The end joint's rest translate (constant, cm, in the mid joint's frame): the lower bone.");
    b.input(GoalMatrix, "goalMatrix", ValueType::Matrix4)
        .doc("World matrix of the goal (connect the IK control's worldMatrix); only its translation is used.");
    b.input(PoleVector, "poleVector", ValueType::Vector3)
        .unit(Unit::Distance)
        .keyable()
        .doc(
            "World-space direction from the start joint towards the side the mid joint bends to (Maya's "
            "poleVector): the mid joint lies in the plane through the start joint, the goal and start + "
            "poleVector, on the poleVector's side of the start->goal line; only its direction matters. For a pole "
            "control, "
            "connect a poleVectorConstraint's constraintTranslate (pole control world position - start joint "
            "world position). Zero, or parallel to start->goal: "
            "the rest chain plane is kept.");
    b.input(Twist, "twist", ValueType::Double)
        .unit(Unit::Angle)
        .keyable()
        .doc("Rotation of the chain plane about the start->goal axis (right-handed), after the pole vector.");
    b.input(Stretch, "stretch", ValueType::Bool)
        .keyable()
        .doc(
            "When the goal is farther than the (soft) reach, scale both bones by distance / reach so the "
            "end reaches it; outMidTranslate and outEndTranslate carry the scaled bones.");
    b.input(Softness, "softness", ValueType::Double)
        .unit(Unit::Distance)
        .min(0.0)
        .keyable()
        .doc(
            "Soft IK distance s (cm in the start joint's frame; 0 = off, clamped to the chain length L): past "
            "L - s the reach eases in as (L - s) + s * (1 - exp(-(d - (L - s)) / s)) and reaches L only at "
            "infinity, so the knee never snaps straight.");
    b.input(BendAxis, "bendAxis", ValueType::Vector3)
        .doc(
            "The mid joint's hinge axis, in its rotate space (after midJointOrient); positive angles about it bend "
            "the chain. Zero (the default): the rest chain plane's normal n, Maya's rotate-plane solver. A given "
            "axis makes the IK bend the mid joint as an FK hinge about that axis does (the knee of a leg whose FK "
            "control turns about X), with the angle found by Newton's method on the branch from the straightest "
            "chain to the one whose end is nearest the start (the fully folded one, or a little before it where a "
            "sliding mid joint brings the end nearest sooner); a nearer goal clamps to that pose.");
    b.input(MidSlide, "midSlide", ValueType::Double)
        .unit(Unit::Distance)
        .doc(
            "A mid joint that slides as it bends (slidingPivot's knee): its translate moves along midSlideAxis "
            "by midSlide * angle + midSlideQuadratic * angle^2 cm (angle: the bend from rest, in radians), and "
            "the IK accounts for it, so the end still reaches the goal. 0 = a fixed pivot.");
    b.input(MidSlideQuadratic, "midSlideQuadratic", ValueType::Double)
        .unit(Unit::Distance)
        .doc("The slide's quadratic term, cm per radian squared (as slidingPivot's slideQuadratic).");
    b.input(MidSlideAxis, "midSlideAxis", ValueType::Enum)
        .enumNames({"x", "y", "z"})
        .defaultValue(1)
        .doc("The direction the mid joint slides along, in its translate space (the start joint's frame).");
    b.output(StartRotate, "startRotate", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc(
            "The start joint's rotate, in startRotateOrder, such that JO * R is the solved orientation (the "
            "Euler triple nearest to zero). Connect to the start joint's rotate.");
    b.output(MidRotate, "midRotate", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc(
            "The mid joint's rotate, in midRotateOrder: a single rotation about the bend axis expressed in "
            "the mid joint's frame (about Z for a chain bent in its XY plane). Connect to the mid joint's rotate.");
    b.output(OutMidTranslate, "outMidTranslate", ValueType::Vector3)
        .unit(Unit::Distance)
        .doc(
            "midTranslate, moved by the slide (midSlide), scaled by the stretch factor (equal to midTranslate "
            "for a fixed pivot, not stretching). Connect to the mid joint's translate.");
    b.output(OutEndTranslate, "outEndTranslate", ValueType::Vector3)
        .unit(Unit::Distance)
        .doc(
            "endTranslate scaled by the stretch factor (equal to endTranslate when not stretching). Connect "
            "to the end joint's translate.");
    // Rotations depend on everything; the translates on the stretch factor and the slide, which depend on the
    // distances and the bend.
    for (AttrId in = StartParentMatrix; in <= MidSlideAxis; ++in) b.affects(in, {StartRotate, MidRotate});
    for (AttrId in : {StartParentMatrix, StartInverseScale, StartTranslate, MidTranslate, MidJointOrient, EndTranslate,
                      GoalMatrix, Stretch, Softness, BendAxis, MidSlide, MidSlideQuadratic, MidSlideAxis})
        b.affects(in, {OutMidTranslate, OutEndTranslate});
    b.factory<IkHandleNode>();
    return b.build();
}

}  // namespace rig
