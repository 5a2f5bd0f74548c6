#include "inversion/solve/jacobian.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

#include <fmt/format.h>
#include <oneapi/tbb/parallel_for.h>
#include <Eigen/Dense>

#include "core/error.h"
#include "core/prefetch.h"
#include "core/rotation_math.h"
#include "inversion/model/operators.h"
#include "inversion/solve/jacobian_math.h"

// The residual workspace (jacobian.h): targets prepared, the outputs' products evaluated up the prefix tree, the
// operators' velocities and the Jacobian from them (or from prefix and suffix products, or finite differences), the
// normal equations where J is formed. The structure is built in residual_structure.cpp, the constraints' and blends'
// bases in base_velocity.cpp, the twist-form normal equations in twist_fold.cpp.

namespace rig {

using namespace jacobian_math;

namespace {

// Below this determinant a linear part is taken as singular: its inverse would be meaningless.
constexpr double singularDeterminant = 1e-12;

// The step of the whole-evaluation differences that stand in for the suffix products where a product begins with
// a base (ResidualWorkspace::jacobianFromSuffixes).
constexpr double wholeDifferenceStep = 1e-6;

// The same value to the bit (a signed zero is not the other zero), and not NaN: what a held matrix was made at.
bool sameBits(double a, double b)
{
    return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b) && a == a;
}

}  // namespace

bool prepareTarget(const JointTarget& target, double rotationScaleCm, PreparedTarget& prepared)
{
    if (!target.world.topRows<3>().allFinite()) return false;
    if (!std::isfinite(target.positionWeight) || !std::isfinite(target.rotationWeight)) return false;
    if (target.positionWeight < 0 || target.rotationWeight < 0) return false;
    const Eigen::Matrix3d a = target.world.block<3, 3>(0, 0);
    if (nearlyOrthonormal(a)) {
        prepared.rotation = orthonormalOrientation(a);
    } else {
        if (nearlySingular(Eigen::JacobiSVD<Eigen::Matrix3d>(a).singularValues())) return false;
        prepared.rotation = polarRotation(a);
    }
    prepared.position = target.world.block<3, 1>(0, 3);
    prepared.positionWeight = target.positionWeight;
    prepared.rotationWeight = target.rotationWeight * rotationScaleCm;
    return true;
}

Eigen::Matrix<double, 6, 1> targetResidual(const Eigen::Matrix4d& world, const PreparedTarget& target)
{
    return residual6(world, target);
}

TargetError targetError(const Eigen::Matrix4d& world, const PreparedTarget& target)
{
    const Eigen::Matrix3d a = world.block<3, 3>(0, 0);
    const Eigen::Matrix3d q = nearlyOrthonormal(a) ? orthonormalOrientation(a) : polarRotation(a);
    // stableNorm: a target 1e160 cm away is 1e160 cm away, not an overflow to infinity.
    return {(world.block<3, 1>(0, 3) - target.position).stableNorm(),
            rotationVector(target.rotation.transpose() * q).norm()};
}

// --- ResidualWorkspace ---

ResidualWorkspace::ResidualWorkspace(const ResidualStructure& structure) : structure_(&structure)
{
    const auto& s = structure;
    constants_.assign(static_cast<std::size_t>(s.constantCount_), Eigen::Matrix4d::Identity());
    identity_.assign(static_cast<std::size_t>(s.constantCount_), 1);
    constantOffset_.resize(s.chains_.size());
    int offset = 0;
    for (std::size_t o = 0; o < s.chains_.size(); ++o) {
        constantOffset_[o] = offset;
        offset += static_cast<int>(s.chains_[o].gaps.size());
    }
    targets_.resize(s.outputs_.size());
    slotMatrix_.assign(s.slots_.size(), Eigen::Matrix4d::Identity());
    slotDerivative_.assign(s.slots_.size(), Eigen::Matrix4d::Zero());
    worlds_.assign(s.outputs_.size(), Eigen::Matrix4d::Identity());
    prefix_.assign(static_cast<std::size_t>(s.maxVars_ + 1), Eigen::Matrix4d::Identity());
    suffix_.assign(static_cast<std::size_t>(s.maxVars_ + 1), Eigen::Matrix4d::Identity());
    // NaN: no value yet, so that the first holdParameters makes every held matrix.
    held_.assign(s.heldParameters_.size(), std::numeric_limits<double>::quiet_NaN());
    heldValue_.assign(s.nodes_.size(), std::numeric_limits<double>::quiet_NaN());
    heldMoved_.assign(s.nodes_.size(), 0);
    heldMatrix_.assign(s.nodes_.size(), Affine::Identity());
    nodeMatrix_.assign(s.nodes_.size(), Affine::Identity());
    velocity_.assign(s.nodes_.size(), Affine::Zero());
    baseVelocity_.assign(static_cast<std::size_t>(s.baseVelocities_), Affine::Zero());
    basePoints_.resize(s.bases_.size());
    baseCentres_.assign(s.bases_.size(), Eigen::Vector3d::Zero());
    baseTwists_.resize(s.bases_.size());
    blends_.resize(s.bases_.size());
    slotOffset_.assign(s.slots_.size(), 0.0);
    quaternion_.assign(s.outputs_.size(), Eigen::Quaterniond::Identity());
    twist_.assign(s.nodes_.size(), Vector6d::Zero());
    load_.assign(s.nodes_.size(), Vector6d::Zero());
    weight_.assign(s.nodes_.size(), TwistWeight{Eigen::Matrix3d::Zero(), Eigen::Vector3d::Zero(), 0.0});
    weighted_.assign(s.nodes_.size(), Vector6d::Zero());
    if (!s.jointTargetsOnly_) fullWeight_.assign(s.nodes_.size(), Matrix6::Zero());
    baseTwist_.assign(static_cast<std::size_t>(s.baseVelocities_), Vector6d::Zero());
    baseWeighted_.assign(baseTwist_.size(), Vector6d::Zero());
    baseLoad_.assign(s.bases_.size(), Vector6d::Zero());
    baseWeight_.assign(s.bases_.size(), TwistWeight{Eigen::Matrix3d::Zero(), Eigen::Vector3d::Zero(), 0.0});
    if (!s.jointTargetsOnly_) baseFullWeight_.assign(s.bases_.size(), Matrix6::Zero());
    baseFresh_.assign(s.bases_.size(), 0);
    useLayout({});
    fresh_.assign(s.nodes_.size(), 0);
}

void ResidualWorkspace::holdParameters(std::span<const double> values)
{
    const auto& s = *structure_;
    const Approximation& approx = *s.approximation_;
    if (values.size() != approx.parameters.size())
        throw internalError("ResidualWorkspace::holdParameters: one value per modelled parameter");
    // Only the parameters this structure holds: a crowd's blocks must not each copy every value.
    bool heldChanged = false;
    for (std::size_t i = 0; i < s.heldParameters_.size(); ++i) {
        const double v = values[static_cast<std::size_t>(s.heldParameters_[i])];
        heldChanged = heldChanged || !sameBits(v, held_[i]);
        held_[i] = v;
    }
    for (std::size_t b = 0; b < s.bases_.size(); ++b)
        if (const ConstraintBase& c = approx.constraints[static_cast<std::size_t>(s.bases_[b].constraint)];
            c.kind == ConstraintKind::blend && s.bases_[b].weightColumn < 0)
            blends_[b].weight = values[static_cast<std::size_t>(c.weight)];
    chainsHeld_ = chainsHeld_ && !heldChanged;
    // A held node's matrix, and a constant node's product, are made again only where its value (or a constant
    // ancestor's) changed since the last call: the initial guess holds the same values for every start of a step,
    // and a sampled operator's matrix costs a curve's evaluation.
    for (std::size_t n = 0; n < s.nodes_.size(); ++n) {
        const auto& node = s.nodes_[n];
        if (node.slot >= 0 || node.base >= 0) continue;
        const ModelledParameter& m = approx.parameters[static_cast<std::size_t>(node.parameter)];
        const double v = values[static_cast<std::size_t>(node.parameter)];
        const bool same = sameBits(v, heldValue_[n]);
        if (!same) {
            heldMatrix_[n] = m.operators[static_cast<std::size_t>(node.op)].affineRows(v - m.parameter.defaultValue);
            heldValue_[n] = v;
        }
        const bool parentMoved = node.parent >= 0 && heldMoved_[static_cast<std::size_t>(node.parent)];
        heldMoved_[n] = !same || parentMoved;
        if (node.constant && heldMoved_[n])
            nodeMatrix_[n] = node.parent < 0
                                 ? heldMatrix_[n]
                                 : compose(nodeMatrix_[static_cast<std::size_t>(node.parent)], heldMatrix_[n]);
    }
}

void ResidualWorkspace::holdChains()
{
    if (chainsHeld_) return;
    const auto& s = *structure_;
    const Approximation& approx = *s.approximation_;
    for (std::size_t o = 0; o < s.chains_.size(); ++o) {
        const auto& gaps = s.chains_[o].gaps;
        for (std::size_t g = 0; g < gaps.size(); ++g) {
            const std::size_t index = static_cast<std::size_t>(constantOffset_[o]) + g;
            Eigen::Matrix4d c = Eigen::Matrix4d::Identity();
            for (const auto& link : gaps[g]) {
                const ModelledParameter& m = approx.parameters[static_cast<std::size_t>(link.parameter)];
                c = c * m.operators[static_cast<std::size_t>(link.op)].matrix(
                            held_[static_cast<std::size_t>(link.held)] - m.parameter.defaultValue);
            }
            const bool last = g + 1 == gaps.size();
            if (last) c = c * approx.outputs[static_cast<std::size_t>(s.outputs_[o])].rest;
            constants_[index] = c;
            identity_[index] = !last && gaps[g].empty();
        }
    }
    chainsHeld_ = true;
}

void ResidualWorkspace::setTargets(std::span<const PreparedTarget> targets)
{
    const auto& outputs = structure_->outputs_;
    for (std::size_t o = 0; o < outputs.size(); ++o) targets_[o] = targets[static_cast<std::size_t>(outputs[o])];
}

void ResidualWorkspace::setTarget(int position, const PreparedTarget& target)
{
    targets_[static_cast<std::size_t>(position)] = target;
}

void ResidualWorkspace::evaluateSlots(std::span<const double> x, bool derivatives)
{
    const auto& s = *structure_;
    for (std::size_t i = 0; i < s.slots_.size(); ++i) {
        const auto& slot = s.slots_[i];
        const Operator& op = *slot.operation;
        const double a = x[static_cast<std::size_t>(slot.column)] - slot.defaultValue;
        slotOffset_[i] = a;
        slotMatrix_[i].topRows<3>() = op.affineRows(a);  // the last row stays 0 0 0 1
        if (!derivatives) continue;
        // The two commonest kinds from the matrix just made (Operator::derivative would make the
        // rotation again): dR/da = m'(a) [n]x R about the pivot.
        if (op.kind == OperatorKind::rotation) {
            Eigen::Matrix4d& d = slotDerivative_[i];
            d.setZero();
            d.block<3, 3>(0, 0) = op.magnitudeDerivative(a) * skew(op.axis) * slotMatrix_[i].block<3, 3>(0, 0);
            d.block<3, 1>(0, 3) = -d.block<3, 3>(0, 0) * op.pivot;
        } else if (op.kind == OperatorKind::translation) {
            Eigen::Matrix4d& d = slotDerivative_[i];
            d.setZero();
            d.block<3, 1>(0, 3) = op.magnitudeDerivative(a) * op.axis;
        } else {
            slotDerivative_[i] = op.derivative(a);
        }
    }
    for (std::size_t b = 0; b < s.bases_.size(); ++b)
        if (const int c = s.bases_[b].weightColumn; c >= 0) blends_[b].weight = x[static_cast<std::size_t>(c)];
}

Eigen::Matrix4d ResidualWorkspace::chainWorld(int o, int perturbed, double value) const
{
    const auto& s = *structure_;
    const auto& chain = s.chains_[static_cast<std::size_t>(o)];
    const std::size_t base = static_cast<std::size_t>(constantOffset_[static_cast<std::size_t>(o)]);
    Eigen::Matrix4d w = constants_[base];
    for (std::size_t j = 0; j < chain.varSlots.size(); ++j) {
        const int slot = chain.varSlots[j];
        if (chain.varColumns[j] == perturbed) {
            const auto& sl = s.slots_[static_cast<std::size_t>(slot)];
            const ModelledParameter& m = s.approximation_->parameters[static_cast<std::size_t>(sl.parameter)];
            w = w * m.operators[static_cast<std::size_t>(sl.op)].matrix(value - m.parameter.defaultValue);
        } else {
            w = w * slotMatrix_[static_cast<std::size_t>(slot)];
        }
        if (!identity_[base + j + 1]) w = w * constants_[base + j + 1];
    }
    return w;
}

void ResidualWorkspace::evaluateTree()
{
    const auto& s = *structure_;
    for (std::size_t n = 0; n < s.nodes_.size(); ++n) {
        const auto& node = s.nodes_[n];
        if (node.constant) continue;
        Affine& product = nodeMatrix_[n];
        if (node.base >= 0) {
            product = evaluateBase(static_cast<std::size_t>(node.base));
        } else if (node.slot >= 0) {
            const auto item = slotMatrix_[static_cast<std::size_t>(node.slot)].topRows<3>();
            if (node.parent < 0) product = item;
            else product = compose(nodeMatrix_[static_cast<std::size_t>(node.parent)], item);
        } else {
            if (node.parent < 0) product = heldMatrix_[n];
            else product = compose(nodeMatrix_[static_cast<std::size_t>(node.parent)], heldMatrix_[n]);
        }
    }
    for (std::size_t o = 0; o < worlds_.size(); ++o) {
        const Eigen::Matrix4d& rest = s.approximation_->outputs[static_cast<std::size_t>(s.outputs_[o])].rest;
        const int node = s.outputNode_[o];
        if (node < 0) {
            worlds_[o] = rest;
        } else {
            worlds_[o].topRows<3>() = compose(nodeMatrix_[static_cast<std::size_t>(node)], rest.topRows<3>());
            worlds_[o].row(3) = rest.row(3);
        }
    }
}

void ResidualWorkspace::residualRows(Eigen::Ref<Eigen::VectorXd> r)
{
    const auto& s = *structure_;
    for (std::size_t o = 0; o < worlds_.size(); ++o) {
        if (!s.jointTarget(o)) {
            TermRows rows;
            s.terms_[o]->residual(worlds_[o], targets_[o], rows);
            r.segment(s.rowOffset_[o], rows.size()) = rows;
            continue;
        }
        auto rows = r.segment<jointTargetRows>(s.rowOffset_[o]);
        if (!s.outputRigid_[o]) {
            rows = residual6(worlds_[o], targets_[o]);
            continue;
        }
        // A rigid world is its own rotation (or a reflection's negation): its quaternion is kept for the normal
        // equations' rows.
        const PreparedTarget& t = targets_[o];
        rows.head<3>() = t.positionWeight * (worlds_[o].block<3, 1>(0, 3) - t.position);
        Eigen::Quaterniond& e = quaternion_[o];
        e = Eigen::Quaterniond(t.rotation.transpose() * orthonormalOrientation(worlds_[o].block<3, 3>(0, 0)));
        if (e.w() < 0) e.coeffs() = -e.coeffs();
        rows.tail<3>() = (2.0 * t.rotationWeight) * e.vec();
    }
}

TargetError ResidualWorkspace::error(int o) const
{
    const std::size_t i = static_cast<std::size_t>(o);
    if (!structure_->jointTarget(i)) return structure_->terms_[i]->error(worlds_[i], targets_[i]);
    if (!structure_->outputRigid_[i]) return targetError(worlds_[i], targets_[i]);
    // residualRows' quaternion of Q_target^T Q (w >= 0): its angle, as targetError's AngleAxis takes it.
    const Eigen::Quaterniond& e = quaternion_[i];
    return {(worlds_[i].block<3, 1>(0, 3) - targets_[i].position).norm(), 2.0 * std::atan2(e.vec().norm(), e.w())};
}

void ResidualWorkspace::residuals(std::span<const double> x, Eigen::Ref<Eigen::VectorXd> r)
{
    evaluateSlots(x, false);
    evaluateTree();
    residualRows(r);
}

bool ResidualWorkspace::velocities()
{
    const auto& s = *structure_;
    // Xi = P X P^-1 with X = dM M^-1, for 4x4s whose last rows are 0 0 0 1 (P, M) or 0 (dM, X, Xi).
    for (std::size_t n = 0; n < s.nodes_.size(); ++n) {
        const auto& node = s.nodes_[n];
        if (node.slot < 0) continue;
        const auto& slot = s.slots_[static_cast<std::size_t>(node.slot)];
        const Affine m = slotMatrix_[static_cast<std::size_t>(node.slot)].topRows<3>();
        const Affine d = slotDerivative_[static_cast<std::size_t>(node.slot)].topRows<3>();
        Eigen::Matrix3d mInverse;
        if (slot.rigid) {
            mInverse = m.leftCols<3>().transpose();
        } else {
            const double det = m.leftCols<3>().determinant();
            if (!(std::abs(det) > singularDeterminant)) return false;
            mInverse = m.leftCols<3>().inverse();
        }
        const Eigen::Matrix3d xl = d.leftCols<3>() * mInverse;
        const Eigen::Vector3d xt = d.col(3) - xl * m.col(3);
        Affine& xi = velocity_[n];
        if (node.parent < 0) {
            xi.leftCols<3>() = xl;
            xi.col(3) = xt;
            continue;
        }
        const Affine& p = nodeMatrix_[static_cast<std::size_t>(node.parent)];
        Eigen::Matrix3d pInverse;
        if (s.nodes_[static_cast<std::size_t>(node.parent)].rigid) {
            pInverse = p.leftCols<3>().transpose();
        } else {
            const double det = p.leftCols<3>().determinant();
            if (!(std::abs(det) > singularDeterminant)) return false;
            pInverse = p.leftCols<3>().inverse();
        }
        xi.leftCols<3>() = p.leftCols<3>() * xl * pInverse;
        xi.col(3) = p.leftCols<3>() * xt - xi.leftCols<3>() * p.col(3);
    }
    baseVelocities();
    return true;
}

void ResidualWorkspace::treeJacobian(Eigen::Ref<Eigen::MatrixXd> jacobian)
{
    const auto& s = *structure_;
    for (std::size_t o = 0; o < worlds_.size(); ++o) {
        const auto& vars = s.outputVars_[o];
        if (vars.empty() && s.outputBase_[o] < 0) continue;
        if (!s.jointTarget(o)) {
            termTreeJacobian(o, jacobian);
            continue;
        }
        const PreparedTarget& t = targets_[o];
        const Eigen::Matrix3d a = worlds_[o].block<3, 3>(0, 0);
        const Eigen::Vector3d position = worlds_[o].block<3, 1>(0, 3);
        // Rotation rows: with A = Q S (polar), dQ = Q [w]x where (tr(S) I - S) w = vee(Q^T dA - dA^T Q);
        // then d(2 vec q) = (w_q I + [v_q]x) w (halfAngle). For a rotation A, w = Q^T (the skew part of Xi's 3x3).
        const bool rigid = s.outputRigid_[o] || nearlyOrthonormal(a);
        Eigen::Matrix3d q, kInverse = Eigen::Matrix3d::Zero();  // kInverse: read only when not rigid
        if (rigid) {
            q = orthonormalOrientation(a);  // omega turns -A as it turns A
        } else {
            Eigen::Matrix3d sym;
            q = polarRotation(a, &sym);
            kInverse = (sym.trace() * Eigen::Matrix3d::Identity() - sym).inverse();
        }
        Eigen::Matrix3d rotationRows = t.rotationWeight * halfAngle(q, t).rows;
        if (!rigid) rotationRows = rotationRows * kInverse;
        const Eigen::Index row = s.rowOffset_[o];
        forEachVelocity(o, [&](const Affine& xi, Eigen::Index column) {
            // += : a control spread over relative outputs has one node per output on the path.
            jacobian.block<3, 1>(row, column) += t.positionWeight * (xi.leftCols<3>() * position + xi.col(3));
            if (rigid) {
                const Eigen::Vector3d omega(0.5 * (xi(2, 1) - xi(1, 2)), 0.5 * (xi(0, 2) - xi(2, 0)),
                                            0.5 * (xi(1, 0) - xi(0, 1)));
                jacobian.block<3, 1>(row + 3, column) += rotationRows * (q.transpose() * omega);
            } else {
                const Eigen::Matrix3d x = q.transpose() * (xi.leftCols<3>() * a);
                const Eigen::Vector3d skewPart(x(2, 1) - x(1, 2), x(0, 2) - x(2, 0), x(1, 0) - x(0, 1));
                jacobian.block<3, 1>(row + 3, column) += rotationRows * skewPart;
            }
        });
    }
}

template <class Body>
void ResidualWorkspace::forEachVelocity(std::size_t o, const Body& body) const
{
    // The unknown nodes on the output's product, then the columns that move the base it begins with.
    const auto& s = *structure_;
    for (const int n : s.outputVars_[o])
        body(velocity_[static_cast<std::size_t>(n)],
             s.slots_[static_cast<std::size_t>(s.nodes_[static_cast<std::size_t>(n)].slot)].column);
    if (s.outputBase_[o] < 0) return;
    const ResidualStructure::Base& base = s.bases_[static_cast<std::size_t>(s.outputBase_[o])];
    for (std::size_t j = 0; j < base.columns.size(); ++j)
        body(baseVelocity_[static_cast<std::size_t>(base.velocityOffset) + j], base.columns[j]);
}

void ResidualWorkspace::clearTreeEntries(Eigen::Ref<Eigen::MatrixXd> jacobian)
{
    const bool inPlace = inPlace_ && jacobian.data() == inPlace_->data() && jacobian.rows() == inPlace_->rows() &&
                         jacobian.cols() == inPlace_->cols() && jacobian.outerStride() == inPlace_->outerStride();
    if (!inPlace || !treeFormed_) {
        jacobian.setZero();
        treeFormed_ = inPlace;
        return;
    }
    const auto& s = *structure_;
    for (std::size_t o = 0; o < worlds_.size(); ++o) {
        const Eigen::Index rows = s.jointTarget(o) ? jointTargetRows : s.terms_[o]->rows();
        forEachVelocity(
            o, [&](const Affine&, Eigen::Index column) { jacobian.block(s.rowOffset_[o], column, rows, 1).setZero(); });
    }
}

void ResidualWorkspace::termTreeJacobian(std::size_t o, Eigen::Ref<Eigen::MatrixXd> jacobian)
{
    // A velocity Xi moves the world by dW = Xi W: a twist when rigid, any change of a stretch's.
    const auto& s = *structure_;
    const Eigen::Matrix4d& world = worlds_[o];
    TermRows rows;
    forEachVelocity(o, [&](const Affine& xi, Eigen::Index column) {
        Affine change;
        change.leftCols<3>().noalias() = xi.leftCols<3>() * world.block<3, 3>(0, 0);
        change.col(3) = xi.leftCols<3>() * world.block<3, 1>(0, 3) + xi.col(3);
        s.terms_[o]->change(world, targets_[o], change, rows);
        jacobian.block(s.rowOffset_[o], column, rows.size(), 1) += rows;
    });
}

void ResidualWorkspace::prefetch() const
{
    const auto& s = *structure_;
    rig::prefetch(s.slots_);
    rig::prefetch(s.nodes_);
    rig::prefetch(s.unknownNodes_);
    rig::prefetch(s.unknownUp_);
    rig::prefetch(s.unknownColumn_);
    rig::prefetch(s.outputDeepest_);
    rig::prefetch(s.outputNode_);
    for (const auto& slot : s.slots_) prefetchBytes(slot.operation, sizeof(Operator));
    rig::prefetch(s.outputs_);
    rig::prefetch(s.outputRigid_);
    rig::prefetch(slotMatrix_);
    rig::prefetch(slotOffset_);
    rig::prefetch(nodeMatrix_);
    rig::prefetch(twist_);
    rig::prefetch(load_);
    rig::prefetch(weight_);
    rig::prefetch(weighted_);
    rig::prefetch(fresh_);
    rig::prefetch(worlds_);
    rig::prefetch(quaternion_);
    rig::prefetch(targets_);
    rig::prefetch(pairBegin_);
    rig::prefetch(pairNode_);
    rig::prefetch(pairTarget_);
    rig::prefetch(pairFactor_);
}

void ResidualWorkspace::outputJacobian(int o, Eigen::Ref<Eigen::MatrixXd> jacobian)
{
    const auto& s = *structure_;
    const auto& chain = s.chains_[static_cast<std::size_t>(o)];
    const std::size_t base = static_cast<std::size_t>(constantOffset_[static_cast<std::size_t>(o)]);
    const std::size_t v = chain.varSlots.size();
    const PreparedTarget& t = targets_[static_cast<std::size_t>(o)];

    // prefix_[j] = C_0 V_0 C_1 ... V_{j-1} C_j: everything before V_j; prefix_[v] is the world.
    prefix_[0] = constants_[base];
    for (std::size_t j = 0; j < v; ++j) {
        prefix_[j + 1].noalias() = prefix_[j] * slotMatrix_[static_cast<std::size_t>(chain.varSlots[j])];
        if (!identity_[base + j + 1]) prefix_[j + 1] = prefix_[j + 1] * constants_[base + j + 1];
    }
    const Eigen::Matrix4d& world = prefix_[v];
    worlds_[static_cast<std::size_t>(o)] = world;
    const Eigen::Index row = s.rowOffset_[static_cast<std::size_t>(o)];
    if (v == 0) return;

    // suffix_[j] = C_{j+1} V_{j+1} ... V_{v-1} C_v: everything after V_j.
    suffix_[v - 1] = constants_[base + v];
    for (std::size_t j = v - 1; j-- > 0;) {
        suffix_[j].noalias() = slotMatrix_[static_cast<std::size_t>(chain.varSlots[j + 1])] * suffix_[j + 1];
        if (!identity_[base + j + 1]) suffix_[j] = constants_[base + j + 1] * suffix_[j];
    }
    // Only the top three rows of dW = prefix_j V_j' suffix_j are needed.
    const auto change = [&](std::size_t j) -> Eigen::Matrix<double, 3, 4> {
        const Eigen::Matrix<double, 3, 4> left =
            prefix_[j].topRows<3>() * slotDerivative_[static_cast<std::size_t>(chain.varSlots[j])];
        return left * suffix_[j];
    };
    if (!s.jointTarget(static_cast<std::size_t>(o))) {
        TermRows rows;
        for (std::size_t j = 0; j < v; ++j) {
            s.terms_[static_cast<std::size_t>(o)]->change(world, t, change(j), rows);
            jacobian.block(row, chain.varColumns[j], rows.size(), 1) += rows;
        }
        return;
    }

    // Rotation rows: with A = Q S (polar), dQ = Q [w]x where (tr(S) I - S) w = vee(Q^T dA - dA^T Q);
    // then d(2 vec q) = (w_q I + [v_q]x) w (halfAngle).
    const Eigen::Matrix3d a = world.block<3, 3>(0, 0);
    Eigen::Matrix3d q, kInverse;
    if (nearlyOrthonormal(a)) {
        q = orthonormalOrientation(a);
        kInverse = std::copysign(0.5, a.determinant()) * Eigen::Matrix3d::Identity();  // S = +-I
    } else {
        Eigen::Matrix3d sym;
        q = polarRotation(a, &sym);
        kInverse = (sym.trace() * Eigen::Matrix3d::Identity() - sym).inverse();
    }
    const Eigen::Matrix3d rotationRows = t.rotationWeight * halfAngle(q, t).rows * kInverse;
    const Eigen::Matrix3d qt = q.transpose();

    for (std::size_t j = 0; j < v; ++j) {
        const Eigen::Matrix<double, 3, 4> d = change(j);
        const Eigen::Index column = chain.varColumns[j];
        jacobian.block<3, 1>(row, column) += t.positionWeight * d.col(3);
        const Eigen::Matrix3d x = qt * d.leftCols<3>();
        const Eigen::Vector3d skewPart(x(2, 1) - x(1, 2), x(0, 2) - x(2, 0), x(1, 0) - x(0, 1));
        jacobian.block<3, 1>(row + 3, column) += rotationRows * skewPart;
    }
}

void ResidualWorkspace::jacobianFromSuffixes(std::span<const double> x, Eigen::Ref<Eigen::VectorXd> r,
                                             Eigen::Ref<Eigen::MatrixXd> jacobian)
{
    treeFormed_ = false;
    if (structure_->hasBases()) {  // no flat chain holds a base: whole evaluations instead
        wholeDifferences(x, wholeDifferenceStep, r, jacobian);
        return;
    }
    holdChains();
    evaluateSlots(x, true);
    jacobian.setZero();
    const auto& s = *structure_;
    for (std::size_t o = 0; o < worlds_.size(); ++o) {
        outputJacobian(static_cast<int>(o), jacobian);
        if (s.jointTarget(o)) {
            r.segment<jointTargetRows>(s.rowOffset_[o]) = residual6(worlds_[o], targets_[o]);
            continue;
        }
        TermRows rows;
        s.terms_[o]->residual(worlds_[o], targets_[o], rows);
        r.segment(s.rowOffset_[o], rows.size()) = rows;
    }
}

void ResidualWorkspace::jacobian(std::span<const double> x, JacobianMethod method, double finiteDifferenceStep,
                                 bool parallel, Eigen::Ref<Eigen::VectorXd> r, Eigen::Ref<Eigen::MatrixXd> jacobian)
{
    const auto& s = *structure_;
    if (method == JacobianMethod::analytic) {
        evaluateSlots(x, true);
        evaluateTree();
        residualRows(r);
        if (velocities()) {
            clearTreeEntries(jacobian);
            treeJacobian(jacobian);
            return;
        }
        treeFormed_ = false;
        // A singular operator or product has no inverse: the prefix and suffix products need none.
        jacobianFromSuffixes(x, r, jacobian);
        return;
    }
    treeFormed_ = false;
    if (s.hasBases()) {
        wholeDifferences(x, finiteDifferenceStep, r, jacobian);
        return;
    }
    jacobian.setZero();
    holdChains();
    residuals(x, r);  // also leaves the slot matrices at x for the columns below
    const double h = finiteDifferenceStep;
    // Each column reads the shared slot matrices and writes only its own entries: the result does not
    // depend on how columns are spread over threads.
    auto column = [&](int c) {
        const double value = x[static_cast<std::size_t>(c)];
        for (const int o : s.outputsOfColumn(c)) {
            const std::size_t i = static_cast<std::size_t>(o);
            if (s.jointTarget(i)) {
                const Vector6d plus = residual6(chainWorld(o, c, value + h), targets_[i]);
                const Vector6d minus = residual6(chainWorld(o, c, value - h), targets_[i]);
                jacobian.block<jointTargetRows, 1>(s.rowOffset_[i], c) = (plus - minus) / (2.0 * h);
                continue;
            }
            TermRows plus, minus;
            s.terms_[i]->residual(chainWorld(o, c, value + h), targets_[i], plus);
            s.terms_[i]->residual(chainWorld(o, c, value - h), targets_[i], minus);
            jacobian.block(s.rowOffset_[i], c, plus.size(), 1) = (plus - minus) / (2.0 * h);
        }
    };
    if (parallel) {
        tbb::parallel_for(0, s.columnCount(), column);
    } else {
        for (int c = 0; c < s.columnCount(); ++c) column(c);
    }
}

void ResidualWorkspace::wholeDifferences(std::span<const double> x, double step, Eigen::Ref<Eigen::VectorXd> r,
                                         Eigen::Ref<Eigen::MatrixXd> jacobian)
{
    // One column at a time on this workspace (its products are shared state): serial, and the same for any thread
    // count.
    treeFormed_ = false;
    jacobian.setZero();
    trial_.assign(x.begin(), x.end());
    const Eigen::Index rows = structure_->rows();
    Eigen::VectorXd plus(rows), minus(rows);
    for (int c = 0; c < structure_->columnCount(); ++c) {
        const std::size_t i = static_cast<std::size_t>(c);
        trial_[i] = x[i] + step;
        residuals(trial_, plus);
        trial_[i] = x[i] - step;
        residuals(trial_, minus);
        trial_[i] = x[i];
        jacobian.col(c) = (plus - minus) / (2.0 * step);
    }
    residuals(x, r.head(rows));
}

void ResidualWorkspace::normalEquations(std::span<const double> x, JacobianMethod method, double finiteDifferenceStep,
                                        bool parallel, Eigen::Ref<Eigen::VectorXd> r, Eigen::Ref<Eigen::VectorXd> g,
                                        std::span<double> h, Eigen::Ref<Eigen::MatrixXd> jacobian)
{
    const auto& s = *structure_;
    if (method == JacobianMethod::analytic && s.twistNormals_) {
        residuals(x, r);
        normalEquationsAtLast(r, g, h);
        return;
    }
    this->jacobian(x, method, finiteDifferenceStep, parallel, r, jacobian);
    g.setZero();
    std::fill(h.begin(), h.end(), 0.0);
    const std::size_t n = static_cast<std::size_t>(s.columnCount());
    const auto entry = [&](int row, int column) -> double& {
        const std::size_t dense = static_cast<std::size_t>(column) * n + static_cast<std::size_t>(row);
        if (layout_.empty()) return h[dense];
        if (layout_[dense] < 0)  // a folded layout's: only the twists' normal equations leave entries out
            throw internalError("ResidualWorkspace::normalEquations: the layout leaves out a pair of columns");
        return h[static_cast<std::size_t>(layout_[dense])];
    };
    // An output's rows against the columns that move it: fixed-size for the joint target's six.
    const auto products = [&]<int Rows>(std::size_t o, Eigen::Index count) {
        const auto& columns = s.columnsOfOutput_[o];
        const Eigen::Index row = s.rowOffset_[o];
        for (std::size_t i = 0; i < columns.size(); ++i) {
            const auto ji = jacobian.block<Rows, 1>(row, columns[i], count, 1);
            g[columns[i]] += ji.dot(r.segment<Rows>(row, count));
            for (std::size_t j = 0; j <= i; ++j)  // columns increase: (i, j) is in the lower triangle
                entry(columns[i], columns[j]) += ji.dot(jacobian.block<Rows, 1>(row, columns[j], count, 1));
        }
    };
    for (std::size_t o = 0; o < s.columnsOfOutput_.size(); ++o) {
        if (s.jointTarget(o)) products.template operator()<jointTargetRows>(o, jointTargetRows);
        else products.template operator()<Eigen::Dynamic>(o, s.terms_[o]->rows());
    }
}

// --- JacobianEvaluator ---

namespace {

std::vector<int> activeOutputs(const Approximation& approximation, std::span<const JointTarget> targets)
{
    if (targets.size() != approximation.outputs.size())
        throw internalError(
            fmt::format("JacobianEvaluator: {} targets for {} outputs", targets.size(), approximation.outputs.size()));
    std::vector<int> outputs;
    for (std::size_t k = 0; k < targets.size(); ++k)
        if (targets[k].active) outputs.push_back(static_cast<int>(k));
    return outputs;
}

// Each target's term, or none when every one is a joint target.
std::vector<const ResidualTerm*> targetTerms(std::span<const JointTarget> targets)
{
    std::vector<const ResidualTerm*> terms;
    for (const JointTarget& t : targets) terms.push_back(t.term);
    if (std::all_of(terms.begin(), terms.end(), [](const ResidualTerm* t) { return !t; })) terms.clear();
    return terms;
}

std::vector<int> allColumns(const Approximation& approximation)
{
    std::vector<int> columns(approximation.parameters.size());
    for (std::size_t p = 0; p < columns.size(); ++p) columns[p] = static_cast<int>(p);
    return columns;
}

}  // namespace

JacobianEvaluator::JacobianEvaluator(const Approximation& approximation, std::span<const JointTarget> targets,
                                     double rotationScaleCm)
    : structure_(approximation, allColumns(approximation), activeOutputs(approximation, targets), targetTerms(targets)),
      workspace_(structure_)
{
    workspace_.holdParameters(approximation.defaults());  // every parameter is a column: only F_k(0) is held
    const auto& outputs = structure_.outputs();
    for (std::size_t o = 0; o < outputs.size(); ++o) {
        PreparedTarget prepared;
        const std::size_t k = static_cast<std::size_t>(outputs[o]);
        if (!prepareTarget(targets[k], rotationScaleCm, prepared))
            throw Error(
                fmt::format("JacobianEvaluator: the target of {} is not usable", approximation.outputs[k].name));
        workspace_.setTarget(static_cast<int>(o), prepared);
    }
}

void JacobianEvaluator::residuals(std::span<const double> values, Eigen::VectorXd& r)
{
    if (values.size() != static_cast<std::size_t>(columns()))
        throw internalError("JacobianEvaluator: one value per modelled parameter");
    r.resize(rows());
    workspace_.residuals(values, r);
}

void JacobianEvaluator::jacobian(std::span<const double> values, JacobianMethod method, double finiteDifferenceStep,
                                 Eigen::MatrixXd& jacobian, Eigen::VectorXd& r)
{
    if (values.size() != static_cast<std::size_t>(columns()))
        throw internalError("JacobianEvaluator: one value per modelled parameter");
    r.resize(rows());
    jacobian.resize(rows(), columns());
    workspace_.jacobian(values, method, finiteDifferenceStep, true, r, jacobian);
}

void JacobianEvaluator::normalEquations(std::span<const double> values, JacobianMethod method,
                                        double finiteDifferenceStep, Eigen::VectorXd& g, Eigen::MatrixXd& h,
                                        Eigen::VectorXd& r)
{
    if (values.size() != static_cast<std::size_t>(columns()))
        throw internalError("JacobianEvaluator: one value per modelled parameter");
    r.resize(rows());
    g.resize(columns());
    h.resize(columns(), columns());
    Eigen::MatrixXd jacobian(rows(), columns());
    const std::span<double> entries(h.data(), static_cast<std::size_t>(h.size()));
    workspace_.normalEquations(values, method, finiteDifferenceStep, true, r, g, entries, jacobian);
}

void JacobianEvaluator::jacobianFromSuffixes(std::span<const double> values, Eigen::MatrixXd& jacobian,
                                             Eigen::VectorXd& r)
{
    if (values.size() != static_cast<std::size_t>(columns()))
        throw internalError("JacobianEvaluator: one value per modelled parameter");
    r.resize(rows());
    jacobian.resize(rows(), columns());
    workspace_.jacobianFromSuffixes(values, r, jacobian);
}

}  // namespace rig
