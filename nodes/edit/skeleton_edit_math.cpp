#include "nodes/edit/skeleton_edit_math.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/rotation_math.h"

namespace rig {
namespace {

// Relative size below which a vector counts as zero (the target on a pivot, an up along the aim).
constexpr double degenerate = 1e-9;
// |aim x direction| below which the two are parallel and the cross product gives no turn axis.
constexpr double parallel = 1e-12;

// The rigid motion turning by `rotation` about the point `pivot`.
Eigen::Matrix4d rotationAbout(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& pivot)
{
    Eigen::Matrix4d g = Eigen::Matrix4d::Identity();
    g.topLeftCorner<3, 3>() = rotation;
    g.topRightCorner<3, 1>() = pivot - rotation * pivot;
    return g;
}

// A unit vector orthogonal to the unit vector a: reference's part orthogonal to a, or when that vanishes
// the world axis least along a, made orthogonal.
Eigen::Vector3d orthogonalTo(const Eigen::Vector3d& a, const Eigen::Vector3d& reference)
{
    const Eigen::Vector3d v = reference - reference.dot(a) * a;
    if (v.norm() > degenerate * reference.norm()) return v.normalized();
    Eigen::Index axis = 0;
    a.cwiseAbs().minCoeff(&axis);
    return (Eigen::Vector3d::Unit(axis) - a[axis] * a).normalized();
}

// The roll about the unit aim a taking up's part orthogonal to a onto worldUp's part; 0 when either part
// vanishes (an up along the aim, the aim straight up).
double rollToward(const Eigen::Vector3d& a, const Eigen::Vector3d& up, const Eigen::Vector3d& worldUp)
{
    const Eigen::Vector3d u = up - up.dot(a) * a;
    const Eigen::Vector3d w = worldUp - worldUp.dot(a) * a;
    if (!(u.norm() > degenerate * up.norm()) || !(w.norm() > degenerate * worldUp.norm())) return 0.0;
    return std::atan2(a.dot(u.cross(w)), u.dot(w));
}

double shareOf(const LookAtSettings& s, std::size_t k)
{
    return s.share.empty() ? 1.0 / static_cast<double>(s.chain.size() - k) : s.share[k];
}

// The full edit (weight 1): joint k's turn, expressed in the input pose (about its input pivot, its axis
// pulled back through the turns of the joints before it), root first.
void fullTurns(const LookAtSettings& s, std::vector<Eigen::AngleAxisd>& turns)
{
    const std::size_t m = s.chain.size();
    const Eigen::Matrix3d lastInput = s.chain.back().topLeftCorner<3, 3>();
    turns.assign(m, Eigen::AngleAxisd(0.0, Eigen::Vector3d::UnitX()));
    Eigen::Matrix4d carried = Eigen::Matrix4d::Identity();  // the rigid motion of the turns so far
    for (std::size_t k = 0; k < m; ++k) {
        const Eigen::Matrix3d carriedAxes = carried.topLeftCorner<3, 3>();
        const Eigen::Vector3d pivot = (carried * s.chain[k].col(3)).head<3>();
        const Eigen::Matrix3d lastAxes = carriedAxes * lastInput;
        const Eigen::Vector3d aimWorld = lastAxes * s.aimAxis;
        const Eigen::Vector3d toTarget = s.target - pivot;
        // A target on the pivot (or a joint whose axes lost the aim: zero scale, NaN) gives no direction.
        if (!(toTarget.norm() > degenerate * std::max({1.0, s.target.norm(), pivot.norm()})) ||
            !(aimWorld.norm() > 0.0))
            continue;
        const Eigen::Vector3d a = aimWorld.normalized();
        const Eigen::Vector3d d = toTarget.normalized();
        const Eigen::Vector3d cross = a.cross(d);
        const double theta = std::atan2(cross.norm(), a.dot(d));
        const double limit = s.limit.empty() ? theta : s.limit[k];
        const double phi = std::min(shareOf(s, k) * theta, limit);
        Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
        if (phi > 0.0) {
            // Target straight behind: turn about the up (world up, or the last joint's up axis).
            const Eigen::Vector3d reference = s.worldUp ? *s.worldUp : Eigen::Vector3d(lastAxes * s.upAxis);
            const Eigen::Vector3d axis = cross.norm() > parallel ? cross.normalized() : orthogonalTo(a, reference);
            turn = Eigen::AngleAxisd(phi, axis).toRotationMatrix();
        }
        if (k + 1 == m && s.worldUp) {
            const Eigen::Vector3d aimed = turn * a;
            turn = Eigen::AngleAxisd(rollToward(aimed, turn * lastAxes * s.upAxis, *s.worldUp), aimed) * turn;
        }
        turns[k] = Eigen::AngleAxisd(Eigen::Matrix3d(carriedAxes.transpose() * turn * carriedAxes));
        carried = rotationAbout(turn, pivot) * carried;
    }
}

}  // namespace

Eigen::Matrix3d scaledRotation(const Eigen::Matrix3d& rotation, double fraction)
{
    const Eigen::AngleAxisd angleAxis(rotation);
    return Eigen::AngleAxisd(fraction * angleAxis.angle(), angleAxis.axis()).toRotationMatrix();
}

void lookAtChain(const LookAtSettings& s, LookAtResult& result)
{
    const std::size_t m = s.chain.size();
    result.world.assign(s.chain.begin(), s.chain.end());
    result.delta.assign(m, Eigen::Matrix4d::Identity());
    result.turn.assign(m, 0.0);
    result.fullTurn.clear();
    const double weight = s.weight > 0.0 ? std::min(s.weight, 1.0) : 0.0;
    if (m == 0 || weight == 0.0) return;
    // A target or an up that is not finite gives no direction. The unedited chain would pass for a target
    // straight ahead (what a rigInversion node downstream solves for, exit 0): NaN is taken through instead.
    if (!s.target.allFinite() || (s.worldUp && !s.worldUp->allFinite())) {
        const double nan = std::numeric_limits<double>::quiet_NaN();
        std::fill(result.world.begin(), result.world.end(), Eigen::Matrix4d::Constant(nan));
        std::fill(result.delta.begin(), result.delta.end(), Eigen::Matrix4d::Constant(nan));
        std::fill(result.turn.begin(), result.turn.end(), nan);
        return;
    }
    std::vector<Eigen::AngleAxisd>& turns = result.fullTurn;
    fullTurns(s, turns);
    // Weighted: each joint turns by weight times its angle about its own axis, re-composed root first, so
    // every later joint keeps its transform relative to the one before it.
    Eigen::Matrix4d composed = Eigen::Matrix4d::Identity();
    for (std::size_t k = 0; k < m; ++k) {
        const Eigen::Matrix3d turn = Eigen::AngleAxisd(weight * turns[k].angle(), turns[k].axis()).toRotationMatrix();
        composed = composed * rotationAbout(turn, s.chain[k].topRightCorner<3, 1>());
        result.delta[k] = composed;
        result.world[k] = composed * s.chain[k];
        result.turn[k] = weight * turns[k].angle();
    }
}

Eigen::Matrix4d offsetMatrix(const Eigen::Matrix4d& matrix, const Eigen::Vector3d& rotateRadians, RotateOrder order,
                             const Eigen::Vector3d& translate, OffsetSpace space, double weight)
{
    const double w = weight > 0.0 ? std::min(weight, 1.0) : 0.0;
    if (w == 0.0) return matrix;
    const Eigen::Matrix3d rotation = scaledRotation(eulerToMatrix(rotateRadians, order), w);
    if (space == OffsetSpace::local) {
        Eigen::Matrix4d offset = Eigen::Matrix4d::Identity();
        offset.topLeftCorner<3, 3>() = rotation;
        offset.topRightCorner<3, 1>() = w * translate;
        return matrix * offset;
    }
    Eigen::Matrix4d out = matrix;
    out.topLeftCorner<3, 3>() = rotation * matrix.topLeftCorner<3, 3>();
    out.topRightCorner<3, 1>() += w * translate;
    return out;
}

Eigen::Matrix4d blendMatrix(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b, double weight)
{
    const double w = weight > 0.0 ? std::min(weight, 1.0) : 0.0;
    if (w == 0.0) return a;
    if (w == 1.0) return b;
    Eigen::Matrix3d stretchA, stretchB;
    const Eigen::Quaterniond qa(polarRotation(a.topLeftCorner<3, 3>(), &stretchA));
    const Eigen::Quaterniond qb(polarRotation(b.topLeftCorner<3, 3>(), &stretchB));
    Eigen::Matrix4d out = Eigen::Matrix4d::Identity();
    out.topLeftCorner<3, 3>() = qa.slerp(w, qb).toRotationMatrix() * ((1.0 - w) * stretchA + w * stretchB);
    out.topRightCorner<3, 1>() = (1.0 - w) * a.topRightCorner<3, 1>() + w * b.topRightCorner<3, 1>();
    return out;
}

}  // namespace rig
