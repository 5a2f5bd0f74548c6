#include "inversion/model/constraint.h"

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
    if (kind == ConstraintKind::blend) return "blend";
    if (kind == ConstraintKind::oriented) return "oriented";
    return kind == ConstraintKind::twistShare ? "twistShare" : "planarChain";
}

std::optional<ConstraintKind> constraintKindFromName(std::string_view name)
{
    for (const ConstraintKind kind :
         {ConstraintKind::planarChain, ConstraintKind::twistShare, ConstraintKind::blend, ConstraintKind::oriented})
        if (constraintKindName(kind) == name) return kind;
    return std::nullopt;
}

std::array<int, 3> ConstraintBase::inputs() const
{
    if (kind == ConstraintKind::twistShare) return {anchor, driver, driverParent};
    if (kind == ConstraintKind::blend) return {anchor, ik, fk};
    if (kind == ConstraintKind::oriented) return {anchor, -1, -1};
    return {anchor, goal, pole};
}

std::array<int, 5> ConstraintBase::frameInputs() const
{
    const std::array<int, 3> in = inputs();
    if (kind == ConstraintKind::blend) return {in[0], in[1], in[2], ikParent, fkParent};
    if (kind == ConstraintKind::planarChain || kind == ConstraintKind::oriented)
        return {in[0], in[1], in[2], orient, -1};
    return {in[0], in[1], in[2], -1, -1};
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

void minimalTurnNormal(const ConstraintBase& base, const Eigen::Matrix3d& anchorLinear, ChainPoints& points)
{
    // R_min(e -> x) N = N - (x . N) / (1 + e . x) (e + x), for N across e.
    const Eigen::Vector3d u = points.goal - points.root;
    const double reach = u.norm();
    const Eigen::Vector3d x = u / reach;
    const Eigen::Vector3d x0 = base.restFrame.block<3, 1>(0, 0);
    const double alpha = base.lineTurn.magnitude(reach - base.restReach);
    points.carried = anchorLinear * base.restNormal;
    points.line = anchorLinear * Eigen::AngleAxisd(alpha, base.restNormal).toRotationMatrix() * x0;
    points.normal = points.carried - x.dot(points.carried) / (1.0 + points.line.dot(x)) * (points.line + x);
}

ChainPoints chainPoints(const ConstraintBase& base, const Eigen::Matrix4d& anchorMotion,
                        const Eigen::Matrix4d& goalWorld, const Eigen::Matrix4d& poleWorld)
{
    const auto carried = [&](const Eigen::Vector3d& p) -> Eigen::Vector3d {
        return anchorMotion.block<3, 3>(0, 0) * p + anchorMotion.block<3, 1>(0, 3);
    };
    const Eigen::Vector3d root = carried(base.root);
    Eigen::Vector3d pole = carried(base.restPole);
    if (base.pole >= 0 && base.poleTurns)
        pole = root + poleWorld.block<3, 3>(0, 0) * base.poleRest.inverse() * (base.restPole - base.root);
    else if (base.pole >= 0) pole = poleWorld.block<3, 1>(0, 3);
    else if (base.worldUp) pole = root + base.restPole - base.root;
    ChainPoints points{root, goalWorld.block<3, 1>(0, 3), pole, anchorMotion.block<3, 3>(0, 0) * base.restNormal};
    if (base.minimalTurn)
        minimalTurnNormal(base,
                          base.goalTurns ? Eigen::Matrix3d(goalWorld.block<3, 3>(0, 0) * base.goalRest.inverse())
                                         : Eigen::Matrix3d(anchorMotion.block<3, 3>(0, 0)),
                          points);
    return points;
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
    l.inverseReach = 1.0 / l.reach;
    l.inverseAcross = 1.0 / l.across;
    l.y = w / l.across;  // divided as chainFrame divides: the frame is the evaluated base's to the bit
    l.frame << l.x, l.y, l.x.cross(l.y);
    // The shape's own motion per unit of reach, dG G^-1 with G rigid, turned into world space by C.
    const double a = l.reach - base.restReach;
    const Eigen::Matrix4d g = base.shape.matrix(a);
    const Eigen::Matrix4d dg = base.shape.derivative(a);
    const Eigen::Matrix3d omega = dg.block<3, 3>(0, 0) * g.block<3, 3>(0, 0).transpose();
    const Eigen::Vector3d v = dg.block<3, 1>(0, 3) - omega * g.block<3, 1>(0, 3);
    const Eigen::Vector3d omegaWorld =
        l.frame * Eigen::Vector3d(0.5 * (omega(2, 1) - omega(1, 2)), 0.5 * (omega(0, 2) - omega(2, 0)),
                                  0.5 * (omega(1, 0) - omega(0, 1)));
    l.shape << omegaWorld, l.frame * v - omegaWorld.cross(l.root);
    if (base.minimalTurn) {
        // e turns with the anchor and, as the reach changes, about the carried normal by the line's turn.
        l.lineTurn = base.lineTurn.magnitudeDerivative(a) * points.carried.normalized().cross(points.line);
        l.inverseTurnScale = 1.0 / (1.0 + points.line.dot(l.x));
        l.turnDot = l.x.dot(points.carried);
    }
    return l;
}

Eigen::Vector3d minimalTurnRate(const BaseLinearization& l, const ChainPoints& points, const ChainPoints& rate,
                                const Eigen::Vector3d& carriedRate, const Eigen::Vector3d& lineRate)
{
    // The normal N - s / c (e + x), s = x . N and c = 1 + e . x (minimalTurnNormal), differentiated.
    const Eigen::Vector3d du = rate.goal - rate.root;
    const Eigen::Vector3d dx = (du - l.x * l.x.dot(du)) * l.inverseReach;
    const Eigen::Vector3d de = lineRate + l.x.dot(du) * l.lineTurn;
    const double ratio = l.turnDot * l.inverseTurnScale;  // s / c
    const double dc = de.dot(l.x) + points.line.dot(dx), ds = dx.dot(points.carried) + l.x.dot(carriedRate);
    return carriedRate - (ds - ratio * dc) * l.inverseTurnScale * (points.line + l.x) - ratio * (de + dx);
}

Eigen::Matrix<double, 6, 1> baseVelocity(const BaseLinearization& l, const ChainPoints& rate)
{
    // dB B^-1 = dC C^-1 + C (dG G^-1) C^-1 (C0 is constant). The frame's columns change as unit vectors do:
    // d(u / |u|) = (I - x x^T) du / |u|. An orthonormal frame [f_i] turning at omega has df_i = omega x f_i, so
    // omega = (sum of f_i x df_i) / 2.
    const Eigen::Vector3d du = rate.goal - rate.root;
    const Eigen::Vector3d dx = (du - l.x * l.x.dot(du)) * l.inverseReach;
    const Eigen::Vector3d dp = rate.pole - rate.root;
    const Eigen::Vector3d dw = l.restPlane
                                   ? Eigen::Vector3d(dx.cross(l.normal) + l.x.cross(rate.normal))
                                   : Eigen::Vector3d(dp - (dp.dot(l.x) + l.pole.dot(dx)) * l.x - l.pole.dot(l.x) * dx);
    const Eigen::Vector3d dy = (dw - l.y * l.y.dot(dw)) * l.inverseAcross;
    const Eigen::Vector3d dz = dx.cross(l.y) + l.x.cross(dy);
    const Eigen::Vector3d omega =
        0.5 * (l.frame.col(0).cross(dx) + l.frame.col(1).cross(dy) + l.frame.col(2).cross(dz));
    Eigen::Matrix<double, 6, 1> v = l.x.dot(du) * l.shape;
    v.head<3>() += omega;
    v.tail<3>() += rate.root - omega.cross(l.root);
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

Eigen::Matrix4d orientedBase(const ConstraintBase& base, const Eigen::Matrix4d& chain,
                             const Eigen::Matrix4d& orientMotion)
{
    if (base.orient < 0) return chain;
    const Eigen::Matrix3d q = polarOf(orientMotion);
    const Eigen::Vector3d centre = chain.block<3, 3>(0, 0) * base.origin + chain.block<3, 1>(0, 3);
    Eigen::Matrix4d b = Eigen::Matrix4d::Identity();
    b.block<3, 3>(0, 0) = q;
    b.block<3, 1>(0, 3) = centre - q * base.origin;
    return b;
}

Eigen::Matrix<double, 6, 1> orientedVelocity(const Eigen::Vector3d& centreRate, const Eigen::Vector3d& orientOmega,
                                             const Eigen::Vector3d& centre)
{
    // B' = [Q | c - Q p0]: dB' B'^-1 = [dQ Q^T | dc - dQ Q^T c].
    Eigen::Matrix<double, 6, 1> v;
    v << orientOmega, centreRate - orientOmega.cross(centre);
    return v;
}

Eigen::Matrix4d constraintBase(const ConstraintBase& base, const Eigen::Matrix4d& anchorMotion,
                               const Eigen::Matrix4d& second, const Eigen::Matrix4d& third,
                               const Eigen::Matrix4d& orientMotion)
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
    // An oriented base is a chain's orientation of the anchor's motion: the origin where the anchor carries it.
    if (base.kind == ConstraintKind::oriented) return orientedBase(base, anchorMotion, orientMotion);
    return orientedBase(base, constraintBase(base, chainPoints(base, anchorMotion, second, third)), orientMotion);
}

namespace {

// A local transform's parts, as a blend takes them: A = R S (R the polar rotation, S its symmetric stretch) and t.
struct LocalParts {
    Eigen::Matrix3d rotation, stretch;
    Eigen::Vector3d translate;
};

LocalParts localParts(const Eigen::Matrix4d& local)
{
    LocalParts parts;
    parts.rotation = polarRotation(local.block<3, 3>(0, 0), &parts.stretch);
    parts.translate = local.block<3, 1>(0, 3);
    return parts;
}

// A branch's Euler angles as the rig holds them: nearest rest.
Eigen::Vector3d restEuler(const Eigen::Matrix3d& rotation, RotateOrder order)
{
    return closestEuler(matrixToEuler(rotation, order), Eigen::Vector3d::Zero(), order);
}

Eigen::Matrix3d expSo3(const Eigen::Vector3d& phi)
{
    const double angle = phi.norm();
    if (angle < 1e-300) return Eigen::Matrix3d::Identity();
    return Eigen::AngleAxisd(angle, phi / angle).toRotationMatrix();
}

Eigen::Vector3d logSo3(const Eigen::Matrix3d& r)
{
    const Eigen::AngleAxisd aa(r);
    return aa.angle() * aa.axis();
}

// SO(3)'s right Jacobian, exp(phi + d) = exp(phi) exp(J_r(phi) d) to first order, and its inverse; their series near
// zero, where the closed forms lose their digits.
Eigen::Matrix3d rightJacobian(const Eigen::Vector3d& phi)
{
    const double t = phi.norm();
    const Eigen::Matrix3d k = skew(phi);
    if (t < 1e-4) return Eigen::Matrix3d::Identity() - 0.5 * k + k * k / 6.0;
    return Eigen::Matrix3d::Identity() - (1.0 - std::cos(t)) / (t * t) * k + (t - std::sin(t)) / (t * t * t) * k * k;
}

Eigen::Matrix3d rightJacobianInverse(const Eigen::Vector3d& phi)
{
    const double t = phi.norm();
    const Eigen::Matrix3d k = skew(phi);
    if (t < 1e-4) return Eigen::Matrix3d::Identity() + 0.5 * k + k * k / 12.0;
    return Eigen::Matrix3d::Identity() + 0.5 * k +
           (1.0 / (t * t) - (1.0 + std::cos(t)) / (2.0 * t * std::sin(t))) * k * k;
}

Eigen::Matrix3d blendRotation(const BlendRule& rule, double w, const Eigen::Matrix3d& ik, const Eigen::Matrix3d& fk)
{
    if (rule.mode == BlendMode::slerp) return fk * expSo3(w * logSo3(fk.transpose() * ik));
    const Eigen::Vector3d angles = (1.0 - w) * restEuler(fk, rule.order) + w * restEuler(ik, rule.order);
    return eulerToMatrix(angles, rule.order);
}

// A branch's rotation rate in its own (body) frame, R^T dR, and its stretch's rate, for its local moving at `rate`.
struct PartsRate {
    Eigen::Vector3d turn;
    Eigen::Matrix3d stretch;
};

PartsRate partsRate(const LocalParts& parts, const Eigen::Matrix4d& local, const Eigen::Matrix4d& rate)
{
    const Eigen::Matrix3d a = local.block<3, 3>(0, 0), da = rate.block<3, 3>(0, 0);
    const Eigen::Vector3d spatial = polarRate(parts.rotation, parts.stretch, da * a.inverse());
    PartsRate r;
    r.turn = parts.rotation.transpose() * spatial;
    r.stretch = parts.rotation.transpose() * (da - skew(spatial) * a);
    return r;
}

// The blended rotation's body rate, from the branches' body rates.
Eigen::Vector3d blendTurnRate(const BlendRule& rule, double w, const LocalParts& ik, const LocalParts& fk, double dw,
                              const PartsRate& dIk, const PartsRate& dFk)
{
    if (rule.mode == BlendMode::slerp) {
        // R = R_fk exp(w phi), phi = log(R_fk^T R_ik): R^T dR = exp(-w phi) [dFk] exp(w phi) + J_r(w phi) d(w phi),
        // with d phi = J_r(phi)^-1 (R_ik^T (omega_ik - omega_fk)) in spatial rates, that is dIk - Delta^T dFk.
        const Eigen::Matrix3d delta = fk.rotation.transpose() * ik.rotation;
        const Eigen::Vector3d phi = logSo3(delta);
        const Eigen::Matrix3d step = expSo3(w * phi);
        const Eigen::Vector3d dphi = rightJacobianInverse(phi) * (dIk.turn - delta.transpose() * dFk.turn);
        return step.transpose() * dFk.turn + rightJacobian(w * phi) * (dw * phi + w * dphi);
    }
    const Eigen::Vector3d aIk = restEuler(ik.rotation, rule.order), aFk = restEuler(fk.rotation, rule.order);
    const Eigen::Vector3d rateIk = eulerRates(aIk, rule.order).inverse() * dIk.turn;
    const Eigen::Vector3d rateFk = eulerRates(aFk, rule.order).inverse() * dFk.turn;
    const Eigen::Vector3d angles = (1.0 - w) * aFk + w * aIk;
    return eulerRates(angles, rule.order) * ((1.0 - w) * rateFk + w * rateIk + dw * (aIk - aFk));
}

}  // namespace

std::string_view blendModeName(BlendMode mode) { return mode == BlendMode::slerp ? "slerp" : "eulerChannels"; }

std::optional<BlendMode> blendModeFromName(std::string_view name)
{
    for (const BlendMode mode : {BlendMode::eulerChannels, BlendMode::slerp})
        if (blendModeName(mode) == name) return mode;
    return std::nullopt;
}

Eigen::Matrix4d blendLocal(const BlendRule& rule, double w, const Eigen::Matrix4d& ik, const Eigen::Matrix4d& fk)
{
    const LocalParts a = localParts(ik), b = localParts(fk);
    Eigen::Matrix4d local = Eigen::Matrix4d::Identity();
    local.block<3, 3>(0, 0) = blendRotation(rule, w, a.rotation, b.rotation) * ((1.0 - w) * b.stretch + w * a.stretch);
    local.block<3, 1>(0, 3) = (1.0 - w) * b.translate + w * a.translate;
    return local;
}

Eigen::Matrix4d blendLocalRate(const BlendRule& rule, double w, const Eigen::Matrix4d& ik, const Eigen::Matrix4d& fk,
                               double dw, const Eigen::Matrix4d& dIk, const Eigen::Matrix4d& dFk)
{
    const LocalParts a = localParts(ik), b = localParts(fk);
    const PartsRate da = partsRate(a, ik, dIk), db = partsRate(b, fk, dFk);
    const Eigen::Matrix3d rotation = blendRotation(rule, w, a.rotation, b.rotation);
    const Eigen::Matrix3d stretch = (1.0 - w) * b.stretch + w * a.stretch;
    const Eigen::Matrix3d stretchRate = (1.0 - w) * db.stretch + w * da.stretch + dw * (a.stretch - b.stretch);
    const Eigen::Vector3d turn = blendTurnRate(rule, w, a, b, dw, da, db);
    Eigen::Matrix4d rate = Eigen::Matrix4d::Zero();
    rate.block<3, 3>(0, 0) = rotation * (skew(turn) * stretch + stretchRate);
    rate.block<3, 1>(0, 3) =
        (1.0 - w) * dFk.block<3, 1>(0, 3) + w * dIk.block<3, 1>(0, 3) + dw * (a.translate - b.translate);
    return rate;
}

}  // namespace rig
