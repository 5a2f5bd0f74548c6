#include "inversion/solve/residual_term.h"

#include <algorithm>
#include <cmath>
#include <mutex>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "core/error.h"
#include "core/rotation_math.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/partition.h"

namespace rig {
namespace {

// The orthonormal part of a world's 3x3 block, and (tr(S) I - S)^-1 for its symmetric part S: the rotation's
// change for a change dA of the block is Q [w]x with w = K^-1 vee(Q^T dA - dA^T Q) (0.5 I for a rotation).
struct Polar {
    Eigen::Matrix3d q;
    Eigen::Matrix3d kInverse;
};

Polar polarOf(const Eigen::Matrix4d& world)
{
    const Eigen::Matrix3d a = world.block<3, 3>(0, 0);
    // S = +-I: (tr(S) I - S)^-1 = +-I / 2, negative for a reflection (Q = -A).
    if (nearlyOrthonormal(a))
        return {orthonormalOrientation(a), std::copysign(0.5, a.determinant()) * Eigen::Matrix3d::Identity()};
    Polar p;
    Eigen::Matrix3d sym;
    p.q = polarRotation(a, &sym);
    p.kInverse = (sym.trace() * Eigen::Matrix3d::Identity() - sym).inverse();
    return p;
}

// d(2 vec q) / d omega for Q -> Q exp([omega]x), q the quaternion of Q_target^T Q with w >= 0: w I + [v]x.
Eigen::Matrix3d halfAngleRows(const Eigen::Matrix3d& q, const PreparedTarget& t)
{
    Eigen::Quaterniond e(t.rotation.transpose() * q);
    if (e.w() < 0) e.coeffs() = -e.coeffs();
    return e.w() * Eigen::Matrix3d::Identity() + skew(e.vec());
}

Eigen::Vector3d skewPart(const Eigen::Matrix3d& x) { return {x(2, 1) - x(1, 2), x(0, 2) - x(2, 0), x(1, 0) - x(0, 1)}; }

// The weighted position rows shared by both kinds: w_p (p - p_target), moved by omega x p + v.
void positionTwistRows(const Eigen::Matrix4d& world, double weight, TermTwistRows& jacobian)
{
    jacobian.topLeftCorner<3, 3>() = -weight * skew(world.block<3, 1>(0, 3));
    jacobian.topRightCorner<3, 3>() = weight * Eigen::Matrix3d::Identity();
}

class JointTargetTerm final : public ResidualTerm {
public:
    std::string_view name() const override { return "jointTarget"; }
    int rows() const override { return jointTargetRows; }
    unsigned char counted(const JointTarget& t) const override
    {
        unsigned char rows = noRows;
        if (t.positionWeight > 0) rows |= positionRows;
        if (t.rotationWeight > 0) rows |= rotationRows;
        return rows;
    }
    double weight(const PreparedTarget& t, int row) const override
    {
        return row < 3 ? t.positionWeight : t.rotationWeight;
    }
    void residual(const Eigen::Matrix4d& world, const PreparedTarget& t, TermRows& rows) const override
    {
        rows = targetResidual(world, t);
    }
    void twistJacobian(const Eigen::Matrix4d& world, const PreparedTarget& t, TermTwistRows& jacobian) const override
    {
        // A world-space turn omega turns the polar part as it turns the whole: Q -> exp([omega]x) Q, that is
        // Q exp([Q^T omega]x), whatever the symmetric part.
        jacobian.resize(jointTargetRows, 6);
        positionTwistRows(world, t.positionWeight, jacobian);
        const Eigen::Matrix3d q = polarOf(world).q;
        jacobian.bottomLeftCorner<3, 3>() = t.rotationWeight * halfAngleRows(q, t) * q.transpose();
        jacobian.bottomRightCorner<3, 3>().setZero();
    }
    void change(const Eigen::Matrix4d& world, const PreparedTarget& t, const Eigen::Matrix<double, 3, 4>& dWorld,
                TermRows& rows) const override
    {
        const Polar p = polarOf(world);
        rows.resize(jointTargetRows);
        rows.head<3>() = t.positionWeight * dWorld.col(3);
        rows.tail<3>() =
            t.rotationWeight * halfAngleRows(p.q, t) * p.kInverse * skewPart(p.q.transpose() * dWorld.leftCols<3>());
    }
    TargetError error(const Eigen::Matrix4d& world, const PreparedTarget& t) const override
    {
        return targetError(world, t);
    }
};

class PositionTerm final : public ResidualTerm {
public:
    std::string_view name() const override { return "position"; }
    int rows() const override { return 3; }
    unsigned char counted(const JointTarget& t) const override { return t.positionWeight > 0 ? positionRows : noRows; }
    double weight(const PreparedTarget& t, int) const override { return t.positionWeight; }
    void residual(const Eigen::Matrix4d& world, const PreparedTarget& t, TermRows& rows) const override
    {
        rows = t.positionWeight * (world.block<3, 1>(0, 3) - t.position);
    }
    void twistJacobian(const Eigen::Matrix4d& world, const PreparedTarget& t, TermTwistRows& jacobian) const override
    {
        jacobian.resize(3, 6);
        positionTwistRows(world, t.positionWeight, jacobian);
    }
    void change(const Eigen::Matrix4d&, const PreparedTarget& t, const Eigen::Matrix<double, 3, 4>& dWorld,
                TermRows& rows) const override
    {
        rows = t.positionWeight * dWorld.col(3);
    }
    TargetError error(const Eigen::Matrix4d& world, const PreparedTarget& t) const override
    {
        return {(world.block<3, 1>(0, 3) - t.position).stableNorm(), 0.0};
    }
};

}  // namespace

// The kinds, never removed (targets and structures point at them), the built-in ones first.
struct ResidualTermRegistry {
    ResidualTermRegistry()
    {
        kinds.push_back(std::make_unique<JointTargetTerm>());
        kinds.push_back(std::make_unique<PositionTerm>());
        for (std::size_t i = 0; i < kinds.size(); ++i) kinds[i]->index_ = static_cast<int>(i);
        joint = kinds[0].get();
        position = kinds[1].get();
    }
    std::mutex mutex;
    std::vector<std::unique_ptr<ResidualTerm>> kinds;
    const ResidualTerm* joint;  // read without the lock: set once, before any registration
    const ResidualTerm* position;
};

namespace {

ResidualTermRegistry& registry()
{
    // Never destroyed: a term may be used from other statics' destructors.
    static ResidualTermRegistry* made = new ResidualTermRegistry;
    return *made;
}

}  // namespace

const ResidualTerm& jointTargetTerm() { return *registry().joint; }

const ResidualTerm& positionTerm() { return *registry().position; }

void registerResidualTerm(std::unique_ptr<ResidualTerm> term)
{
    if (!term) throw internalError("registerResidualTerm: no term");
    if (term->rows() < 1 || term->rows() > maxTermRows)
        throw internalError(
            fmt::format("registerResidualTerm: {} has {} rows, not 1 to {}", term->name(), term->rows(), maxTermRows));
    ResidualTermRegistry& r = registry();
    std::lock_guard lock(r.mutex);
    for (const auto& kind : r.kinds)
        if (kind->name() == term->name())
            throw internalError(fmt::format("registerResidualTerm: a term named {} is registered", term->name()));
    if (r.kinds.size() >= static_cast<std::size_t>(maxResidualTerms))
        throw internalError(fmt::format("registerResidualTerm: more than {} kinds of term", maxResidualTerms));
    term->index_ = static_cast<int>(r.kinds.size());
    r.kinds.push_back(std::move(term));
}

std::vector<std::string> residualTermNames()
{
    ResidualTermRegistry& r = registry();
    std::lock_guard lock(r.mutex);
    std::vector<std::string> names;
    for (const auto& kind : r.kinds) names.emplace_back(kind->name());
    return names;
}

const ResidualTerm& residualTerm(std::string_view name)
{
    {
        ResidualTermRegistry& r = registry();
        std::lock_guard lock(r.mutex);
        for (const auto& kind : r.kinds)
            if (kind->name() == name) return *kind;
    }
    throw Error(
        fmt::format("unknown residual term '{}': use one of {}", oneLine(name), fmt::join(residualTermNames(), ", ")));
}

const ResidualTerm& termOf(const JointTarget& target) { return target.term ? *target.term : jointTargetTerm(); }

void setTerm(JointTarget& target, const ResidualTerm& term)
{
    target.term = &term;
    // Asked of a target that weighs both halves: whether the kind can count a rotation at all.
    if (!(term.counted(JointTarget{}) & rotationRows)) target.rotationWeight = 0.0;
}

unsigned char termRowsKey(const JointTarget& target)
{
    const ResidualTerm& term = termOf(target);
    const unsigned char counted = term.counted(target);
    if (counted == noRows) return noRows;
    return static_cast<unsigned char>(counted | (term.index() << 2));
}

const ResidualTerm& termOfKey(unsigned char key)
{
    const std::size_t index = static_cast<std::size_t>(key >> 2);
    ResidualTermRegistry& r = registry();
    std::lock_guard lock(r.mutex);
    if (index >= r.kinds.size()) throw internalError(fmt::format("termOfKey: no term of index {}", index));
    return *r.kinds[index];
}

}  // namespace rig
