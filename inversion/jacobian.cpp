#include "inversion/jacobian.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>
#include <fmt/format.h>
#include <oneapi/tbb/parallel_for.h>

#include "inversion/operators.h"

namespace rig {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;

// Products of rigid operators drift from orthonormal by rounding only; below this the polar
// decomposition (an SVD) is skipped: the error it would remove is far below any tolerance.
constexpr double orthonormalSlack = 1e-10;

bool nearlyOrthonormal(const Eigen::Matrix3d& a)
{
    return ((a.transpose() * a) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < orthonormalSlack;
}

// A = Q S with Q a rotation (reflections removed) and S symmetric.
Eigen::Matrix3d polar(const Eigen::Matrix3d& a, Eigen::Matrix3d* symmetric)
{
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(a, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d u = svd.matrixU();
    if ((u * svd.matrixV().transpose()).determinant() < 0) u.col(2) = -u.col(2);
    const Eigen::Matrix3d q = u * svd.matrixV().transpose();
    if (symmetric) *symmetric = q.transpose() * a;
    return q;
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v)
{
    Eigen::Matrix3d s;
    s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return s;
}

// Inverse of the right Jacobian of SO(3): d log(X exp(nu)) = J_r^-1(log X) nu.
Eigen::Matrix3d rightJacobianInverse(const Eigen::Vector3d& e)
{
    const double t = e.norm();
    const Eigen::Matrix3d k = skew(e);
    double c;
    if (t < 1e-4) {
        c = 1.0 / 12.0 + t * t / 720.0;  // series: the closed form cancels catastrophically here
    } else {
        // At pi the logarithm itself jumps; keep the coefficient finite there.
        const double s = std::max(std::sin(t), 1e-12);
        c = 1.0 / (t * t) - (1.0 + std::cos(t)) / (2.0 * t * s);
    }
    return Eigen::Matrix3d::Identity() + 0.5 * k + c * k * k;
}

Eigen::Vector3d rotationResidual(const Eigen::Matrix3d& q, const PreparedTarget& t)
{
    return rotationVector(t.rotation.transpose() * q);
}

Vector6d residual6(const Eigen::Matrix4d& world, const PreparedTarget& t)
{
    Vector6d r;
    r.head<3>() = t.positionWeight * (world.block<3, 1>(0, 3) - t.position);
    const Eigen::Matrix3d a = world.block<3, 3>(0, 0);
    r.tail<3>() = t.rotationWeight * rotationResidual(nearlyOrthonormal(a) ? a : polar(a, nullptr), t);
    return r;
}

}  // namespace

std::string_view jacobianMethodName(JacobianMethod method)
{
    return method == JacobianMethod::analytic ? "analytic" : "finiteDifference";
}

Eigen::Matrix3d orthonormalPart(const Eigen::Matrix3d& m) { return polar(m, nullptr); }

bool prepareTarget(const JointTarget& target, double rotationScaleCm, PreparedTarget& prepared)
{
    if (!target.world.topRows<3>().allFinite()) return false;
    if (!std::isfinite(target.positionWeight) || !std::isfinite(target.rotationWeight)) return false;
    if (target.positionWeight < 0 || target.rotationWeight < 0) return false;
    const Eigen::Matrix3d a = target.world.block<3, 3>(0, 0);
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(a);
    const auto& sigma = svd.singularValues();
    if (!(sigma[0] > 0) || sigma[2] <= 1e-9 * sigma[0]) return false;
    prepared.position = target.world.block<3, 1>(0, 3);
    prepared.rotation = nearlyOrthonormal(a) ? a : polar(a, nullptr);
    prepared.positionWeight = target.positionWeight;
    prepared.rotationWeight = target.rotationWeight * rotationScaleCm;
    return true;
}

TargetError targetError(const Eigen::Matrix4d& world, const PreparedTarget& target)
{
    const Eigen::Matrix3d a = world.block<3, 3>(0, 0);
    const Eigen::Matrix3d q = nearlyOrthonormal(a) ? a : polar(a, nullptr);
    return {(world.block<3, 1>(0, 3) - target.position).norm(), rotationResidual(q, target).norm()};
}

// --- ResidualStructure ---

ResidualStructure::ResidualStructure(const Approximation& approximation, std::vector<int> columns, std::vector<int> outputs)
    : approximation_(&approximation), columns_(std::move(columns)), outputs_(std::move(outputs))
{
    const int parameterCount = static_cast<int>(approximation.parameters.size());
    const int outputCount = static_cast<int>(approximation.outputs.size());
    std::vector<int> columnOf(static_cast<std::size_t>(parameterCount), -1);
    for (std::size_t c = 0; c < columns_.size(); ++c) {
        const int p = columns_[c];
        if (p < 0 || p >= parameterCount || (c > 0 && p <= columns_[c - 1]))
            throw std::invalid_argument("ResidualStructure: columns must be increasing parameter indices");
        columnOf[static_cast<std::size_t>(p)] = static_cast<int>(c);
    }
    std::vector<int> positionOf(static_cast<std::size_t>(outputCount), -1);
    for (std::size_t o = 0; o < outputs_.size(); ++o) {
        const int k = outputs_[o];
        if (k < 0 || k >= outputCount || (o > 0 && k <= outputs_[o - 1]))
            throw std::invalid_argument("ResidualStructure: outputs must be increasing output indices");
        positionOf[static_cast<std::size_t>(k)] = static_cast<int>(o);
    }

    // Links of every chain, outermost first: walking the parameters in composition order.
    std::vector<std::vector<Link>> links(outputs_.size());
    std::vector<std::vector<std::pair<int, int>>> slotOfColumnOp(columns_.size());  // (op, slot)
    for (int p = 0; p < parameterCount; ++p) {
        const ModelledParameter& m = approximation.parameters[static_cast<std::size_t>(p)];
        for (std::size_t e = 0; e < m.outputs.size(); ++e) {
            const int k = m.outputs[e];
            if (k < 0 || k >= outputCount || e >= m.operatorOfOutput.size() || m.operatorOfOutput[e] < 0 ||
                m.operatorOfOutput[e] >= static_cast<int>(m.operators.size()))
                throw std::invalid_argument(
                    fmt::format("ResidualStructure: parameter {} has an inconsistent output or operator index",
                                m.parameter.name));
            const int o = positionOf[static_cast<std::size_t>(k)];
            if (o < 0) continue;
            Link link{p, m.operatorOfOutput[e], columnOf[static_cast<std::size_t>(p)], -1};
            if (link.column >= 0) {
                auto& known = slotOfColumnOp[static_cast<std::size_t>(link.column)];
                for (const auto& [op, slot] : known)
                    if (op == link.op) link.slot = slot;
                if (link.slot < 0) {
                    link.slot = static_cast<int>(slots_.size());
                    slots_.push_back({link.column, p, link.op});
                    known.emplace_back(link.op, link.slot);
                }
            }
            links[static_cast<std::size_t>(o)].push_back(link);
        }
    }

    outputsOfColumn_.assign(columns_.size(), {});
    chains_.resize(outputs_.size());
    for (std::size_t o = 0; o < outputs_.size(); ++o) {
        Chain& chain = chains_[o];
        chain.gaps.emplace_back();
        for (const Link& link : links[o]) {
            if (link.column < 0) {
                chain.gaps.back().push_back(link);
                continue;
            }
            chain.varSlots.push_back(link.slot);
            chain.varColumns.push_back(link.column);
            chain.gaps.emplace_back();
            outputsOfColumn_[static_cast<std::size_t>(link.column)].push_back(static_cast<int>(o));
        }
        maxVars_ = std::max(maxVars_, static_cast<int>(chain.varSlots.size()));
        constantCount_ += static_cast<int>(chain.gaps.size());
    }
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
}

void ResidualWorkspace::holdParameters(std::span<const double> values)
{
    const auto& s = *structure_;
    const Approximation& approx = *s.approximation_;
    if (values.size() != approx.parameters.size())
        throw std::invalid_argument("ResidualWorkspace::holdParameters: one value per modelled parameter");
    for (std::size_t o = 0; o < s.chains_.size(); ++o) {
        const auto& gaps = s.chains_[o].gaps;
        for (std::size_t g = 0; g < gaps.size(); ++g) {
            const std::size_t index = static_cast<std::size_t>(constantOffset_[o]) + g;
            Eigen::Matrix4d c = Eigen::Matrix4d::Identity();
            for (const auto& link : gaps[g]) {
                const ModelledParameter& m = approx.parameters[static_cast<std::size_t>(link.parameter)];
                c = c * m.operators[static_cast<std::size_t>(link.op)].matrix(
                            values[static_cast<std::size_t>(link.parameter)] - m.parameter.defaultValue);
            }
            const bool last = g + 1 == gaps.size();
            if (last) c = c * approx.outputs[static_cast<std::size_t>(s.outputs_[o])].rest;
            constants_[index] = c;
            identity_[index] = !last && gaps[g].empty();
        }
    }
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
    const Approximation& approx = *s.approximation_;
    for (std::size_t i = 0; i < s.slots_.size(); ++i) {
        const auto& slot = s.slots_[i];
        const ModelledParameter& m = approx.parameters[static_cast<std::size_t>(slot.parameter)];
        const Operator& op = m.operators[static_cast<std::size_t>(slot.op)];
        const double a = x[static_cast<std::size_t>(slot.column)] - m.parameter.defaultValue;
        slotMatrix_[i] = op.matrix(a);
        if (derivatives) slotDerivative_[i] = op.derivative(a);
    }
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

void ResidualWorkspace::residuals(std::span<const double> x, Eigen::Ref<Eigen::VectorXd> r)
{
    evaluateSlots(x, false);
    for (std::size_t o = 0; o < worlds_.size(); ++o) {
        worlds_[o] = chainWorld(static_cast<int>(o), -1, 0.0);
        r.segment<rowsPerTarget>(static_cast<Eigen::Index>(rowsPerTarget * o)) = residual6(worlds_[o], targets_[o]);
    }
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
    const Eigen::Index row = static_cast<Eigen::Index>(rowsPerTarget * o);
    if (v == 0) return;

    // suffix_[j] = C_{j+1} V_{j+1} ... V_{v-1} C_v: everything after V_j.
    suffix_[v - 1] = constants_[base + v];
    for (std::size_t j = v - 1; j-- > 0;) {
        suffix_[j].noalias() = slotMatrix_[static_cast<std::size_t>(chain.varSlots[j + 1])] * suffix_[j + 1];
        if (!identity_[base + j + 1]) suffix_[j] = constants_[base + j + 1] * suffix_[j];
    }

    // Rotation rows: with A = Q S (polar), dQ = Q [w]x where (tr(S) I - S) w = vee(Q^T dA - dA^T Q);
    // then d log(Q_t^T Q) = J_r^-1(e) w.
    const Eigen::Matrix3d a = world.block<3, 3>(0, 0);
    Eigen::Matrix3d q, kInverse;
    if (nearlyOrthonormal(a)) {
        q = a;
        kInverse = 0.5 * Eigen::Matrix3d::Identity();
    } else {
        Eigen::Matrix3d sym;
        q = polar(a, &sym);
        kInverse = (sym.trace() * Eigen::Matrix3d::Identity() - sym).inverse();
    }
    const Eigen::Vector3d e = rotationResidual(q, t);
    const Eigen::Matrix3d rotationRows = t.rotationWeight * rightJacobianInverse(e) * kInverse;
    const Eigen::Matrix3d qt = q.transpose();

    for (std::size_t j = 0; j < v; ++j) {
        // Only the top three rows of dW = prefix_j V_j' suffix_j are needed.
        const Eigen::Matrix<double, 3, 4> left =
            prefix_[j].topRows<3>() * slotDerivative_[static_cast<std::size_t>(chain.varSlots[j])];
        const Eigen::Matrix<double, 3, 4> d = left * suffix_[j];
        const Eigen::Index column = chain.varColumns[j];
        jacobian.block<3, 1>(row, column) = t.positionWeight * d.col(3);
        const Eigen::Matrix3d x = qt * d.leftCols<3>();
        const Eigen::Vector3d skewPart(x(2, 1) - x(1, 2), x(0, 2) - x(2, 0), x(1, 0) - x(0, 1));
        jacobian.block<3, 1>(row + 3, column) = rotationRows * skewPart;
    }
}

void ResidualWorkspace::jacobian(std::span<const double> x, JacobianMethod method, double finiteDifferenceStep,
                                 bool parallel, Eigen::Ref<Eigen::VectorXd> r, Eigen::Ref<Eigen::MatrixXd> jacobian)
{
    const auto& s = *structure_;
    jacobian.setZero();
    if (method == JacobianMethod::analytic) {
        evaluateSlots(x, true);
        for (std::size_t o = 0; o < worlds_.size(); ++o) {
            outputJacobian(static_cast<int>(o), jacobian);
            r.segment<rowsPerTarget>(static_cast<Eigen::Index>(rowsPerTarget * o)) = residual6(worlds_[o], targets_[o]);
        }
        return;
    }
    residuals(x, r);  // also leaves the slot matrices at x for the columns below
    const double h = finiteDifferenceStep;
    // Each column reads the shared slot matrices and writes only its own entries: the result does not
    // depend on how columns are spread over threads.
    auto column = [&](int c) {
        const double value = x[static_cast<std::size_t>(c)];
        for (const int o : s.outputsOfColumn(c)) {
            const Vector6d plus = residual6(chainWorld(o, c, value + h), targets_[static_cast<std::size_t>(o)]);
            const Vector6d minus = residual6(chainWorld(o, c, value - h), targets_[static_cast<std::size_t>(o)]);
            jacobian.block<rowsPerTarget, 1>(rowsPerTarget * o, c) = (plus - minus) / (2.0 * h);
        }
    };
    if (parallel) {
        tbb::parallel_for(0, s.columnCount(), column);
    } else {
        for (int c = 0; c < s.columnCount(); ++c) column(c);
    }
}

// --- JacobianEvaluator ---

namespace {

std::vector<int> activeOutputs(const Approximation& approximation, std::span<const JointTarget> targets)
{
    if (targets.size() != approximation.outputs.size())
        throw std::invalid_argument(fmt::format("JacobianEvaluator: {} targets for {} outputs", targets.size(),
                                                approximation.outputs.size()));
    std::vector<int> outputs;
    for (std::size_t k = 0; k < targets.size(); ++k)
        if (targets[k].active) outputs.push_back(static_cast<int>(k));
    return outputs;
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
    : structure_(approximation, allColumns(approximation), activeOutputs(approximation, targets)),
      workspace_(structure_)
{
    workspace_.holdParameters(approximation.defaults());  // every parameter is a column: only F_k(0) is held
    const auto& outputs = structure_.outputs();
    for (std::size_t o = 0; o < outputs.size(); ++o) {
        PreparedTarget prepared;
        const std::size_t k = static_cast<std::size_t>(outputs[o]);
        if (!prepareTarget(targets[k], rotationScaleCm, prepared))
            throw std::invalid_argument(fmt::format("JacobianEvaluator: the target of {} is not usable",
                                                    approximation.outputs[k].name));
        workspace_.setTarget(static_cast<int>(o), prepared);
    }
}

void JacobianEvaluator::residuals(std::span<const double> values, Eigen::VectorXd& r)
{
    if (values.size() != static_cast<std::size_t>(columns()))
        throw std::invalid_argument("JacobianEvaluator: one value per modelled parameter");
    r.resize(rows());
    workspace_.residuals(values, r);
}

void JacobianEvaluator::jacobian(std::span<const double> values, JacobianMethod method, double finiteDifferenceStep,
                                 Eigen::MatrixXd& jacobian, Eigen::VectorXd& r)
{
    if (values.size() != static_cast<std::size_t>(columns()))
        throw std::invalid_argument("JacobianEvaluator: one value per modelled parameter");
    r.resize(rows());
    jacobian.resize(rows(), columns());
    workspace_.jacobian(values, method, finiteDifferenceStep, true, r, jacobian);
}

}  // namespace rig
