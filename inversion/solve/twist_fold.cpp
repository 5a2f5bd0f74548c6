#include "inversion/solve/jacobian.h"

#include <algorithm>

#include <fmt/format.h>
#include <Eigen/Dense>

#include "core/error.h"
#include "inversion/solve/jacobian_math.h"

// The twist fold (jacobian.h, ResidualWorkspace::normalEquations): where every operator and output is rigid, J^T J
// and J^T r from each unknown node's twist and the sums of B_k^T B_k and B_k^T r_k up the prefix tree, J never formed;
// through planar chains' bases too, and into a block elimination's layout.

namespace rig {

using namespace jacobian_math;

void ResidualWorkspace::twists()
{
    const auto& s = *structure_;
    for (const int n : s.unknownNodes_) {
        const std::size_t i = static_cast<std::size_t>(n);
        const auto& node = s.nodes_[i];
        const std::size_t slotIndex = static_cast<std::size_t>(node.slot);
        const Operator& op = *s.slots_[slotIndex].operation;
        const double a = slotOffset_[slotIndex];
        // The operator's own twist X = dM M^-1, moved to world space by the parent's rigid product P:
        // (R omega, R v + t x R omega). A rotation about pivot p turns by m'(a) n with v = p x omega, a
        // translation moves by m'(a) n; sampled rigid operators through dM M^-1 itself.
        Eigen::Vector3d omega, v;
        if (op.kind == OperatorKind::rotation) {
            omega = op.magnitudeDerivative(a) * op.axis;
            v = op.pivot.cross(omega);
        } else if (op.kind == OperatorKind::translation) {
            omega.setZero();
            v = op.magnitudeDerivative(a) * op.axis;
        } else {
            const Eigen::Matrix4d d = op.derivative(a);
            const Eigen::Matrix4d& m = slotMatrix_[slotIndex];
            const Eigen::Matrix3d xl = d.block<3, 3>(0, 0) * m.block<3, 3>(0, 0).transpose();
            omega << 0.5 * (xl(2, 1) - xl(1, 2)), 0.5 * (xl(0, 2) - xl(2, 0)), 0.5 * (xl(1, 0) - xl(0, 1));
            v = d.block<3, 1>(0, 3) - xl * m.block<3, 1>(0, 3);
        }
        if (node.parent >= 0) {
            const Affine& p = nodeMatrix_[static_cast<std::size_t>(node.parent)];
            omega = p.leftCols<3>() * omega;
            v = p.leftCols<3>() * v + p.col(3).cross(omega);
        }
        twist_[i] << omega, v;
    }
}

void ResidualWorkspace::useLayout(std::span<const int> layout)
{
    const auto& s = *structure_;
    const std::size_t n = static_cast<std::size_t>(s.columnCount());
    if (!layout.empty() && layout.size() != n * n)
        throw internalError(fmt::format("ResidualWorkspace::useLayout: {} entries for {} columns", layout.size(), n));
    layout_.assign(layout.begin(), layout.end());
    pairBegin_.assign(1, 0);
    pairNode_.clear();
    pairTarget_.clear();
    pairFactor_.clear();
    for (std::size_t k = 0; k < s.unknownNodes_.size(); ++k) {
        // A node's pairs run from itself up: those left out must be the last ones.
        bool left = false;
        for (int p = s.pairBegin_[k]; p < s.pairBegin_[k + 1]; ++p) {
            const std::size_t q = static_cast<std::size_t>(p);
            const int target = layout_.empty() ? s.pairOffset_[q] : layout_[static_cast<std::size_t>(s.pairOffset_[q])];
            if (target >= 0 && left)
                throw internalError("ResidualWorkspace::useLayout: columns that share an output have no entry");
            if (target < 0) {
                if (!s.twistForm_)
                    throw internalError("ResidualWorkspace::useLayout: columns that share an output have no entry");
                left = true;
                continue;
            }
            pairNode_.push_back(s.pairNode_[q]);
            pairTarget_.push_back(target);
            pairFactor_.push_back(s.pairFactor_[q]);
        }
        pairBegin_.push_back(static_cast<int>(pairNode_.size()));
    }
    useBaseLayout();
}

void ResidualWorkspace::useBaseLayout()
{
    const auto& s = *structure_;
    const std::size_t n = static_cast<std::size_t>(s.columnCount());
    const auto target = [&](int a, int c) {
        const std::size_t dense =
            static_cast<std::size_t>(std::min(a, c)) * n + static_cast<std::size_t>(std::max(a, c));
        const int at = layout_.empty() ? static_cast<int>(dense) : layout_[dense];
        if (at < 0) throw internalError("ResidualWorkspace::useLayout: columns that share an output have no entry");
        return at;
    };
    basePairBegin_.assign(1, 0);
    baseNodeBegin_.assign(1, 0);
    for (auto* v : {&basePairTarget_, &baseNodeVelocity_, &baseNodeNode_, &baseNodeTarget_}) v->clear();
    baseNodeFactor_.clear();
    for (std::size_t b = 0; b < s.bases_.size() && s.twistNormals_; ++b) {
        const ResidualStructure::Base& base = s.bases_[b];
        for (std::size_t j = 0; j < base.columns.size(); ++j) {
            const int vj = base.velocityOffset + static_cast<int>(j);
            for (std::size_t i = 0; i <= j; ++i) basePairTarget_.push_back(target(base.columns[i], base.columns[j]));
            for (int u = s.baseUnknownBegin_[b]; u < s.baseUnknownBegin_[b + 1]; ++u) {
                const int node = s.baseUnknown_[static_cast<std::size_t>(u)];
                const int column =
                    s.slots_[static_cast<std::size_t>(s.nodes_[static_cast<std::size_t>(node)].slot)].column;
                baseNodeVelocity_.push_back(vj);
                baseNodeNode_.push_back(node);
                baseNodeTarget_.push_back(target(base.columns[j], column));
                baseNodeFactor_.push_back(column == base.columns[j] ? 2.0 : 1.0);
            }
        }
        basePairBegin_.push_back(static_cast<int>(basePairTarget_.size()));
        baseNodeBegin_.push_back(static_cast<int>(baseNodeTarget_.size()));
    }
}

void ResidualWorkspace::normalEquationsAtLast(const Eigen::Ref<const Eigen::VectorXd>& r, Eigen::Ref<Eigen::VectorXd> g,
                                              std::span<double> h)
{
    if (!structure_->twistNormals_)
        throw internalError("ResidualWorkspace::normalEquationsAtLast: only for structures with twist normals");
    twists();
    if (structure_->hasBases()) baseTwistVelocities();
    twistNormalEquations(r, g, h);
}

void ResidualWorkspace::twistNormalEquations(const Eigen::Ref<const Eigen::VectorXd>& r, Eigen::Ref<Eigen::VectorXd> g,
                                             std::span<double> h)
{
    const auto& s = *structure_;
    if (!s.jointTargetsOnly_) {
        // Any term: B from the term itself, its B^T B a full 6x6.
        const auto contribution = [&](std::size_t o, Matrix6& weight, Vector6d& load) {
            TermTwistRows b;
            s.terms_[o]->twistJacobian(worlds_[o], targets_[o], b);
            weight.noalias() = b.transpose() * b;
            load.noalias() = b.transpose() * r.segment(s.rowOffset_[o], b.rows());
        };
        const auto times = [](const Matrix6& weight, const Vector6d& twist) -> Vector6d { return weight * twist; };
        foldTwists(fullWeight_, baseFullWeight_, contribution, times, g, h);
        return;
    }
    // An output's rows for a twist (omega, v) of a node above it: B = [[-w_p [p]x, w_p I], [w_r H Q^T, 0]]
    // (w_p (omega x p + v) and w_r H Q^T omega, treeJacobian's rigid rows) with H = w_q I + [v_q]x. For a unit
    // quaternion H^T H = I - v_q v_q^T, so B^T B = [[w_p^2 (|p|^2 I - p p^T) + w_r^2 (I - u u^T), w_p^2 [p]x],
    // [-w_p^2 [p]x, w_p^2 I]] with u = Q v_q, and B^T r = (w_p p x r_p + w_r Q H^T r_q, w_p r_p).
    const auto contribution = [&](std::size_t o, TwistWeight& w, Vector6d& load) {
        const PreparedTarget& t = targets_[o];
        const Eigen::Matrix3d q = worlds_[o].block<3, 3>(0, 0);
        const Eigen::Vector3d p = worlds_[o].block<3, 1>(0, 3);
        const Eigen::Quaterniond& e = quaternion_[o];  // residualRows' (halfAngle)
        const Eigen::Vector3d u = q * e.vec();
        const double wp = t.positionWeight, wr = t.rotationWeight;
        const double wp2 = wp * wp, wr2 = wr * wr;
        w.a.noalias() = (wp2 * p.squaredNorm() + wr2) * Eigen::Matrix3d::Identity() - wp2 * p * p.transpose() -
                        wr2 * u * u.transpose();
        w.m = wp2 * p;
        w.s = wp2;
        const auto rows = r.segment<jointTargetRows>(s.rowOffset_[o]);
        const Eigen::Vector3d rp = rows.head<3>(), rq = rows.tail<3>();
        load << wp * p.cross(rp) + wr * (q * (e.w() * rq - e.vec().cross(rq))), wp * rp;
    };
    // W t = (A omega + m x v, s v - m x omega).
    const auto times = [](const TwistWeight& w, const Vector6d& twist) -> Vector6d {
        const auto omega = twist.head<3>(), v = twist.tail<3>();
        Vector6d u;
        u << w.a * omega + w.m.cross(v), w.s * v - w.m.cross(omega);
        return u;
    };
    foldTwists(weight_, baseWeight_, contribution, times, g, h);
}

template <class Weight, class Contribution, class Times>
void ResidualWorkspace::foldTwists(std::vector<Weight>& weights, std::vector<Weight>& baseWeights,
                                   const Contribution& contribution, const Times& times, Eigen::Ref<Eigen::VectorXd> g,
                                   std::span<double> h)
{
    const auto& s = *structure_;
    // A node's sums are set by their first term rather than zeroed first: two hundred small memsets cost
    // more than the sums. Every unknown node has an output below it.
    for (const int n : s.unknownNodes_) fresh_[static_cast<std::size_t>(n)] = 1;
    std::fill(baseFresh_.begin(), baseFresh_.end(), 1);
    const auto addTo = [](std::vector<Weight>& sums, std::vector<Vector6d>& loads, std::vector<char>& fresh,
                          std::size_t n, const Weight& weight, const Vector6d& load) {
        if (fresh[n]) {
            sums[n] = weight;
            loads[n] = load;
            fresh[n] = 0;
            return;
        }
        sums[n] += weight;
        loads[n] += load;
    };
    const auto add = [&](std::size_t n, const Weight& weight, const Vector6d& load) {
        addTo(weights, load_, fresh_, n, weight, load);
    };
    for (std::size_t o = 0; o < worlds_.size(); ++o) {
        const int deepest = s.outputDeepest_[o], base = s.outputBase_[o];
        if (deepest < 0 && base < 0) continue;
        Weight w;
        Vector6d load;
        contribution(o, w, load);
        if (deepest >= 0) add(static_cast<std::size_t>(deepest), w, load);
        if (base >= 0) addTo(baseWeights, baseLoad_, baseFresh_, static_cast<std::size_t>(base), w, load);
    }
    // Children after parents: summed leaves first, each node's sums cover every output below it.
    for (auto it = s.unknownNodes_.rbegin(); it != s.unknownNodes_.rend(); ++it) {
        const std::size_t n = static_cast<std::size_t>(*it);
        const int up = s.unknownUp_[n];
        if (up >= 0) add(static_cast<std::size_t>(up), weights[n], load_[n]);
    }
    g.setZero();
    std::fill(h.begin(), h.end(), 0.0);
    double* entries = h.data();
    for (std::size_t k = 0; k < s.unknownNodes_.size(); ++k) {
        const std::size_t i = static_cast<std::size_t>(s.unknownNodes_[k]);
        g[s.unknownColumn_[k]] += twist_[i].dot(load_[i]);
        const Vector6d u = times(weights[i], twist_[i]);
        weighted_[i] = u;
        // Itself, then every unknown node above: those share exactly the outputs below this one.
        for (int p = pairBegin_[k]; p < pairBegin_[k + 1]; ++p) {
            const std::size_t q = static_cast<std::size_t>(p);
            entries[pairTarget_[q]] += pairFactor_[q] * twist_[static_cast<std::size_t>(pairNode_[q])].dot(u);
        }
    }
    if (s.hasBases()) foldBases(baseWeights, times, g, entries);
}

template <class Weight, class Times>
void ResidualWorkspace::foldBases(const std::vector<Weight>& baseWeights, const Times& times,
                                  Eigen::Ref<Eigen::VectorXd> g, double* entries)
{
    // A base's column moves every output that begins with the base by its twist tau: g += tau . (sum of B_k^T r_k),
    // its pairs with the base's other columns tau_i^T W_b tau_j, with an unknown node m below tau^T (W_m t_m) (twice
    // on the diagonal where m is of the same column).
    const auto& s = *structure_;
    for (std::size_t b = 0; b < s.bases_.size(); ++b) {
        if (baseFresh_[b]) continue;  // no output begins with it
        const ResidualStructure::Base& base = s.bases_[b];
        for (std::size_t j = 0; j < base.columns.size(); ++j) {
            const std::size_t v = static_cast<std::size_t>(base.velocityOffset) + j;
            g[base.columns[j]] += baseTwist_[v].dot(baseLoad_[b]);
            baseWeighted_[v] = times(baseWeights[b], baseTwist_[v]);
        }
        // Its pairs (i <= j) in the order useBaseLayout listed their entries.
        const Vector6d* twist = baseTwist_.data() + base.velocityOffset;
        const Vector6d* weighted = baseWeighted_.data() + base.velocityOffset;
        const int* target = basePairTarget_.data() + basePairBegin_[b];
        for (std::size_t j = 0; j < base.columns.size(); ++j)
            for (std::size_t i = 0; i <= j; ++i) entries[*target++] += twist[i].dot(weighted[j]);
        for (int p = baseNodeBegin_[b]; p < baseNodeBegin_[b + 1]; ++p) {
            const std::size_t q = static_cast<std::size_t>(p);
            entries[baseNodeTarget_[q]] +=
                baseNodeFactor_[q] * baseTwist_[static_cast<std::size_t>(baseNodeVelocity_[q])].dot(
                                         weighted_[static_cast<std::size_t>(baseNodeNode_[q])]);
        }
    }
}

}  // namespace rig
