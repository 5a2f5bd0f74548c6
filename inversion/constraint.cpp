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

}  // namespace

std::string_view constraintKindName(ConstraintKind) { return "planarChain"; }

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
            base.pole >= 0 ? Eigen::Vector3d(poleWorld.block<3, 1>(0, 3)) : carried(base.restPole),
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

}  // namespace rig
