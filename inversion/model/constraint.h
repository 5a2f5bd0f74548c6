#pragma once
// Constraint operators (docs/rig-learn.md, Constraint operators): what an output that no product of operators
// reproduces is a function of. An output learned with a constraint has a base B instead of a parent's motion,
//
//   F~_k(beta) = B_k(inputs) * M_k(beta) * F_k(0),      B_k = I at rest,
//
// where the inputs are other outputs of the approximation (joints or helper frames, learned before it) and
// M_k is its own operators, as for any output. Outputs below it stay relative to it.
//
// The one family so far is the planar chain: two-bone IK and its production variants. The chain's plane
// is spanned by its root r (a point carried by the anchor output), its goal g (a helper's origin) and its
// pole q (another helper's origin, or a point carried by the anchor: the rotate-plane default):
//
//   C(r, g, q) = [x y z | r],  x = (g - r) / |g - r|,  y = the unit part of q - r across x,  z = x × y
//
// or, for a chain without a pole (the rotate-plane default: the rest plane kept), y = x × N / |x × N| with N the
// rest plane's normal carried by the anchor, so that the plane's normal is the nearest to N across x
//   B = C G(d - d0) C0^-1,     d = |g - r|
//
// with G a rigid motion sampled over the reach d (a spline of a rotation vector and a translation: the
// sampledRigid operator), so that the chain's shape in its plane (its bend, a sliding knee, stretch, soft IK)
// is learned from the rig without knowing which of them it uses.
//
// The twist share (a roll joint turned by a fraction of a driver's twist): the output turns with its anchor's
// rotation (its polar part: a stretched parent's scale is not inherited, as a joint's segment scale compensation
// does) about a fixed axis u0 through its rest origin c0 by a fitted share w of the driver's twist tau,
//
//   B(y) = Q_a Rot(u0, w tau) (y - c0) + M_a c0,      Q_a = polar(M_a),  M_a the anchor's motion
//
// where tau is the twist about one of the driver's local axes of its rotation relative to its parent output (from
// rest: R_d = R_d(0)^T Q_p^T Q_d), read as a rig reads it: R_d's angles in one rotate order taken as angles in
// another (a twist node reading the driver's rotate in an order other than the driver's; the same order is the
// plain swing-twist), then twist = 2 atan2(q . e, q_w) of that rotation's quaternion (q_w >= 0).

#include <array>
#include <optional>
#include <string_view>

#include <Eigen/Core>

#include "core/rotation_math.h"
#include "inversion/model/operators.h"

namespace rig {

// The blend (issue #32, an animated switch): an output whose local transform relative to its parent output is the
// rig's blend, by a weight w in [0, 1], of two branches each modelled on its own, the IK branch (w = 1) and the FK
// branch (w = 0): L = blend(w, L_ik, L_fk), L_x = W(parent_x)^-1 W(x) read in each branch's own frames, as blendColors
// nodes blend a joint's channels between an IK handle's and the FK controls' values. A rig blends channels, not
// frames: its rotation is the blend of each Euler angle in one rotate order, read nearest rest (the values the rig
// blends, where they are within half a turn of rest, the middle angle within a quarter), so that slerping the frames
// does not reproduce it; the translation is blended linearly (a sliding knee), the stretch (the linear part's right
// polar factor) too. A rig that blends frames (a pair blend in quaternions) is the slerp: R_fk exp(w log(R_fk^T R_ik)).
enum class BlendMode { eulerChannels, slerp };

std::string_view blendModeName(BlendMode mode);
std::optional<BlendMode> blendModeFromName(std::string_view name);

struct BlendRule {
    BlendMode mode = BlendMode::eulerChannels;
    RotateOrder order = RotateOrder::xyz;  // eulerChannels: the order the angles are read and composed in
};

// The oriented base (issue #46): an output whose position its anchor carries and whose rotation is another output's
// (a joint orient-constrained to a helper while its parent moves it: a ball turning as the toe pivot of a reverse foot,
// a foot joint under an FK ankle turning as its IK control), B = [Q_o | M_a p0 - Q_o p0], with M_a the anchor's
// motion, Q_o the orient output's polar rotation from rest and p0 the output's rest origin (`origin`).
enum class ConstraintKind { planarChain, twistShare, blend, oriented };

std::string_view constraintKindName(ConstraintKind kind);
std::optional<ConstraintKind> constraintKindFromName(std::string_view name);

struct ConstraintBase {
    ConstraintKind kind = ConstraintKind::planarChain;
    // Inputs, indices into Approximation::outputs (rig outputs while learning).
    int anchor = -1;  // carries the root (and a fixed pole): its motion F~_a F_a(0)^-1; -1: the world
    int goal = -1;    // the goal is its origin
    int pole = -1;    // the pole is its origin; -1: `restPole` carried by the anchor, or the rest plane (restPlane)
    // Twist share inputs: the driver, and its parent output (-1: the world) its rotation is relative to.
    int driver = -1;
    int driverParent = -1;
    Eigen::Vector3d root = Eigen::Vector3d::Zero();      // the chain root at rest, world (twist share: c0)
    Eigen::Vector3d restPole = Eigen::Vector3d::Zero();  // the pole at rest, world
    // No pole output: `restPole` at its rest offset from the root in world axes, not turned by the anchor (an aim's up
    // vector fixed in the world: scene or vector up).
    bool worldUp = false;
    // A pole output whose rotation carries the pole: the root plus restPole's rest offset from it, turned by the pole
    // output's motion from rest (W_p poleRest^-1, its 3x3 parts), as a mayaIkHandle's pole vector, kept in its parent's
    // space, turns with the foot it hangs under where no pole constraint drives it. poleRest is the 3x3 part of the
    // pole output's rest world (derived: set with `pole`).
    bool poleTurns = false;
    Eigen::Matrix3d poleRest = Eigen::Matrix3d::Identity();
    // No pole: the plane through the chain's line nearest the rest plane, whose normal at rest is restNormal (unit).
    bool restPlane = false;
    Eigen::Vector3d restNormal = Eigen::Vector3d::Zero();
    // With restPlane, Maya's ikSCsolver: the rest plane turned by the smallest rotation that takes the chain's line
    // onto the goal's, n = R_min(e -> x) N with N = Q_a restNormal and e the line from the root to the chain's end as
    // the chain bends to the reach d with its start joint unturned (in the anchor's axes): x0 turned about restNormal
    // by lineTurn's magnitude at d - d0 (a curve of the reach; zero for a one-bone chain, which does not bend).
    bool minimalTurn = false;
    // With minimalTurn, Maya's ikSCsolver as Maya solves it: the chain then turns about its line toward the goal's
    // orientation (the handle's, which Maya's handle tool gives the effector's at rest). The plane is the rest plane
    // carried by the goal's rotation from rest W instead of the anchor's, turned minimally onto the goal's line,
    // n = R_min(t -> x) W N with t = W Rot(N, lineTurn) x0 (lineTurn: the effector's turn as the chain bends, the
    // bend's line turn less the effector joint's own; zero for one bone): with the start joint's turn about the line
    // that brings the effector's orientation nearest the handle's, the chain's frame is the one whose x column is
    // the line and that is nearest W C0. goalRest is the 3x3 part of the goal output's rest world (derived: set with
    // `goal`).
    bool goalTurns = false;
    Eigen::Matrix3d goalRest = Eigen::Matrix3d::Identity();
    Operator lineTurn;
    double restReach = 0.0;  // d0 = |g - r| at rest
    Operator shape;          // sampledRigid in d - d0: the output's motion within the chain's frame
    // C0, the chain frame at rest (chainFrame of the rest points): derived, set by `prepare`.
    Eigen::Matrix4d restFrame = Eigen::Matrix4d::Identity();
    Eigen::Matrix4d restFrameInverse = Eigen::Matrix4d::Identity();
    // Twist share: the axis u0 the output turns about (world, at rest, unit), the driver's local axis its twist is
    // taken about (0 x, 1 y, 2 z), the driver's rotation at rest relative to its parent (R_d(0)), the order its
    // angles are read in and the order the twist takes them in, and the share w.
    Eigen::Vector3d axis = Eigen::Vector3d::UnitX();
    int twistAxis = 0;
    Eigen::Matrix3d driverRest = Eigen::Matrix3d::Identity();
    RotateOrder readOrder = RotateOrder::xyz;
    RotateOrder twistOrder = RotateOrder::xyz;
    double share = 0.0;
    // Blend: the output's own parent output is `anchor`; the branches' outputs (`ik` the IK branch's, at weight 1)
    // and their parent outputs (-1: the world), whose locals it blends; the weight, an index into
    // Approximation::parameters; and the blend the rig does.
    int ik = -1, fk = -1, ikParent = -1, fkParent = -1;
    int weight = -1;
    BlendRule blend;
    // A planar chain whose output turns as another output does (an IK hand or foot orient-constrained to its control,
    // a joint whose rotation a constraint takes from a helper): `orient` is that output, whose motion's rotation
    // replaces B's, and B's translation takes the output's rest origin `origin` (world) where the chain takes it.
    // -1: B is the chain's alone.
    int orient = -1;
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();

    // Its inputs (indices into the outputs, -1 for none): anchor, goal, pole for a chain; anchor, driver and the
    // driver's parent for a twist share; the anchor alone for an oriented base (its orient output is a frame input).
    // The solver and the orderer read them in this order.
    std::array<int, 3> inputs() const;
    // Every output its frame reads, -1 where none: inputs() and, for a blend, its branches and their parents, for a
    // chain or an oriented base its orient output (the fourth).
    std::array<int, 5> frameInputs() const;

    // Every field holding an output index (-1 for none), for whatever renumbers the outputs.
    std::array<int*, 10> outputFields()
    {
        return {&anchor, &goal, &pole, &driver, &driverParent, &ik, &fk, &ikParent, &fkParent, &orient};
    }

    // Sets the derived fields from the others and the goal's rest position. False when the rest points do not
    // span a plane (the goal on the root, or the pole on the root-goal line).
    bool prepare(const Eigen::Vector3d& restGoal);
};

// The three points of a chain and the rest plane's normal as the anchor carries it, and their rates of change.
// A minimalTurn chain's normal is the turned one; `carried` and `line` are then N and e (minimalTurnNormal).
struct ChainPoints {
    Eigen::Vector3d root, goal, pole, normal = Eigen::Vector3d::Zero();
    Eigen::Vector3d carried = Eigen::Vector3d::Zero(), line = Eigen::Vector3d::Zero();
};

// A minimalTurn chain's plane normal at its points (root and goal set), from the anchor's motion's 3x3 part: sets
// `carried`, `line` and `normal`.
void minimalTurnNormal(const ConstraintBase& base, const Eigen::Matrix3d& anchorLinear, ChainPoints& points);

// The chain frame of three points (or of the root, the goal and the normal, `restPlane`); false when they do not
// span a plane (`frame` is then untouched).
bool chainFrame(const ChainPoints& points, bool restPlane, Eigen::Matrix4d& frame);

// The points from the inputs' matrices: the anchor's motion (identity for the world), the goal's world, and the
// pole's world (ignored when the base has no pole output).
ChainPoints chainPoints(const ConstraintBase& base, const Eigen::Matrix4d& anchorMotion,
                        const Eigen::Matrix4d& goalWorld, const Eigen::Matrix4d& poleWorld);

// B for these points. Non-finite when the points span no plane.
Eigen::Matrix4d constraintBase(const ConstraintBase& base, const ChainPoints& points);

// What a base's velocity needs at one set of points, made once for every rate of them (a solve's columns): the
// chain frame, and the shape's own velocity per unit of reach, in world space.
struct BaseLinearization {
    bool restPlane = false;
    Eigen::Vector3d root, x, y, pole, normal;  // pole: q - r
    double reach = 0.0, across = 0.0;          // |g - r|, and the pole's distance from the chain's line (or |x × N|)
    // Their reciprocals: every column's velocity scales by them, and a multiplication costs a fraction of a division.
    double inverseReach = 0.0, inverseAcross = 0.0;
    Eigen::Matrix3d frame;              // [x y z]
    Eigen::Matrix<double, 6, 1> shape;  // C (dG/dd G^-1) C^-1 as a twist (omega, v): G is rigid
    // A minimalTurn chain's (minimalTurnNormal: N carried, e the line, x the chain's direction): the line's turn
    // per unit of reach along x (the line turn's slope times N / |N| x e), 1 / (1 + e . x) and x . N.
    Eigen::Vector3d lineTurn = Eigen::Vector3d::Zero();
    double inverseTurnScale = 0.0, turnDot = 0.0;
};
BaseLinearization linearizeBase(const ConstraintBase& base, const ChainPoints& points);

// A minimalTurn chain's normal's rate for its root and goal moving at `rate` and the anchor turning the carried
// normal and the line at `carriedRate` and `lineRate` (dM M^-1 times each).
Eigen::Vector3d minimalTurnRate(const BaseLinearization& at, const ChainPoints& points, const ChainPoints& rate,
                                const Eigen::Vector3d& carriedRate, const Eigen::Vector3d& lineRate);

// dB B^-1 for points moving at `rate`, as the twist (omega, v) it is (B is rigid: dB B^-1 = [[omega]x, v]).
Eigen::Matrix<double, 6, 1> baseVelocity(const BaseLinearization& at, const ChainPoints& rate);

// B from its inputs, for either family: the anchor's motion, the worlds of its second and third inputs, and the
// orient output's motion (the identity where there is none).
Eigen::Matrix4d constraintBase(const ConstraintBase& base, const Eigen::Matrix4d& anchorMotion,
                               const Eigen::Matrix4d& second, const Eigen::Matrix4d& third,
                               const Eigen::Matrix4d& orientMotion);

// A chain's B (`chain`) with its rotation taken from the orient output's motion (ConstraintBase::orient):
// [Q_o | c - Q_o p0], c = B p0 with p0 the output's rest origin and Q_o the motion's polar rotation. `chain` itself
// where the base has no orient output.
Eigen::Matrix4d orientedBase(const ConstraintBase& base, const Eigen::Matrix4d& chain,
                             const Eigen::Matrix4d& orientMotion);

// Its velocity d B' B'^-1 as a twist (omega, v), from the rate of c = B p0 (where the chain moves it) and the orient
// output's angular velocity: that angular velocity, and a translation keeping c where the chain moves it,
// v' = dc - omega_o x c.
Eigen::Matrix<double, 6, 1> orientedVelocity(const Eigen::Vector3d& centreRate, const Eigen::Vector3d& orientOmega,
                                             const Eigen::Vector3d& centre);

// The driver's twist tau (radians) from its rotation relative to its parent's (Q_p^T Q_d), and its gradient with
// respect to a turn of that rotation in its own frame (R exp([delta]x): d tau = gradient . delta; zero where the
// angles or the twist are undefined).
double driverTwist(const ConstraintBase& base, const Eigen::Matrix3d& relative, Eigen::Vector3d* gradient = nullptr);

// Whether the driver's twist is undefined at this relative rotation, so that a rig's twist there is decided by
// rounding: its angles at gimbal lock where they are read in another order, its rotation a half turn about an axis
// across the twist's, or its twist a half turn (where it wraps from +pi to -pi).
bool twistSingular(const ConstraintBase& base, const Eigen::Matrix3d& relative);

// The angular velocity of polar(A) when A moves at dA = L A (A = Q S given).
Eigen::Vector3d polarRate(const Eigen::Matrix3d& q, const Eigen::Matrix3d& s, const Eigen::Matrix3d& l);

// A twist share's base and what its velocity needs, made once per set of inputs.
struct TwistLinearization {
    Eigen::Matrix3d anchorQ, anchorS, driverQ, driverS, parentQ, parentS;
    Eigen::Vector3d centre;    // M_a c0
    Eigen::Vector3d turnAxis;  // Q_a u0
    Eigen::Vector3d gradient;  // d tau / d delta (the driver's own frame), times the share
    Eigen::Matrix4d base;
};
TwistLinearization linearizeTwist(const ConstraintBase& base, const Eigen::Matrix4d& anchorMotion,
                                  const Eigen::Matrix4d& driverWorld, const Eigen::Matrix4d& parentWorld);
// dB B^-1 for inputs moving at dM = L M (top three rows of each: [L | v]).
Eigen::Matrix<double, 3, 4> twistVelocity(const TwistLinearization& at, const Eigen::Matrix<double, 3, 4>& anchor,
                                          const Eigen::Matrix<double, 3, 4>& driver,
                                          const Eigen::Matrix<double, 3, 4>& parent);

// The blended local transform, from the branches' locals (rotation times a stretch, and a translation).
Eigen::Matrix4d blendLocal(const BlendRule& rule, double w, const Eigen::Matrix4d& ik, const Eigen::Matrix4d& fk);

// Its derivative for the weight and the branches' locals moving at dw, dIk and dFk (its velocity: the solver's
// column of w, and the columns of the branches' controls through their locals).
Eigen::Matrix4d blendLocalRate(const BlendRule& rule, double w, const Eigen::Matrix4d& ik, const Eigen::Matrix4d& fk,
                               double dw, const Eigen::Matrix4d& dIk, const Eigen::Matrix4d& dFk);

}  // namespace rig
