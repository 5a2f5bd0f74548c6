#include "inversion/constraint.h"

#include <cmath>
#include <limits>

#include <Eigen/Geometry>

namespace rig {
namespace {

// Below this a direction is taken as undefined: the goal on the root, or the pole on the chain's line.
constexpr double degenerateLength = 1e-9;

using Affine = Eigen::Matrix<double, 3, 4>;

Eigen::Matrix4d rigidInverse(const Eigen::Matrix4d& m)
{
    Eigen::Matrix4d inverse = Eigen::Matrix4d::Identity();
    inverse.block<3, 3>(0, 0) = m.block<3, 3>(0, 0).transpose();
    inverse.block<3, 1>(0, 3) = -inverse.block<3, 3>(0, 0) * m.block<3, 1>(0, 3);
    return inverse;
}

// The body rates of Euler angles: R(a)^T dR = [E(a) da]x, for R = R3 R2 R1 in the order's application order
// (R1 = Rot(e_i1, a_i1) acts first), so that E's columns are R1^T R2^T e_i3, R1^T e_i2 and e_i1 at i3, i2, i1.
Eigen::Matrix3d eulerRates(const Eigen::Vector3d& a, RotateOrder order)
{
    const std::string_view name = rotateOrderName(order);
    const int i1 = name[0] - 'x', i2 = name[1] - 'x', i3 = name[2] - 'x';
    const Eigen::Matrix3d r1 = Eigen::AngleAxisd(a[i1], Eigen::Vector3d::Unit(i1)).toRotationMatrix();
    const Eigen::Matrix3d r2 = Eigen::AngleAxisd(a[i2], Eigen::Vector3d::Unit(i2)).toRotationMatrix();
    Eigen::Matrix3d e;
    e.col(i1) = Eigen::Vector3d::Unit(i1);
    e.col(i2) = r1.transpose() * Eigen::Vector3d::Unit(i2);
    e.col(i3) = r1.transpose() * r2.transpose() * Eigen::Vector3d::Unit(i3);
    return e;
}

Eigen::Matrix3d polarOf(const Eigen::Matrix4d& m, Eigen::Matrix3d* symmetric = nullptr)
{
    return polarRotation(m.block<3, 3>(0, 0), symmetric);
}

// A twist share's B for the anchor's motion, its polar rotation and the driver's twist.
Eigen::Matrix4d twistTurn(const ConstraintBase& base, const Eigen::Matrix4d& anchorMotion,
                          const Eigen::Matrix3d& anchorQ, double tau)
{
    const Eigen::Matrix3d rotation = anchorQ * Eigen::AngleAxisd(base.share * tau, base.axis).toRotationMatrix();
    Eigen::Matrix4d b = Eigen::Matrix4d::Identity();
    b.block<3, 3>(0, 0) = rotation;
    b.block<3, 1>(0, 3) =
        anchorMotion.block<3, 3>(0, 0) * base.root + anchorMotion.block<3, 1>(0, 3) - rotation * base.root;
    return b;
}

// The vector of a skew matrix's skew part.
Eigen::Vector3d vee(const Eigen::Matrix3d& k)
{
    return 0.5 * Eigen::Vector3d(k(2, 1) - k(1, 2), k(0, 2) - k(2, 0), k(1, 0) - k(0, 1));
}

}  // namespace

std::string_view constraintKindName(ConstraintKind kind)
{
    return kind == ConstraintKind::twistShare ? "twistShare" : "planarChain";
}

std::optional<ConstraintKind> constraintKindFromName(std::string_view name)
{
    for (const ConstraintKind kind : {ConstraintKind::planarChain, ConstraintKind::twistShare})
        if (constraintKindName(kind) == name) return kind;
    return std::nullopt;
}

std::array<int, 3> ConstraintBase::inputs() const
{
    if (kind == ConstraintKind::twistShare) return {anchor, driver, driverParent};
    return {anchor, goal, pole};
}

bool chainFrame(const ChainPoints& points, bool restPlane, Eigen::Matrix4d& frame)
{
    const Eigen::Vector3d u = points.goal - points.root;
    const double reach = u.norm();
    if (!(reach > degenerateLength)) return false;
    const Eigen::Vector3d x = u / reach;
    const Eigen::Vector3d p = points.pole - points.root;
    const Eigen::Vector3d w = restPlane ? Eigen::Vector3d(x.cross(points.normal)) : Eigen::Vector3d(p - p.dot(x) * x);
    const double across = w.norm();
    if (!(across > degenerateLength * (restPlane ? 1.0 : std::max(1.0, p.norm())))) return false;
    const Eigen::Vector3d y = w / across;
    frame.setIdentity();
    frame.block<3, 1>(0, 0) = x;
    frame.block<3, 1>(0, 1) = y;
    frame.block<3, 1>(0, 2) = x.cross(y);
    frame.block<3, 1>(0, 3) = points.root;
    return true;
}

bool ConstraintBase::prepare(const Eigen::Vector3d& restGoal)
{
    Eigen::Matrix4d frame;
    if (!chainFrame({root, restGoal, restPole, restNormal}, restPlane, frame)) return false;
    restFrame = frame;
    restFrameInverse = rigidInverse(frame);
    restReach = (restGoal - root).norm();
    return true;
}

ChainPoints chainPoints(const ConstraintBase& base, const Eigen::Matrix4d& anchorMotion,
                        const Eigen::Matrix4d& goalWorld, const Eigen::Matrix4d& poleWorld)
{
    const auto carried = [&](const Eigen::Vector3d& p) -> Eigen::Vector3d {
        return anchorMotion.block<3, 3>(0, 0) * p + anchorMotion.block<3, 1>(0, 3);
    };
    return {carried(base.root), goalWorld.block<3, 1>(0, 3),
            base.pole >= 0 ? Eigen::Vector3d(poleWorld.block<3, 1>(0, 3))
            : base.worldUp ? Eigen::Vector3d(carried(base.root) + base.restPole - base.root)
                           : carried(base.restPole),
            anchorMotion.block<3, 3>(0, 0) * base.restNormal};
}

Eigen::Matrix4d constraintBase(const ConstraintBase& base, const ChainPoints& points)
{
    Eigen::Matrix4d frame;
    if (!chainFrame(points, base.restPlane, frame))
        return Eigen::Matrix4d::Constant(std::numeric_limits<double>::quiet_NaN());
    const double reach = (points.goal - points.root).norm();
    return frame * base.shape.matrix(reach - base.restReach) * base.restFrameInverse;
}

BaseLinearization linearizeBase(const ConstraintBase& base, const ChainPoints& points)
{
    BaseLinearization l;
    l.restPlane = base.restPlane;
    l.normal = points.normal;
    l.root = points.root;
    const Eigen::Vector3d u = points.goal - points.root;
    l.reach = u.norm();
    l.x = u / l.reach;
    l.pole = points.pole - points.root;
    const Eigen::Vector3d w =
        l.restPlane ? Eigen::Vector3d(l.x.cross(l.normal)) : Eigen::Vector3d(l.pole - l.pole.dot(l.x) * l.x);
    l.across = w.norm();
    l.y = w / l.across;
    l.frame << l.x, l.y, l.x.cross(l.y);
    // The shape's own motion per unit of reach, dG G^-1 with G rigid, turned into world space by C.
    const double a = l.reach - base.restReach;
    const Eigen::Matrix4d g = base.shape.matrix(a);
    const Eigen::Matrix4d dg = base.shape.derivative(a);
    const Eigen::Matrix3d omega = dg.block<3, 3>(0, 0) * g.block<3, 3>(0, 0).transpose();
    const Eigen::Vector3d v = dg.block<3, 1>(0, 3) - omega * g.block<3, 1>(0, 3);
    const Eigen::Matrix3d omegaWorld = l.frame * omega * l.frame.transpose();
    l.shape.leftCols<3>() = omegaWorld;
    l.shape.col(3) = l.frame * v - omegaWorld * l.root;
    return l;
}

Affine baseVelocity(const BaseLinearization& l, const ChainPoints& rate)
{
    // dB B^-1 = dC C^-1 + C (dG G^-1) C^-1 (C0 is constant). The frame's columns change as unit vectors do:
    // d(u / |u|) = (I - x x^T) du / |u|.
    const Eigen::Vector3d du = rate.goal - rate.root;
    const Eigen::Vector3d dx = (du - l.x * l.x.dot(du)) / l.reach;
    const Eigen::Vector3d dp = rate.pole - rate.root;
    const Eigen::Vector3d dw = l.restPlane
                                   ? Eigen::Vector3d(dx.cross(l.normal) + l.x.cross(rate.normal))
                                   : Eigen::Vector3d(dp - (dp.dot(l.x) + l.pole.dot(dx)) * l.x - l.pole.dot(l.x) * dx);
    const Eigen::Vector3d dy = (dw - l.y * l.y.dot(dw)) / l.across;
    Eigen::Matrix3d dr;
    dr << dx, dy, dx.cross(l.y) + l.x.cross(dy);
    const Eigen::Matrix3d omega = dr * l.frame.transpose();
    Affine v = l.x.dot(du) * l.shape;
    v.leftCols<3>() += omega;
    v.col(3) += rate.root - omega * l.root;
    return v;
}

double driverTwist(const ConstraintBase& base, const Eigen::Matrix3d& relative, Eigen::Vector3d* gradient)
{
    const Eigen::Matrix3d r = base.driverRest.transpose() * relative;
    // The rig's reading: R's angles in readOrder taken in twistOrder (the same order: R itself).
    Eigen::Matrix3d read = r, rates = Eigen::Matrix3d::Identity();
    if (base.readOrder != base.twistOrder) {
        const Eigen::Vector3d angles = matrixToEuler(r, base.readOrder);
        read = eulerToMatrix(angles, base.twistOrder);
        // A turn delta of R changes the angles by E_read^-1 delta, which turn the read rotation by E_twist of that.
        rates = eulerRates(angles, base.twistOrder) * eulerRates(angles, base.readOrder).inverse();
    }
    Eigen::Quaterniond q(read);
    if (q.w() < 0) q.coeffs() = -q.coeffs();
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(base.twistAxis);
    const double s = q.vec().dot(e), c = q.w();
    if (gradient) {
        // q turned by delta in its own frame: dq_w = -q_v . delta / 2, dq_v = (q_w delta + q_v x delta) / 2.
        const Eigen::Vector3d g = (c * (c * e + e.cross(q.vec())) + s * q.vec()) / (s * s + c * c);
        *gradient = rates.transpose() * g;
        if (!gradient->allFinite()) gradient->setZero();
    }
    return 2.0 * std::atan2(s, c);
}

bool twistSingular(const ConstraintBase& base, const Eigen::Matrix3d& relative)
{
    // Below these the angles' split or the twist's sign is decided by rounding.
    constexpr double gimbal = 1e-9, halfTurn = 1e-12;
    const Eigen::Matrix3d r = base.driverRest.transpose() * relative;
    Eigen::Matrix3d read = r;
    if (base.readOrder != base.twistOrder) {
        const Eigen::Vector3d angles = matrixToEuler(r, base.readOrder);
        const int middle = rotateOrderName(base.readOrder)[1] - 'x';
        if (std::abs(std::cos(angles[middle])) < gimbal) return true;
        read = eulerToMatrix(angles, base.twistOrder);
    }
    const Eigen::Quaterniond q(read);
    const double s = q.vec()[base.twistAxis], c = q.w();
    // A half-turn swing leaves no twist; a twist of a half turn is where it wraps from +pi to -pi.
    return s * s + c * c < halfTurn || std::abs(c) < gimbal * std::abs(s);
}

Eigen::Vector3d polarRate(const Eigen::Matrix3d& q, const Eigen::Matrix3d& s, const Eigen::Matrix3d& l)
{
    // A = Q S, dA = L A: Q^T dA = W S + dS with W = Q^T dQ skew and dS symmetric, so the skew part of
    // M = Q^T L Q S is W S + S W, whose vector is (tr S I - S) w.
    const Eigen::Matrix3d m = q.transpose() * l * q * s;
    const Eigen::Matrix3d t = s.trace() * Eigen::Matrix3d::Identity() - s;
    return q * t.inverse() * (2.0 * vee(m));
}

TwistLinearization linearizeTwist(const ConstraintBase& base, const Eigen::Matrix4d& anchorMotion,
                                  const Eigen::Matrix4d& driverWorld, const Eigen::Matrix4d& parentWorld)
{
    TwistLinearization l;
    l.anchorQ = polarOf(anchorMotion, &l.anchorS);
    l.driverQ = polarOf(driverWorld, &l.driverS);
    l.parentQ = polarOf(parentWorld, &l.parentS);
    const double tau = driverTwist(base, l.parentQ.transpose() * l.driverQ, &l.gradient);
    l.gradient *= base.share;
    l.centre = anchorMotion.block<3, 3>(0, 0) * base.root + anchorMotion.block<3, 1>(0, 3);
    l.turnAxis = l.anchorQ * base.axis;
    l.base = twistTurn(base, anchorMotion, l.anchorQ, tau);
    return l;
}

Affine twistVelocity(const TwistLinearization& l, const Affine& anchor, const Affine& driver, const Affine& parent)
{
    // B y = R (y - c0) + m with R = Q_a Rot(u0, w tau), m = M_a c0: omega = omega(Q_a) + Q_a u0 w dtau, and the
    // twist's translation part v = dm - omega x m.
    const Eigen::Vector3d driverTurn = l.driverQ.transpose() * (polarRate(l.driverQ, l.driverS, driver.leftCols<3>()) -
                                                                polarRate(l.parentQ, l.parentS, parent.leftCols<3>()));
    const Eigen::Vector3d omega =
        polarRate(l.anchorQ, l.anchorS, anchor.leftCols<3>()) + l.turnAxis * l.gradient.dot(driverTurn);
    const Eigen::Vector3d moved = anchor.leftCols<3>() * l.centre + anchor.col(3);
    Affine v;
    v.leftCols<3>() = skew(omega);
    v.col(3) = moved - omega.cross(l.centre);
    return v;
}

Eigen::Matrix4d constraintBase(const ConstraintBase& base, const Eigen::Matrix4d& anchorMotion,
                               const Eigen::Matrix4d& second, const Eigen::Matrix4d& third)
{
    if (base.kind == ConstraintKind::twistShare) {
        // The base alone: no polar stretch parts and no twist gradient, which only its velocity needs.
        const Eigen::Matrix3d anchorQ = polarOf(anchorMotion);
        const double tau = driverTwist(base, polarOf(third).transpose() * polarOf(second));
        const Eigen::Matrix3d rotation = anchorQ * Eigen::AngleAxisd(base.share * tau, base.axis).toRotationMatrix();
        Eigen::Matrix4d b = Eigen::Matrix4d::Identity();
        b.block<3, 3>(0, 0) = rotation;
        b.block<3, 1>(0, 3) =
            anchorMotion.block<3, 3>(0, 0) * base.root + anchorMotion.block<3, 1>(0, 3) - rotation * base.root;
        return b;
    }
    return constraintBase(base, chainPoints(base, anchorMotion, second, third));
}

}  // namespace rig
