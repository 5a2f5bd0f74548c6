// mayaIkHandle: Maya's ikHandle with the ikRPsolver or the ikSCsolver, on chains of one to N bones, as Maya
// solves it (docs/ik-and-deformers.md, "mayaIkHandle"). The handle is a DAG transform whose rotate pivot is the
// goal; the chain's joints are constant (or FK-driven) inputs, never read through connections from the joints
// the node drives (the engine refuses node-level cycles), and the solve starts from them as Maya's starts from
// the chain's current pose.
//
// The solve, in world space about the reference pose (jointRotate): the joints after the start one bend to put
// the effector at the goal's distance from the start joint (2 bones: Maya's rotate-plane closed form, the mid
// joint turning about (start->mid) x (mid->effector)); the start joint then turns the effector onto the goal by
// the smallest rotation, then (ikRPsolver) about start->goal until the chain's plane holds the pole vector (its
// normal kept from the reference pose where the goal is past the chain's reach and the solve straightens it, from
// the preferred angles' pose where the reference is straight too),
// then by the twist; the ikSCsolver's start joint turns about start->goal toward the handle's orientation instead
// (history independent, as Maya's Nodes reference says of it). Each world turn D_i is taken into joint i's rotate
// space, R_i' = (B_i^-1 D_i B_i) R_i, B_i the frame its rotate acts in (the product-of-exponentials form of the chain:
// exact for rigid and uniformly scaled chains).

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/Geometry>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"
#include "nodes/enum_names.h"
#include "nodes/transform_math.h"

namespace rig {
namespace {

enum Attr : AttrId {
    Translate,
    Rotate,
    RotateOrderAttr,
    Scale,
    Shear,
    RotatePivot,
    RotatePivotTranslate,
    ScalePivot,
    ScalePivotTranslate,
    RotateAxis,
    ParentMatrix,
    PoleVector,
    Twist,
    IkBlend,
    Roll,
    Offset,
    SolverType,
    StartParentMatrix,
    StartInverseScale,
    JointTranslate,
    JointRotate,
    JointOrient,
    JointRotateAxis,
    JointRotateOrder,
    JointScale,
    JointSegmentScaleCompensate,
    JointPreferredAngle,
    EffectorTranslate,
    Matrix,
    WorldMatrix,
    WorldInverseMatrix,
    OutRotate
};

enum Solver { RotatePlane = 0, SingleChain = 1 };

// A direction shorter than this fraction of the lengths it came from is undefined (parallel vectors, a goal at
// the start joint).
constexpr double parallelTolerance = 1e-10;

struct ChainJoint {
    Eigen::Vector3d translate = Eigen::Vector3d::Zero();
    Eigen::Vector3d rotate = Eigen::Vector3d::Zero();
    Eigen::Vector3d orient = Eigen::Vector3d::Zero();
    Eigen::Vector3d rotateAxis = Eigen::Vector3d::Zero();
    Eigen::Vector3d scale = Eigen::Vector3d::Ones();
    Eigen::Vector3d preferred = Eigen::Vector3d::Zero();
    RotateOrder order = RotateOrder::xyz;
    bool segmentScaleCompensate = true;
};

struct Chain {
    Eigen::Matrix4d startParent = Eigen::Matrix4d::Identity();
    Eigen::Vector3d startInverseScale = Eigen::Vector3d::Ones();
    std::vector<ChainJoint> joints;
    Eigen::Vector3d effector = Eigen::Vector3d::Zero();
};

// The chain posed with the given rotate values: each joint's world position and B_i, the linear frame its rotate
// acts in (parent * T * IS * JO), and the effector's world position.
struct Pose {
    std::vector<Eigen::Vector3d> position;
    std::vector<Eigen::Matrix3d> frame;
    std::vector<Eigen::Matrix3d> world;  // linear part of each joint's world matrix
    Eigen::Vector3d effector = Eigen::Vector3d::Zero();
};

Pose forward(const Chain& chain, const std::vector<Eigen::Vector3d>& rotates)
{
    Pose pose;
    Eigen::Matrix4d parent = chain.startParent;
    Eigen::Vector3d inverseScale = chain.startInverseScale;
    for (std::size_t i = 0; i < chain.joints.size(); ++i) {
        const ChainJoint& j = chain.joints[i];
        JointInputs in;
        in.translate = j.translate;
        in.rotate = rotates[i];
        in.rotateOrder = j.order;
        in.jointOrient = j.orient;
        in.rotateAxis = j.rotateAxis;
        in.scale = j.scale;
        in.inverseScale = inverseScale;
        in.segmentScaleCompensate = j.segmentScaleCompensate;
        JointInputs preRotate = in;  // T * IS * JO: rotate, rotateAxis and scale left out
        preRotate.rotate = preRotate.rotateAxis = Eigen::Vector3d::Zero();
        preRotate.scale = Eigen::Vector3d::Ones();
        const Eigen::Matrix4d world = parent * jointMatrix(in);
        pose.position.push_back(world.topRightCorner<3, 1>());
        pose.frame.push_back((parent * jointMatrix(preRotate)).topLeftCorner<3, 3>());
        pose.world.push_back(world.topLeftCorner<3, 3>());
        parent = world;
        inverseScale = j.scale;
    }
    pose.effector = (parent * chain.effector.homogeneous()).head<3>();
    return pose;
}

// A rotation about a point (the product-of-exponentials factor of one joint).
struct Turn {
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    Eigen::Vector3d pivot = Eigen::Vector3d::Zero();
    Eigen::Vector3d apply(const Eigen::Vector3d& p) const { return pivot + rotation * (p - pivot); }
};

// Where the reference pose's point p (carried by joint `joint`, or the effector for joint = n) lands when each
// joint k <= joint turns by turns[k], applied from the start joint down (M_0 M_1 ... M_k p).
Eigen::Vector3d carried(const std::vector<Turn>& turns, std::size_t joint, Eigen::Vector3d p)
{
    for (std::size_t k = std::min(joint, turns.size() - 1) + 1; k-- > 0;) p = turns[k].apply(p);
    return p;
}

// The unit vector along v's component perpendicular to unit `axis`, or zero when there is none.
Eigen::Vector3d perpendicular(const Eigen::Vector3d& v, const Eigen::Vector3d& axis)
{
    const Eigen::Vector3d p = v - v.dot(axis) * axis;
    const double n = p.norm();
    return n > parallelTolerance * v.norm() && n > 0.0 ? Eigen::Vector3d(p / n) : Eigen::Vector3d::Zero();
}

// The bend of the joints after the start one: joint i turns about axis[i] by s * weight[i] - angle[i], so that
// s = 1 is the reference pose and s = 0 lines every bone up with the one before it (the straight chain).
struct BendFamily {
    std::vector<Eigen::Vector3d> axis;
    std::vector<double> weight, angle;
    bool bent = false;  // some joint has a bend axis
};

BendFamily bendFamily(const Pose& pose)
{
    const std::size_t n = pose.position.size();
    BendFamily f;
    f.axis.assign(n, Eigen::Vector3d::Zero());
    f.weight.assign(n, 0.0);
    f.angle.assign(n, 0.0);
    for (std::size_t i = 1; i < n; ++i) {
        const Eigen::Vector3d before = pose.position[i] - pose.position[i - 1];
        const Eigen::Vector3d after = (i + 1 < n ? pose.position[i + 1] : pose.effector) - pose.position[i];
        const Eigen::Vector3d normal = before.cross(after);
        const double size = normal.norm();
        if (!(size > parallelTolerance * before.norm() * after.norm()) || !(size > 0.0)) continue;
        f.axis[i] = normal / size;
        f.angle[i] = f.weight[i] = std::atan2(size, before.dot(after));
        f.bent = true;
    }
    return f;
}

std::vector<Turn> bendTurns(const Pose& pose, const BendFamily& f, double s)
{
    std::vector<Turn> turns(pose.position.size());
    for (std::size_t i = 0; i < turns.size(); ++i) {
        turns[i].pivot = pose.position[i];
        if (f.axis[i].squaredNorm() > 0.0)
            turns[i].rotation = Eigen::AngleAxisd(s * f.weight[i] - f.angle[i], f.axis[i]).toRotationMatrix();
    }
    return turns;
}

double reachAt(const Pose& pose, const BendFamily& f, double s)
{
    return (carried(bendTurns(pose, f, s), pose.position.size(), pose.effector) - pose.position[0]).norm();
}

// 2 bones, Maya's closed form: the mid joint turns about (start->mid) x (mid->effector) until the angle between
// the bones is theta, |start->goal|^2 = l1^2 + l2^2 + 2 l1 l2 cos(theta), clamped (a goal out of reach gives the
// straight or the folded chain). The half-angle form sin(theta / 2) = sqrt((L - d)(L + d) / (4 l1 l2)) keeps the
// precision near full extension, where acos loses half the digits.
double twoBoneScale(const Pose& pose, const BendFamily& f, double distance)
{
    const double l1 = (pose.position[1] - pose.position[0]).norm();
    const double l2 = (pose.effector - pose.position[1]).norm();
    const double length = l1 + l2;
    if (!(l1 > 0.0 && l2 > 0.0 && f.weight[1] > 0.0)) return f.weight[1] > 0.0 ? f.angle[1] / f.weight[1] : 0.0;
    const double half = std::sqrt(std::clamp((length - distance) * (length + distance) / (4.0 * l1 * l2), 0.0, 1.0));
    return 2.0 * std::asin(half) / f.weight[1];
}

// 3 bones or more: the same family, every bend scaled by one factor s in [0, pi / max weight], s found where the
// effector is at the goal's distance: the crossing nearest the reference (s = 1) on a grid, then bisection to
// rounding. Out of reach: the nearest end of the family's range of reaches.
double chainScale(const Pose& pose, const BendFamily& f, double distance)
{
    const double top = std::numbers::pi / *std::max_element(f.weight.begin(), f.weight.end());
    constexpr int steps = 64;
    std::array<double, steps + 1> reach{};
    for (int k = 0; k <= steps; ++k) reach[static_cast<std::size_t>(k)] = reachAt(pose, f, top * k / steps);
    double best = 0.0, bestGap = std::abs(reach[0] - distance), bestFromReference = 1e300;
    bool crossing = false;
    for (int k = 0; k < steps; ++k) {
        const double a = reach[static_cast<std::size_t>(k)] - distance;
        const double b = reach[static_cast<std::size_t>(k) + 1] - distance;
        const double lo = top * k / steps, hi = top * (k + 1) / steps;
        if (a == 0.0 || (a > 0.0) != (b > 0.0)) {
            const double fromReference = std::abs(0.5 * (lo + hi) - 1.0);
            if (!crossing || fromReference < bestFromReference) {
                crossing = true;
                best = lo;
                bestFromReference = fromReference;
            }
        } else if (!crossing && std::abs(b) < bestGap) {
            bestGap = std::abs(b);
            best = hi;
        }
    }
    if (!crossing) return best;
    double lo = best, hi = best + top / steps;
    const bool fallsAtLo = reachAt(pose, f, lo) > distance;
    for (int iteration = 0; iteration < 200 && hi - lo > 1e-16 * top; ++iteration) {
        const double mid = 0.5 * (lo + hi);
        ((reachAt(pose, f, mid) > distance) == fallsAtLo ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

// A straight reference chain has no bend axis: it bends as its preferred angles bend it (Maya's rule), else about
// each joint's own Z axis (then Y, then X) made perpendicular to the chain.
BendFamily fallbackFamily(const Chain& chain, const Pose& pose)
{
    std::vector<Eigen::Vector3d> preferred;
    for (const ChainJoint& j : chain.joints) preferred.push_back(j.preferred);
    const Pose preferredPose = forward(chain, preferred);
    BendFamily f = bendFamily(preferredPose);
    const std::size_t n = pose.position.size();
    const Eigen::Vector3d along = pose.effector - pose.position[0];
    const Eigen::Vector3d direction =
        along.norm() > 0.0 ? Eigen::Vector3d(along.normalized()) : Eigen::Vector3d::Zero();
    for (std::size_t i = 1; i < n; ++i) {
        if (f.bent) {
            // The preferred pose's axis, carried from the frame joint i turns in there into the reference's.
            if (f.axis[i].squaredNorm() > 0.0)
                f.axis[i] = (pose.frame[i] * preferredPose.frame[i].inverse() * f.axis[i]).normalized();
            f.angle[i] = 0.0;
            continue;
        }
        for (int c : {2, 1, 0}) {
            const Eigen::Vector3d axis = perpendicular(pose.world[i].col(c), direction);
            if (axis.squaredNorm() > 0.0) {
                f.axis[i] = axis;
                break;
            }
        }
        f.weight[i] = 1.0;
    }
    f.bent = true;
    return f;
}

struct Goal {
    Eigen::Vector3d position, pole;
    double twist;
    Solver solver;
    Eigen::Matrix3d orientation;  // the handle's world rotation, which the ikSCsolver's effector turns toward
};

// The start joint's turn: the effector onto the goal by the smallest rotation, then (rotate plane) about
// start->goal until the chain's plane (start->mid; past 2 bones, the sum of the joints' offsets from the start)
// holds the pole vector on its side, then by the twist.
// The normal of a posed chain's plane (its joints' offsets from the start against the effector's), zero where the
// chain is straight.
Eigen::Vector3d planeNormal(const Pose& pose)
{
    Eigen::Vector3d offsets = Eigen::Vector3d::Zero();
    for (std::size_t k = 1; k < pose.position.size(); ++k) offsets += pose.position[k] - pose.position[0];
    return offsets.cross(pose.effector - pose.position[0]);
}

// A straight reference chain's plane: its preferred angles' (Maya's rule), carried by the start joint from the
// preferred pose into the reference pose.
Eigen::Vector3d preferredNormal(const Chain& chain, const Pose& pose)
{
    std::vector<Eigen::Vector3d> preferred;
    for (const ChainJoint& j : chain.joints) preferred.push_back(j.preferred);
    const Pose preferredPose = forward(chain, preferred);
    return pose.world[0] * preferredPose.world[0].inverse() * planeNormal(preferredPose);
}

// Maya's ikSCsolver, history independent: with the effector on the line to the goal, the start joint turns about that
// line (h) so that the effector's world orientation (its parent joint's, the last of the chain) comes as close as a
// turn about h can to the handle's: the twist of their difference about h. `aimed`: the start joint's turn so far.
Eigen::Matrix3d singleChainTwist(const Pose& pose, const std::vector<Turn>& bends, const Goal& goal,
                                 const Eigen::Vector3d& h, const Eigen::Matrix3d& aimed)
{
    Eigen::Matrix3d effector = polarRotation(pose.world.back());
    for (std::size_t k = bends.size(); k-- > 1;) effector = bends[k].rotation * effector;
    const Eigen::Quaterniond apart(Eigen::Matrix3d(goal.orientation * (aimed * effector).transpose()));
    return Eigen::AngleAxisd(2.0 * std::atan2(apart.vec().dot(h), apart.w()), h).toRotationMatrix();
}

Eigen::Matrix3d startTurn(const Chain& chain, const Pose& pose, const std::vector<Turn>& bends, const Goal& goal)
{
    const std::size_t n = pose.position.size();
    const Eigen::Vector3d start = pose.position[0];
    const Eigen::Vector3d toGoal = goal.position - start;
    const Eigen::Vector3d toEffector = carried(bends, n, pose.effector) - start;
    Eigen::Vector3d plane = Eigen::Vector3d::Zero();
    for (std::size_t k = 1; k < n; ++k) plane += carried(bends, k, pose.position[k]) - start;
    Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
    const double scale = std::max({toGoal.norm(), toEffector.norm(), 1e-300});
    if (!(toGoal.norm() > parallelTolerance * scale && toEffector.norm() > parallelTolerance * scale)) return turn;
    const Eigen::Vector3d h = toGoal.normalized();
    const Eigen::Vector3d e = toEffector.normalized();
    if (e.dot(h) < -1.0 + 1e-15) {  // straight behind: half a turn about the chain plane's normal keeps the plane
        Eigen::Vector3d axis = perpendicular(plane, e).cross(e);
        if (axis.squaredNorm() == 0.0) axis = e.unitOrthogonal();
        turn = Eigen::AngleAxisd(std::numbers::pi, axis.normalized()).toRotationMatrix();
    } else {
        turn = Eigen::Quaterniond::FromTwoVectors(e, h).toRotationMatrix();
    }
    if (goal.solver == SingleChain) return singleChainTwist(pose, bends, goal, h, turn) * turn;
    // The chain's plane by its normal, which a chain straightened past its reach keeps from its reference pose (as
    // Maya's does: a straight arm still turns with its pole vector); h x (turn n) is the plane's side of h.
    Eigen::Vector3d normal = plane.cross(toEffector);
    if (!(normal.norm() > parallelTolerance * scale * scale)) normal = planeNormal(pose);
    if (!(normal.norm() > parallelTolerance * scale * scale)) normal = preferredNormal(chain, pose);
    const Eigen::Vector3d side = h.cross(turn * normal);
    const Eigen::Vector3d pole = perpendicular(goal.pole, h);
    if (side.squaredNorm() > 0.0 && pole.squaredNorm() > 0.0)
        turn = Eigen::AngleAxisd(std::atan2(side.cross(pole).dot(h), side.dot(pole)), h) * turn;
    return Eigen::AngleAxisd(goal.twist, h) * turn;
}

// The solved rotate of every chain joint, as rotation matrices (R_i, before the Euler angles are chosen).
std::vector<Eigen::Matrix3d> solve(const Chain& chain, const Goal& goal)
{
    const std::size_t n = chain.joints.size();
    std::vector<Eigen::Vector3d> rotates;
    for (const ChainJoint& j : chain.joints) rotates.push_back(j.rotate);
    const Pose pose = forward(chain, rotates);
    const double distance = (goal.position - pose.position[0]).norm();
    std::vector<Turn> bends(n);
    for (std::size_t i = 0; i < n; ++i) bends[i].pivot = pose.position[i];
    if (n >= 2) {
        BendFamily f = bendFamily(pose);
        // Straight (no bend axis anywhere): only a goal nearer than the chain's length needs one.
        if (!f.bent && distance < (pose.effector - pose.position[0]).norm() * (1.0 - 1e-12))
            f = fallbackFamily(chain, pose);
        if (f.bent)
            bends = bendTurns(pose, f, n == 2 ? twoBoneScale(pose, f, distance) : chainScale(pose, f, distance));
    }
    bends[0].rotation = startTurn(chain, pose, bends, goal);
    std::vector<Eigen::Matrix3d> out;
    for (std::size_t i = 0; i < n; ++i) {
        const Eigen::Matrix3d& b = pose.frame[i];
        Eigen::Matrix3d local = b.inverse() * bends[i].rotation * b;
        if (!nearlyOrthonormal(local)) local = polarRotation(local);  // a non-uniformly scaled parent
        out.push_back(local * eulerToMatrix(chain.joints[i].rotate, chain.joints[i].order));
    }
    return out;
}

RotateOrder orderOf(int index) { return rotateOrderFromIndex(index).value_or(RotateOrder::xyz); }

// Array elements by logical index, `fallback` where an element is absent.
template <class T>
std::vector<T> elements(const ComputeContext& c, AttrId a, std::size_t n, T fallback)
{
    const auto given = c.elements<T>(a);
    std::vector<T> out(n, fallback);
    for (std::size_t i = 0; i < n; ++i) out[i] = given.valueOr(static_cast<int>(i), fallback);
    return out;
}

Chain readChain(const ComputeContext& c)
{
    std::size_t n = 0;
    c.forEachIndex(JointTranslate, [&](int i) { n = std::max(n, static_cast<std::size_t>(i) + 1); });
    const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
    const auto translate = elements(c, JointTranslate, n, zero);
    const auto rotate = elements(c, JointRotate, n, zero);
    const auto orient = elements(c, JointOrient, n, zero);
    const auto axis = elements(c, JointRotateAxis, n, zero);
    const auto scale = elements(c, JointScale, n, Eigen::Vector3d(Eigen::Vector3d::Ones()));
    const auto preferred = elements(c, JointPreferredAngle, n, zero);
    const auto order = elements(c, JointRotateOrder, n, 0);
    const auto compensate = elements(c, JointSegmentScaleCompensate, n, true);
    Chain chain;
    chain.startParent = c.getMatrix(StartParentMatrix);
    chain.startInverseScale = c.getVector3(StartInverseScale);
    chain.effector = c.getVector3(EffectorTranslate);
    for (std::size_t i = 0; i < n; ++i)
        chain.joints.push_back(ChainJoint{translate[i], rotate[i], orient[i], axis[i], scale[i], preferred[i],
                                          orderOf(order[i]), compensate[i]});
    return chain;
}

// Maya's ikBlend: each joint's rotation from its FK rotate to its IK one by slerp.
Eigen::Matrix3d blend(const Eigen::Matrix3d& fk, const Eigen::Matrix3d& ik, double weight)
{
    if (weight >= 1.0) return ik;
    if (weight <= 0.0) return fk;
    return Eigen::Quaterniond(fk).slerp(weight, Eigen::Quaterniond(ik)).toRotationMatrix();
}

class MayaIkHandleNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        TransformInputs in;
        in.translate = c.getVector3(Translate);
        in.rotate = c.getVector3(Rotate);
        in.rotateOrder = orderOf(c.getEnum(RotateOrderAttr));
        in.scale = c.getVector3(Scale);
        in.shear = c.getVector3(Shear);
        in.rotatePivot = c.getVector3(RotatePivot);
        in.rotatePivotTranslate = c.getVector3(RotatePivotTranslate);
        in.scalePivot = c.getVector3(ScalePivot);
        in.scalePivotTranslate = c.getVector3(ScalePivotTranslate);
        in.rotateAxis = c.getVector3(RotateAxis);
        const Eigen::Matrix4d& parent = c.getMatrix(ParentMatrix);
        const Eigen::Matrix4d local = transformMatrix(in);
        const Eigen::Matrix4d world = parent * local;
        c.setOutput(Matrix, local);
        c.setOutput(WorldMatrix, world);
        c.setOutput(WorldInverseMatrix, Eigen::Matrix4d(world.inverse()));

        const Chain chain = readChain(c);
        std::vector<Value> out;
        if (chain.joints.empty()) {
            c.setOutputElements(OutRotate, std::move(out));
            return;
        }
        // The goal: the handle's rotate pivot in world space; the pole vector: in the handle's parent space.
        const Goal goal{(parent * (in.translate + in.rotatePivotTranslate + in.rotatePivot).homogeneous()).head<3>(),
                        parent.topLeftCorner<3, 3>() * c.getVector3(PoleVector), c.getDouble(Twist),
                        c.getEnum(SolverType) == SingleChain ? SingleChain : RotatePlane,
                        polarRotation(world.topLeftCorner<3, 3>())};
        const double weight = std::clamp(c.getDouble(IkBlend), 0.0, 1.0);
        std::vector<Eigen::Matrix3d> ik;
        if (weight > 0.0) ik = solve(chain, goal);
        for (std::size_t i = 0; i < chain.joints.size(); ++i) {
            const ChainJoint& j = chain.joints[i];
            Eigen::Vector3d euler = j.rotate;
            if (weight > 0.0) {
                const Eigen::Matrix3d r = blend(eulerToMatrix(j.rotate, j.order), ik[i], weight);
                euler = closestEuler(matrixToEuler(r, j.order), j.rotate, j.order);
            }
            // Overflowing or NaN inputs must not reach the joints as NaN: the FK rotate stands in.
            out.emplace_back(euler.allFinite() ? euler : (j.rotate.allFinite() ? j.rotate : Eigen::Vector3d::Zero()));
        }
        c.setOutputElements(OutRotate, std::move(out));
    }
};

void declareTransform(NodeTypeBuilder& b)
{
    b.input(Translate, "translate", ValueType::Vector3)
        .shortName("t")
        .unit(Unit::Distance)
        .keyable()
        .doc("The handle's translation, cm (moves the goal).");
    b.input(Rotate, "rotate", ValueType::Vector3)
        .shortName("r")
        .unit(Unit::Angle)
        .keyable()
        .doc("The handle's rotation (no effect on the solve).");
    b.input(RotateOrderAttr, "rotateOrder", ValueType::Enum)
        .shortName("ro")
        .enumNames(rotateOrderEnumNames())
        .doc("The order of the handle's rotate angles.");
    b.input(Scale, "scale", ValueType::Vector3)
        .shortName("s")
        .defaultValue(Eigen::Vector3d(1, 1, 1))
        .keyable()
        .doc("The handle's scale.");
    b.input(Shear, "shear", ValueType::Vector3)
        .shortName("sh")
        .children("shearXY", "shearXZ", "shearYZ")
        .doc("The handle's shear xy, xz, yz.");
    b.input(RotatePivot, "rotatePivot", ValueType::Vector3)
        .shortName("rp")
        .unit(Unit::Distance)
        .doc("The handle's rotate pivot, cm: with translate, the goal.");
    b.input(RotatePivotTranslate, "rotatePivotTranslate", ValueType::Vector3)
        .shortName("rpt")
        .unit(Unit::Distance)
        .doc("Offset of the rotate pivot, cm (moves the goal).");
    b.input(ScalePivot, "scalePivot", ValueType::Vector3)
        .shortName("sp")
        .unit(Unit::Distance)
        .doc("The handle's scale pivot, cm.");
    b.input(ScalePivotTranslate, "scalePivotTranslate", ValueType::Vector3)
        .shortName("spt")
        .unit(Unit::Distance)
        .doc("Offset of the scale pivot, cm.");
    b.input(RotateAxis, "rotateAxis", ValueType::Vector3)
        .shortName("ra")
        .unit(Unit::Angle)
        .doc("The handle's rotate axis (xyz).");
    b.input(ParentMatrix, "parentMatrix", ValueType::Matrix4)
        .shortName("pm")
        .doc("World matrix of the handle's parent (identity at the root): the goal's and pole's space.");
}

void declareHandle(NodeTypeBuilder& b)
{
    b.input(PoleVector, "poleVector", ValueType::Vector3)
        .shortName("pv")
        .defaultValue(Eigen::Vector3d(0, 1, 0))
        .keyable()
        .doc(
            "ikRPsolver: the direction from the start joint toward the side the chain bends to, in the handle's "
            "parent space (a poleVectorConstraint's constraintTranslate); only its direction matters. Zero or "
            "parallel to start->goal: the chain's plane turns with the smallest rotation.");
    b.input(Twist, "twist", ValueType::Double)
        .shortName("twi")
        .unit(Unit::Angle)
        .keyable()
        .doc("ikRPsolver: the chain's plane turned about start->goal.");
    b.input(IkBlend, "ikBlend", ValueType::Double)
        .shortName("ikb")
        .defaultValue(1.0)
        .range(0.0, 1.0)
        .keyable()
        .doc("1: the IK solve; 0: the FK rotates (jointRotate); between: each joint slerped from FK to IK.");
    b.input(Roll, "roll", ValueType::Double)
        .shortName("rol")
        .unit(Unit::Angle)
        .keyable()
        .doc("Maya's spline-IK roll: read, no effect on RP and SC.");
    b.input(Offset, "offset", ValueType::Double)
        .shortName("off")
        .doc("Maya's spline-IK offset along the curve: read, no effect on RP and SC.");
    b.input(SolverType, "solverType", ValueType::Enum)
        .enumNames({"ikRPsolver", "ikSCsolver"})
        .doc("The solver (Maya's .hsv connection): rotate plane (pole vector, twist) or single chain.");
}

void declareChain(NodeTypeBuilder& b)
{
    b.input(StartParentMatrix, "startParentMatrix", ValueType::Matrix4)
        .doc("World matrix of the start joint's parent (identity for a root joint).");
    b.input(StartInverseScale, "startInverseScale", ValueType::Vector3)
        .defaultValue(Eigen::Vector3d(1, 1, 1))
        .doc("The start joint's inverseScale (its parent's scale, undone with segmentScaleCompensate).");
    b.input(JointTranslate, "jointTranslate", ValueType::Vector3)
        .array()
        .unit(Unit::Distance)
        .doc("Chain joint i's translate, cm; i = 0 the start joint. Its count is the chain's.");
    b.input(JointRotate, "jointRotate", ValueType::Vector3)
        .array()
        .unit(Unit::Angle)
        .doc("Chain joint i's rotate as saved or as FK drives it: the pose the solve starts from, and ikBlend's FK.");
    b.input(JointOrient, "jointOrient", ValueType::Vector3)
        .array()
        .unit(Unit::Angle)
        .doc("Chain joint i's jointOrient (xyz).");
    b.input(JointRotateAxis, "jointRotateAxis", ValueType::Vector3)
        .array()
        .unit(Unit::Angle)
        .doc("Chain joint i's rotateAxis (xyz).");
    b.input(JointRotateOrder, "jointRotateOrder", ValueType::Enum)
        .array()
        .enumNames(rotateOrderEnumNames())
        .doc("Chain joint i's rotateOrder: the order of outRotate[i].");
    b.input(JointScale, "jointScale", ValueType::Vector3)
        .array()
        .defaultValue(Eigen::Vector3d(1, 1, 1))
        .doc("Chain joint i's scale.");
    b.input(JointSegmentScaleCompensate, "jointSegmentScaleCompensate", ValueType::Bool)
        .array()
        .defaultValue(true)
        .doc("Chain joint i's segmentScaleCompensate (its inverseScale: joint i-1's scale).");
    b.input(JointPreferredAngle, "jointPreferredAngle", ValueType::Vector3)
        .array()
        .unit(Unit::Angle)
        .doc("Chain joint i's preferredAngle: the way a straight chain bends.");
    b.input(EffectorTranslate, "effectorTranslate", ValueType::Vector3)
        .unit(Unit::Distance)
        .doc("The effector's translate in the last chain joint's frame (Maya connects the end joint's translate).");
}

}  // namespace

std::shared_ptr<const NodeType> makeMayaIkHandleType()
{
    NodeTypeBuilder b("mayaIkHandle");
    b.mayaType("ikHandle");
    b.description(
        "Maya's ikHandle with the ikRPsolver or ikSCsolver on a chain of 1 to N joints (docs/ik-and-deformers.md). "
        "The goal is the handle's rotate pivot in world space; the chain is given as inputs (jointTranslate[i] ..., "
        "i = 0 the start joint) and the solve starts from jointRotate. 2 bones: the mid joint bends about "
        "(start->mid) x (mid->effector) so that |start->effector| = |start->goal| (clamped), the start joint "
        "turns the effector onto the goal, then (RP) about start->goal so that the mid joint lies on the pole "
        "vector's side, then by twist, or (SC) about start->goal so that the effector's orientation (the last chain "
        "joint's) comes as close as that turn can to the handle's world orientation. 3+ bones: every bend scaled by "
        "one factor. outRotate[i] drives joint i's "
        "rotate, the Euler triple nearest jointRotate[i]; ikBlend slerps each joint from jointRotate.");
    declareTransform(b);
    declareHandle(b);
    declareChain(b);
    b.output(Matrix, "matrix", ValueType::Matrix4).shortName("m").doc("The handle's local matrix.");
    b.output(WorldMatrix, "worldMatrix", ValueType::Matrix4).shortName("wm").doc("parentMatrix * matrix.");
    b.output(WorldInverseMatrix, "worldInverseMatrix", ValueType::Matrix4)
        .shortName("wim")
        .doc("Inverse of worldMatrix.");
    b.output(OutRotate, "outRotate", ValueType::Vector3)
        .array()
        .unit(Unit::Angle)
        .doc("The solved rotate of chain joint i, in jointRotateOrder[i]: connect to the joint's rotate.");
    // Every transform input moves the goal or turns the handle, which an ikSCsolver's chain turns toward.
    for (AttrId a = Translate; a <= ParentMatrix; ++a)
        b.affects(a, {Matrix, WorldMatrix, WorldInverseMatrix, OutRotate});
    for (AttrId a = PoleVector; a <= EffectorTranslate; ++a)
        if (a != Roll && a != Offset) b.affects(a, {OutRotate});
    return b.factory<MayaIkHandleNode>().build();
}

}  // namespace rig
