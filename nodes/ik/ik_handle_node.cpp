// ikHandle: a two-bone rotate-plane IK solver (Maya's ikHandle with the ikRPsolver) as a DG node that
// outputs the start and mid joints' rotate values (and stretched translates). The chain's rest values
// are constant inputs: the node cannot read the joints it drives (no cycles at node level).

#include <algorithm>
#include <cmath>
#include <numbers>
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

    // upper . lower(angle) = p + m cos(angle - phi) for the rigid hinge: phi is where it is straightest.
    double straightest() const
    {
        const Eigen::Vector3d across = restLower - restLower.dot(axis) * axis;
        return std::atan2(upper.dot(axis.cross(across)), upper.dot(across));
    }

    // The angle on the bending branch, phi to phi + pi, that puts the end `reach` from the start: Newton from
    // the rigid hinge's closed form, kept inside a shrinking bracket (the distance falls along the branch); a
    // reach beyond the branch's ends clamps to them.
    double angle(double phi, double reach) const
    {
        double lo = phi, hi = phi + std::numbers::pi;
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

Solution solve(const Inputs& in)
{
    // Solve space A: the start joint's frame before its jointOrient and rotate, A = parent * T * IS
    // (IS undoes the parent's scale as the joint does with segmentScaleCompensate). In A the start
    // joint sits at the origin and its orientation JO * R is a rotation; any affine parent maps the
    // solution back exactly (goal reached, plane kept).
    JointInputs frame;
    frame.translate = in.startTranslate;
    frame.inverseScale = in.inverseScale;
    const Eigen::Matrix4d a = in.parent * jointMatrix(frame);
    const Eigen::Matrix3d aLinear = a.topLeftCorner<3, 3>();
    const double columnProduct = aLinear.col(0).norm() * aLinear.col(1).norm() * aLinear.col(2).norm();
    if (!(std::abs(aLinear.determinant()) > 1e-12 * columnProduct)) return rest(in);  // singular parent
    const Eigen::Matrix3d aInverse = aLinear.inverse();
    const Eigen::Vector3d goal = aInverse * (in.goal - a.topRightCorner<3, 1>());
    const Eigen::Vector3d pole = aInverse * in.pole;

    const Eigen::Matrix3d startOrient = eulerToMatrix(in.startOrient, RotateOrder::xyz);
    const Eigen::Matrix3d midOrient = eulerToMatrix(in.midOrient, RotateOrder::xyz);
    const Eigen::Vector3d& u = in.midTranslate;                 // start -> mid, start joint frame
    const Eigen::Vector3d restB = midOrient * in.endTranslate;  // mid -> end, start joint frame, at rest
    const double l1 = u.norm();
    const double l2 = in.endTranslate.norm();  // = |restB|, but free of midJointOrient's rounding
    const double chain = l1 + l2;
    if (!(chain > 0.0)) return rest(in);
    const double tiny = 1e-12 * std::max(1.0, chain);
    const bool twoBones = l1 > tiny && l2 > tiny;

    // Bend axis n (start joint frame): the normal of the rest chain plane, u x restB. A straight rest
    // chain falls back on the mid joint's Z axis (then Y, then X) made perpendicular to the chain.
    const Eigen::Vector3d chainDirection = (l1 > tiny ? u : restB).normalized();
    Eigen::Vector3d n = u.cross(restB);
    if (twoBones && n.norm() > parallelTolerance * l1 * l2) n.normalize();
    else n = perpendicularFrom(chainDirection, {midOrient.col(2), midOrient.col(1), midOrient.col(0)});

    // A given hinge axis, or a mid joint that slides as it bends: the hinge chain's angle by Newton (the rigid
    // rest-plane hinge keeps its closed form below). Its longest reach is where it is straightest.
    const bool hinge = twoBones && (in.bendAxis.squaredNorm() > 0.0 || in.slide != 0.0 || in.slideQuadratic != 0.0);
    const Eigen::Vector3d localAxis =
        in.bendAxis.squaredNorm() > 0.0 ? in.bendAxis.normalized() : Eigen::Vector3d(midOrient.transpose() * n);
    const HingeChain hingeChain{
        u, restB, midOrient * localAxis, Eigen::Vector3d::Unit(in.slideAxis), in.slide, in.slideQuadratic};
    const double phi = hinge ? hingeChain.straightest() : 0.0;
    const double longest = hinge ? hingeChain.distance(phi) : chain;

    // Reach: soft IK eases the distance in over the last `softness` cm; stretch scales both bones.
    const double distance = goal.stableNorm();  // no overflow for far goals
    const double soft = std::clamp(in.softness, 0.0, longest);
    double reach = std::min(distance, longest);
    if (soft > 0.0 && distance > longest - soft)
        reach = (longest - soft) + soft * (1.0 - std::exp(-(distance - (longest - soft)) / soft));
    const double k = in.stretch && distance > reach && reach > 0.0 ? distance / reach : 1.0;

    // Mid joint: rotate about n so that |start -> end| = k * reach. theta is the angle from the upper
    // bone to the lower one about n (0 = straight), theta0 its rest value.
    double delta = 0.0;
    if (hinge) delta = hingeChain.angle(phi, reach);
    else if (twoBones) {
        // Law of cosines, reach^2 = l1^2 + l2^2 + 2 l1 l2 cos(theta), in its half-angle form
        // sin^2(theta / 2) = (L - reach)(L + reach) / (4 l1 l2): exact at full extension, well
        // conditioned near it, and scale-free (the unscaled lengths cannot overflow).
        const double half = std::sqrt(std::clamp((chain - reach) * (chain + reach) / (4.0 * l1 * l2), 0.0, 1.0));
        const double theta = 2.0 * std::asin(half);
        const double theta0 = std::atan2(u.cross(restB).dot(n), u.dot(restB));
        delta = theta - theta0;
    }
    const Eigen::Vector3d upper = k * (hinge ? hingeChain.mid(delta) : u);
    const Eigen::Vector3d lower = hinge ? Eigen::Vector3d(k * hingeChain.lower(delta))
                                        : Eigen::Vector3d(Eigen::AngleAxisd(delta, n) * (k * restB));
    // The plane's normal: the rest plane's, or the bent hinge chain's (on a straight one, the hinge axis made
    // perpendicular to the chain, its limit as the chain starts to bend).
    Eigen::Vector3d normal = n;
    if (hinge) {
        normal = upper.cross(lower);
        const double size = normal.norm();
        if (size > parallelTolerance * upper.norm() * lower.norm()) normal /= size;
        else normal = perpendicularFrom((upper + lower).normalized(), {hingeChain.axis, n});
    }
    const Eigen::Vector3d end = upper + lower;

    // Chain frame (start joint frame): x1 towards the end, y1 towards the mid joint's side, z1 = -normal.
    const Eigen::Vector3d x1 = end.norm() > tiny ? end.normalized() : perpendicularFrom(normal, {chainDirection});
    const Eigen::Vector3d y1 = perpendicularFrom(x1, {x1.cross(normal), chainDirection});
    Eigen::Matrix3d b1;
    b1 << x1, y1, x1.cross(y1);

    // Goal frame (space A): x2 towards the goal, y2 towards the pole vector, then twisted about x2.
    const Eigen::Vector3d restEnd = u + restB;
    Eigen::Vector3d x2 = startOrient * (restEnd.norm() > tiny ? restEnd.normalized() : chainDirection);
    if (distance > tiny) x2 = goal / distance;
    const double poleLength = pole.stableNorm();
    const Eigen::Vector3d poleDirection =
        poleLength > 0.0 && std::isfinite(poleLength) ? Eigen::Vector3d(pole / poleLength) : Eigen::Vector3d::Zero();
    const Eigen::Vector3d polePerpendicular = poleDirection - poleDirection.dot(x2) * x2;
    Eigen::Vector3d y2;
    if (polePerpendicular.norm() > parallelTolerance) y2 = polePerpendicular.normalized();
    else  // no usable pole: keep the rest plane, whose normal is startOrient * n
        y2 = perpendicularFrom(x2, {x2.cross(startOrient * n), startOrient * chainDirection});
    const Eigen::Vector3d y2Twisted = std::cos(in.twist) * y2 + std::sin(in.twist) * x2.cross(y2);
    Eigen::Matrix3d b2;
    b2 << x2, y2Twisted, x2.cross(y2Twisted);

    // Start joint orientation in A: Q = B2 * B1^T = JO * R.
    const Eigen::Matrix3d q = b2 * b1.transpose();
    Solution s;
    s.startRotate = eulerNearZero(startOrient.transpose() * q, in.startOrder);
    // Mid joint: JO_mid * R_mid = bend * JO_mid, so R_mid is the bend about JO_mid^T * n (or the given axis).
    s.midRotate = eulerNearZero(Eigen::AngleAxisd(delta, localAxis).toRotationMatrix(), in.midOrder);
    s.midTranslate = k * (hinge ? hingeChain.mid(delta) : in.midTranslate);
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
            "chain to the fully folded one.");
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
