#include "inversion/solve/jacobian.h"

#include <type_traits>

#include <Eigen/Dense>

#include "inversion/model/constraint.h"
#include "inversion/solve/jacobian_math.h"

// The constraints' and blends' bases in a residual workspace (jacobian.h): each base's product evaluated from its
// inputs' products, and its velocity per column, dB B^-1, from its inputs' velocities (inversion/model/constraint.h
// differentiates each family), as twists where the normal equations fold through bases.

namespace rig {

using namespace jacobian_math;

ResidualWorkspace::Affine ResidualWorkspace::evaluateBase(std::size_t b)
{
    const auto& s = *structure_;
    const ResidualStructure::Base& base = s.bases_[b];
    const ConstraintBase& c = s.approximation_->constraints[static_cast<std::size_t>(base.constraint)];
    if (c.kind == ConstraintKind::blend) return evaluateBlend(b);
    if (c.kind == ConstraintKind::twistShare) {
        const auto motion = [&](int node) -> Eigen::Matrix4d {
            Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
            if (node >= 0) m.topRows<3>() = nodeMatrix_[static_cast<std::size_t>(node)];
            return m;
        };
        TwistLinearization& t = baseTwists_[b];
        t = linearizeTwist(c, motion(base.anchorNode), motion(base.goalNode) * base.secondRest,
                           motion(base.poleNode) * base.thirdRest);
        return t.base.topRows<3>();
    }
    if (c.kind == ConstraintKind::oriented) return evaluateOriented(b);
    // An input's product is its node's (the identity without one): points move with it.
    const auto moved = [&](int node, const Eigen::Vector3d& p) -> Eigen::Vector3d {
        if (node < 0) return p;
        const Affine& m = nodeMatrix_[static_cast<std::size_t>(node)];
        return m.leftCols<3>() * p + m.col(3);
    };
    ChainPoints& points = basePoints_[b];
    points.root = moved(base.anchorNode, c.root);
    points.goal = moved(base.goalNode, base.goalRest);
    // A pole carried by the pole output's rotation: its node's product turns the rest offset (a node's product is
    // its motion from rest).
    const auto turned = [&](const Eigen::Vector3d& offset) -> Eigen::Vector3d {
        if (base.poleNode < 0) return offset;
        return nodeMatrix_[static_cast<std::size_t>(base.poleNode)].leftCols<3>() * offset;
    };
    points.pole = c.pole >= 0 && c.poleTurns ? Eigen::Vector3d(points.root + turned(c.restPole - c.root))
                  : c.pole >= 0              ? moved(base.poleNode, base.poleRest)
                  : c.worldUp                ? Eigen::Vector3d(points.root + c.restPole - c.root)
                                             : moved(base.anchorNode, c.restPole);
    const Eigen::Matrix3d anchorLinear =
        base.anchorNode < 0 ? Eigen::Matrix3d(Eigen::Matrix3d::Identity())
                            : Eigen::Matrix3d(nodeMatrix_[static_cast<std::size_t>(base.anchorNode)].leftCols<3>());
    points.normal = anchorLinear * c.restNormal;
    // An ikSCsolver's plane turns with the goal's rotation (its node's product, a motion from rest).
    if (c.minimalTurn) {
        Eigen::Matrix3d turn = anchorLinear;
        if (c.goalTurns)
            turn = base.goalNode < 0
                       ? Eigen::Matrix3d(Eigen::Matrix3d::Identity())
                       : Eigen::Matrix3d(nodeMatrix_[static_cast<std::size_t>(base.goalNode)].leftCols<3>());
        minimalTurnNormal(c, turn, points);
    }
    const Eigen::Matrix4d chain = constraintBase(c, points);
    if (c.orient < 0) return chain.topRows<3>();
    Eigen::Matrix4d orient = Eigen::Matrix4d::Identity();
    if (base.orientNode >= 0) orient.topRows<3>() = nodeMatrix_[static_cast<std::size_t>(base.orientNode)];
    baseCentres_[b] = chain.block<3, 3>(0, 0) * c.origin + chain.block<3, 1>(0, 3);
    return orientedBase(c, chain, orient).topRows<3>();
}

ResidualWorkspace::Affine ResidualWorkspace::evaluateOriented(std::size_t b)
{
    // B = [Q_o | M_a p0 - Q_o p0] from the anchor's and the orient output's products (their motions from rest).
    const ResidualStructure::Base& base = structure_->bases_[b];
    const ConstraintBase& c = structure_->approximation_->constraints[static_cast<std::size_t>(base.constraint)];
    const auto motion = [&](int node) -> Eigen::Matrix4d {
        Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
        if (node >= 0) m.topRows<3>() = nodeMatrix_[static_cast<std::size_t>(node)];
        return m;
    };
    const Eigen::Matrix4d anchor = motion(base.anchorNode);
    baseCentres_[b] = anchor.block<3, 3>(0, 0) * c.origin + anchor.block<3, 1>(0, 3);
    return orientedBase(c, anchor, motion(base.orientNode)).topRows<3>();
}

ResidualWorkspace::Affine ResidualWorkspace::evaluateBlend(std::size_t b)
{
    // B = W_a blend(w, W_ikp^-1 W_ik, W_fkp^-1 W_fk) R^-1 (Approximation::evaluate), each input's world its node's
    // product times its rest.
    const ResidualStructure::Base& base = structure_->bases_[b];
    BlendState& blend = blends_[b];
    for (std::size_t i = 0; i < blend.worlds.size(); ++i) {
        blend.worlds[i] = base.frameRest[i];
        if (const int node = base.frameNodes[i]; node >= 0)
            blend.worlds[i].topRows<3>() =
                compose(nodeMatrix_[static_cast<std::size_t>(node)], base.frameRest[i].topRows<3>());
    }
    const BlendRule& rule = structure_->approximation_->constraints[static_cast<std::size_t>(base.constraint)].blend;
    blend.ik = blend.worlds[3].inverse() * blend.worlds[1];
    blend.fk = blend.worlds[4].inverse() * blend.worlds[2];
    blend.moved = blend.worlds[0] * blendLocal(rule, blend.weight, blend.ik, blend.fk);
    return (blend.moved * base.restInverse).topRows<3>();
}

ResidualWorkspace::Affine ResidualWorkspace::blendVelocity(std::size_t b, const std::array<Affine, 5>& x,
                                                           double dw) const
{
    // dB B^-1 = Xi_a + W_a dL (W_a L)^-1, a branch's local moving at d(W_p^-1 W) = W_p^-1 (Xi - Xi_p) W.
    const ResidualStructure::Base& base = structure_->bases_[b];
    const BlendState& blend = blends_[b];
    const auto full = [](const Affine& v) {
        Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
        m.topRows<3>() = v;
        return m;
    };
    const auto localRate = [&](std::size_t branch, std::size_t parent) -> Eigen::Matrix4d {
        return blend.worlds[parent].inverse() * (full(x[branch]) - full(x[parent])) * blend.worlds[branch];
    };
    const BlendRule& rule = structure_->approximation_->constraints[static_cast<std::size_t>(base.constraint)].blend;
    const Eigen::Matrix4d rate =
        blendLocalRate(rule, blend.weight, blend.ik, blend.fk, dw, localRate(1, 3), localRate(2, 4));
    return x[0] + (blend.worlds[0] * rate * blend.moved.inverse()).topRows<3>();
}

namespace {

// An input's velocity acting on a point and on a direction, and as the 3x4 rate blends and twist shares take: the
// velocity dM M^-1 of any operators (an affine rate [L | t]), or the twist (omega, v) of rigid ones (the twist form).
Eigen::Vector3d pointRate(const Affine& x, const Eigen::Vector3d& p) { return x.leftCols<3>() * p + x.col(3); }
Eigen::Vector3d pointRate(const Vector6d& x, const Eigen::Vector3d& p) { return x.head<3>().cross(p) + x.tail<3>(); }
Eigen::Vector3d directionRate(const Affine& x, const Eigen::Vector3d& d) { return x.leftCols<3>() * d; }
Eigen::Vector3d directionRate(const Vector6d& x, const Eigen::Vector3d& d) { return x.head<3>().cross(d); }
Vector6d twistOf(const Affine& x)
{
    Vector6d t;
    t << 0.5 * (x(2, 1) - x(1, 2)), 0.5 * (x(0, 2) - x(2, 0)), 0.5 * (x(1, 0) - x(0, 1)), x.col(3);
    return t;
}
const Vector6d& twistOf(const Vector6d& x) { return x; }
Affine affineOf(const Vector6d& x)
{
    Affine a;
    a.leftCols<3>() = skew(x.head<3>());
    a.col(3) = x.tail<3>();
    return a;
}
const Affine& affineOf(const Affine& x) { return x; }
// A base's velocity (rigid, so a twist) kept as the velocities it is computed from.
template <class Velocity>
Velocity kept(const Vector6d& t)
{
    if constexpr (std::is_same_v<Velocity, Vector6d>) return t;
    else return affineOf(t);
}
template <class Velocity>
Velocity kept(const Affine& a)
{
    if constexpr (std::is_same_v<Velocity, Affine>) return a;
    else return twistOf(a);
}

// A planar chain's twist (with its orient output's where it has one) for its inputs moving at x.
template <class Velocity>
Vector6d chainVelocity(const ConstraintBase& c, const ChainPoints& points, const BaseLinearization& at,
                       const std::array<Velocity, 5>& x, const Eigen::Vector3d& centre)
{
    // A world up moves with the root only; a fixed pole with the anchor; a pole the pole output's rotation carries
    // with the root, turning as that output does.
    const Eigen::Vector3d poleRate =
        c.pole >= 0 && c.poleTurns
            ? Eigen::Vector3d(pointRate(x[0], points.root) + directionRate(x[2], points.pole - points.root))
        : c.pole >= 0 ? pointRate(x[2], points.pole)
        : c.worldUp   ? pointRate(x[0], points.root)
                      : pointRate(x[0], points.pole);
    ChainPoints rates{pointRate(x[0], points.root), pointRate(x[1], points.goal), poleRate,
                      directionRate(x[0], points.normal)};
    if (c.minimalTurn) {
        const Velocity& turn = c.goalTurns ? x[1] : x[0];
        rates.normal =
            minimalTurnRate(at, points, rates, directionRate(turn, points.carried), directionRate(turn, points.line));
    }
    const Vector6d velocity = baseVelocity(at, rates);
    if (c.orient < 0) return velocity;
    return orientedVelocity(velocity.head<3>().cross(centre) + velocity.tail<3>(), twistOf(x[3]).template head<3>(),
                            centre);
}

}  // namespace

template <class Velocity>
void ResidualWorkspace::baseVelocities(const std::vector<Velocity>& nodeVelocity, std::vector<Velocity>& baseVelocity)
{
    // Per base and column: each input's velocity (the sum of what moves it), then the base's.
    const auto& s = *structure_;
    for (std::size_t b = 0; b < s.bases_.size(); ++b) {
        const ResidualStructure::Base& base = s.bases_[b];
        const ConstraintBase& c = s.approximation_->constraints[static_cast<std::size_t>(base.constraint)];
        const bool chain = c.kind != ConstraintKind::twistShare && c.kind != ConstraintKind::blend &&
                           c.kind != ConstraintKind::oriented;
        const BaseLinearization at = chain ? linearizeBase(c, basePoints_[b]) : BaseLinearization{};
        for (std::size_t j = 0; j < base.columns.size(); ++j) {
            std::array<Velocity, 5> x;
            x.fill(Velocity::Zero());
            double dw = 0.0;
            for (int t = base.termBegin[j]; t < base.termBegin[j + 1]; ++t) {
                const ResidualStructure::InputTerm& term = s.inputTerms_[static_cast<std::size_t>(t)];
                if (term.input == ResidualStructure::blendWeightInput) {
                    dw = 1.0;
                    continue;
                }
                x[static_cast<std::size_t>(term.input)] +=
                    term.node >= 0 ? nodeVelocity[static_cast<std::size_t>(term.node)]
                                   : baseVelocity[static_cast<std::size_t>(term.baseVelocity)];
            }
            // An oriented base's origin moves with the anchor, its rotation as the orient output turns.
            Velocity& out = baseVelocity[static_cast<std::size_t>(base.velocityOffset) + j];
            if (c.kind == ConstraintKind::blend)
                out = kept<Velocity>(blendVelocity(
                    b, {affineOf(x[0]), affineOf(x[1]), affineOf(x[2]), affineOf(x[3]), affineOf(x[4])}, dw));
            else if (c.kind == ConstraintKind::twistShare)
                out = kept<Velocity>(twistVelocity(baseTwists_[b], affineOf(x[0]), affineOf(x[1]), affineOf(x[2])));
            else if (c.kind == ConstraintKind::oriented)
                out = kept<Velocity>(orientedVelocity(pointRate(x[0], baseCentres_[b]),
                                                      twistOf(x[3]).template head<3>(), baseCentres_[b]));
            else out = kept<Velocity>(chainVelocity(c, basePoints_[b], at, x, baseCentres_[b]));
        }
    }
}

void ResidualWorkspace::baseVelocities() { baseVelocities(velocity_, baseVelocity_); }

void ResidualWorkspace::baseTwistVelocities() { baseVelocities(twist_, baseTwist_); }

}  // namespace rig
