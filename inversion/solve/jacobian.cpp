#include "inversion/solve/jacobian.h"

#include "core/prefetch.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include <fmt/format.h>
#include <oneapi/tbb/parallel_for.h>
#include <Eigen/Dense>

#include "core/error.h"
#include "core/rotation_math.h"
#include "inversion/model/operators.h"

namespace rig {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;

// The rotation residual: 2 vec(q) for the unit quaternion q = (w, v) of Q_target^T Q, taken with w >= 0,
// so |r| = 2 sin(theta / 2). Its cost 2 sin^2(theta / 2) = 1 - cos(theta) is smooth everywhere and stationary
// only at theta = 0 (the minimum) and at half a turn (its maximum). The logarithm's cost theta^2 / 2 has
// the same minimum, but its derivative blows up at half a turn, where Gauss-Newton's steps shrink to
// nothing and a solve "converges" 180 degrees away.
struct HalfAngle {
    Eigen::Vector3d residual;  // 2 v
    Eigen::Matrix3d rows;      // d(2 v) / d omega for Q -> Q exp([omega]x): w I + [v]x
};

HalfAngle halfAngle(const Eigen::Matrix3d& q, const PreparedTarget& t)
{
    Eigen::Quaterniond e(t.rotation.transpose() * q);
    if (e.w() < 0) e.coeffs() = -e.coeffs();
    HalfAngle h;
    h.residual = 2.0 * e.vec();
    h.rows = e.w() * Eigen::Matrix3d::Identity() + skew(e.vec());
    return h;
}

Eigen::Vector3d rotationResidual(const Eigen::Matrix3d& q, const PreparedTarget& t)
{
    Eigen::Quaterniond e(t.rotation.transpose() * q);
    return 2.0 * (e.w() < 0 ? -e.vec() : Eigen::Vector3d(e.vec()));
}

// `rigid`: the world is known to be a rotation and a translation (no check, no polar decomposition).
Vector6d residual6(const Eigen::Matrix4d& world, const PreparedTarget& t, bool rigid = false)
{
    Vector6d r;
    r.head<3>() = t.positionWeight * (world.block<3, 1>(0, 3) - t.position);
    const Eigen::Matrix3d a = world.block<3, 3>(0, 0);
    r.tail<3>() = t.rotationWeight * rotationResidual(rigid || nearlyOrthonormal(a) ? a : polarRotation(a), t);
    return r;
}

using Affine = Eigen::Matrix<double, 3, 4>;

// a * b for 4x4 matrices whose last rows are 0 0 0 1, kept as their top three rows (b: any 3x4, such as a
// 4x4's top rows, read in place).
template <class B>
[[gnu::always_inline]] inline Affine compose(const Affine& a, const Eigen::MatrixBase<B>& b)
{
    Affine r;
    r.leftCols<3>().noalias() = a.leftCols<3>() * b.template leftCols<3>();
    r.col(3).noalias() = a.leftCols<3>() * b.col(3);
    r.col(3) += a.col(3);
    return r;
}

bool rigidKind(OperatorKind kind) { return operatorTraits(kind).rigid; }

// Below this determinant a linear part is taken as singular: its inverse would be meaningless.
constexpr double singularDeterminant = 1e-12;

// The step of the whole-evaluation differences that stand in for the suffix products where a product begins with
// a base (ResidualWorkspace::jacobianFromSuffixes).
constexpr double wholeDifferenceStep = 1e-6;

}  // namespace

bool prepareTarget(const JointTarget& target, double rotationScaleCm, PreparedTarget& prepared)
{
    if (!target.world.topRows<3>().allFinite()) return false;
    if (!std::isfinite(target.positionWeight) || !std::isfinite(target.rotationWeight)) return false;
    if (target.positionWeight < 0 || target.rotationWeight < 0) return false;
    const Eigen::Matrix3d a = target.world.block<3, 3>(0, 0);
    if (nearlyOrthonormal(a)) {
        prepared.rotation = a;
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
    const Eigen::Matrix3d q = nearlyOrthonormal(a) ? a : polarRotation(a);
    // stableNorm: a target 1e160 cm away is 1e160 cm away, not an overflow to infinity.
    return {(world.block<3, 1>(0, 3) - target.position).stableNorm(),
            rotationVector(target.rotation.transpose() * q).norm()};
}

// --- ResidualStructure ---

ResidualStructure::ResidualStructure(const Approximation& approximation, std::vector<int> columns,
                                     std::vector<int> outputs, std::span<const ResidualTerm* const> terms)
    : approximation_(&approximation), columns_(std::move(columns)), outputs_(std::move(outputs))
{
    const std::vector<std::vector<Link>> own = ownLinks(checkIndices());
    std::vector<Path> paths;
    for (const int k : outputs_) paths.push_back(pathOf(k, own));
    makeChains(paths);
    makeTree(paths, own);
    addBaseColumns();
    makePairs();
    attachTerms(terms);
}

std::vector<int> ResidualStructure::checkIndices() const
{
    const int parameterCount = static_cast<int>(approximation_->parameters.size());
    const int outputCount = static_cast<int>(approximation_->outputs.size());
    std::vector<int> columnOf(static_cast<std::size_t>(parameterCount), -1);
    for (std::size_t c = 0; c < columns_.size(); ++c) {
        const int p = columns_[c];
        if (p < 0 || p >= parameterCount || (c > 0 && p <= columns_[c - 1]))
            throw internalError("ResidualStructure: columns must be increasing parameter indices");
        columnOf[static_cast<std::size_t>(p)] = static_cast<int>(c);
    }
    for (std::size_t o = 0; o < outputs_.size(); ++o) {
        const int k = outputs_[o];
        if (k < 0 || k >= outputCount || (o > 0 && k <= outputs_[o - 1]))
            throw internalError("ResidualStructure: outputs must be increasing output indices");
    }
    return columnOf;
}

std::vector<std::vector<ResidualStructure::Link>> ResidualStructure::ownLinks(const std::vector<int>& columnOf)
{
    // Each output's own links, outermost first: walking the parameters in composition order.
    const Approximation& approximation = *approximation_;
    const int outputCount = static_cast<int>(approximation.outputs.size());
    std::vector<std::vector<Link>> own(static_cast<std::size_t>(outputCount));
    std::vector<std::vector<std::pair<int, int>>> slotOfColumnOp(columns_.size());  // (op, slot)
    for (int p = 0; p < static_cast<int>(approximation.parameters.size()); ++p) {
        const ModelledParameter& m = approximation.parameters[static_cast<std::size_t>(p)];
        for (std::size_t e = 0; e < m.outputs.size(); ++e) {
            const int k = m.outputs[e];
            if (k < 0 || k >= outputCount || e >= m.operatorOfOutput.size() || m.operatorOfOutput[e] < 0 ||
                m.operatorOfOutput[e] >= static_cast<int>(m.operators.size()))
                throw internalError(fmt::format(
                    "ResidualStructure: parameter {} has an inconsistent output or operator index", m.parameter.name));
            Link link{p, m.operatorOfOutput[e], columnOf[static_cast<std::size_t>(p)], -1};
            if (link.column >= 0) {
                auto& known = slotOfColumnOp[static_cast<std::size_t>(link.column)];
                for (const auto& [op, slot] : known)
                    if (op == link.op) link.slot = slot;
                if (link.slot < 0) {
                    link.slot = static_cast<int>(slots_.size());
                    const Operator& operation = m.operators[static_cast<std::size_t>(link.op)];
                    slots_.push_back(
                        {link.column, p, link.op, rigidKind(operation.kind), &operation, m.parameter.defaultValue});
                    known.emplace_back(link.op, link.slot);
                }
            }
            own[static_cast<std::size_t>(k)].push_back(link);
        }
    }
    return own;
}

ResidualStructure::Path ResidualStructure::pathOf(int k, const std::vector<std::vector<Link>>& own) const
{
    // An output's product is its ancestors' own links (relative outputs), root first, then its own; a constraint
    // output's begins with its base instead of its parent's.
    const std::size_t outputCount = approximation_->outputs.size();
    std::vector<int> up;
    Path path;
    for (int u = k; u >= 0;) {
        if (up.size() > outputCount) throw internalError("ResidualStructure: the outputs' parents form a cycle");
        up.push_back(u);
        const ApproximationOutput& output = approximation_->outputs[static_cast<std::size_t>(u)];
        if (output.constraint >= 0) {
            path.base = u;
            break;
        }
        u = output.parent;
    }
    for (auto it = up.rbegin(); it != up.rend(); ++it)
        path.links.insert(path.links.end(), own[static_cast<std::size_t>(*it)].begin(),
                          own[static_cast<std::size_t>(*it)].end());
    return path;
}

void ResidualStructure::makeChains(const std::vector<Path>& paths)
{
    // Flat chains serve finite differences and the suffix fallback; a product that begins with a base is
    // differenced whole instead (ResidualWorkspace::wholeDifferences), its chain holds its own links only.
    outputsOfColumn_.assign(columns_.size(), {});
    chains_.resize(outputs_.size());
    std::map<int, int> heldIndex;  // parameter -> index into heldParameters_
    for (std::size_t o = 0; o < outputs_.size(); ++o) {
        Chain& chain = chains_[o];
        chain.gaps.emplace_back();
        for (Link link : paths[o].links) {
            if (link.column < 0) {
                const auto [it, added] =
                    heldIndex.try_emplace(link.parameter, static_cast<int>(heldParameters_.size()));
                if (added) heldParameters_.push_back(link.parameter);
                link.held = it->second;
                chain.gaps.back().push_back(link);
                continue;
            }
            chain.varSlots.push_back(link.slot);
            chain.varColumns.push_back(link.column);
            chain.gaps.emplace_back();
            // A control spread over relative outputs appears once per output on the path.
            auto& moved = outputsOfColumn_[static_cast<std::size_t>(link.column)];
            if (moved.empty() || moved.back() != static_cast<int>(o)) moved.push_back(static_cast<int>(o));
        }
        maxVars_ = std::max(maxVars_, static_cast<int>(chain.varSlots.size()));
        constantCount_ += static_cast<int>(chain.gaps.size());
    }
    columnsOfOutput_.assign(outputs_.size(), {});
    for (std::size_t c = 0; c < outputsOfColumn_.size(); ++c)
        for (const int o : outputsOfColumn_[c])
            columnsOfOutput_[static_cast<std::size_t>(o)].push_back(static_cast<int>(c));
}

void ResidualStructure::makeTree(const std::vector<Path>& paths, const std::vector<std::vector<Link>>& own)
{
    // The prefix tree: an output's path is its links; equal beginnings share nodes. A constraint's base is a root
    // node, made once, after the nodes of its inputs' paths.
    const Approximation& approximation = *approximation_;
    std::map<std::tuple<int, int, int, int>, int> nodeOf;  // parent, slot, parameter, op
    auto child = [&](int parent, const Link& link) {
        const int parameter = link.column >= 0 ? -1 : link.parameter;
        const int op = link.column >= 0 ? -1 : link.op;
        const auto [it, added] =
            nodeOf.try_emplace({parent, link.slot, parameter, op}, static_cast<int>(nodes_.size()));
        if (added) {
            Node node;
            node.parent = parent;
            node.slot = link.slot;
            node.parameter = parameter;
            node.op = op;
            const Node* up = parent < 0 ? nullptr : &nodes_[static_cast<std::size_t>(parent)];
            node.rigid =
                (!up || up->rigid) && rigidKind(approximation.parameters[static_cast<std::size_t>(link.parameter)]
                                                    .operators[static_cast<std::size_t>(link.op)]
                                                    .kind);
            node.constant = (!up || up->constant) && link.column < 0;
            nodes_.push_back(node);
        }
        return it->second;
    };
    const auto baseNode = [&](const auto& self, int output) -> int {
        if (const auto known = baseOfOutput_.find(output); known != baseOfOutput_.end())
            return bases_[static_cast<std::size_t>(known->second)].node;
        const int constraint = approximation.outputs[static_cast<std::size_t>(output)].constraint;
        const ConstraintBase& c = approximation.constraints[static_cast<std::size_t>(constraint)];
        std::array<int, 5> inputNodes{-1, -1, -1, -1, -1};
        const std::array<int, 5> inputs = c.frameInputs();
        for (std::size_t i = 0; i < inputs.size(); ++i) {
            if (inputs[i] < 0) continue;
            const Path path = pathOf(inputs[i], own);
            int node = path.base >= 0 ? self(self, path.base) : -1;
            for (const Link& link : path.links) node = child(node, link);
            inputNodes[i] = node;
        }
        Base base = makeBase(constraint, inputNodes);
        base.node = static_cast<int>(nodes_.size());
        base.restInverse = approximation.outputs[static_cast<std::size_t>(output)].rest.inverse();
        Node node;
        node.base = static_cast<int>(bases_.size());
        // A chain's: a rigid frame times a sampled rigid motion; a blend's blended stretch need not be rigid.
        node.rigid = c.kind != ConstraintKind::blend;
        nodes_.push_back(node);
        baseTerms(base, inputNodes);
        baseOfOutput_[output] = static_cast<int>(bases_.size());
        bases_.push_back(std::move(base));
        return bases_.back().node;
    };
    outputNode_.assign(outputs_.size(), -1);
    outputRigid_.assign(outputs_.size(), 0);
    outputVars_.assign(outputs_.size(), {});
    outputBase_.assign(outputs_.size(), -1);
    for (std::size_t o = 0; o < outputs_.size(); ++o) {
        int node = -1;
        if (paths[o].base >= 0) {
            node = baseNode(baseNode, paths[o].base);
            outputBase_[o] = nodes_[static_cast<std::size_t>(node)].base;
        }
        for (const Link& link : paths[o].links) {
            node = child(node, link);
            if (link.column >= 0) outputVars_[o].push_back(node);
        }
        outputNode_[o] = node;
        const Eigen::Matrix4d& rest = approximation.outputs[static_cast<std::size_t>(outputs_[o])].rest;
        outputRigid_[o] =
            (node < 0 || nodes_[static_cast<std::size_t>(node)].rigid) && nearlyOrthonormal(rest.block<3, 3>(0, 0));
    }
}

ResidualStructure::Base ResidualStructure::makeBase(int constraint, const std::array<int, 5>& inputNodes) const
{
    const ConstraintBase& c = approximation_->constraints[static_cast<std::size_t>(constraint)];
    const auto restOrigin = [&](int k) -> Eigen::Vector3d {
        if (k < 0) return Eigen::Vector3d::Zero();
        return approximation_->outputs[static_cast<std::size_t>(k)].rest.block<3, 1>(0, 3);
    };
    Base base;
    base.constraint = constraint;
    base.anchorNode = inputNodes[0];
    base.goalNode = inputNodes[1];
    base.poleNode = inputNodes[2];
    base.orientNode = c.kind == ConstraintKind::planarChain ? inputNodes[3] : -1;
    base.goalRest = restOrigin(c.goal);
    base.poleRest = restOrigin(c.pole);
    const auto rest = [&](int k) -> Eigen::Matrix4d {
        return k < 0 ? Eigen::Matrix4d(Eigen::Matrix4d::Identity())
                     : approximation_->outputs[static_cast<std::size_t>(k)].rest;
    };
    base.secondRest = rest(c.driver);
    base.thirdRest = rest(c.driverParent);
    base.frameRest.fill(Eigen::Matrix4d::Identity());
    if (c.kind != ConstraintKind::blend) return base;
    const std::array<int, 5> inputs = c.frameInputs();
    for (std::size_t i = 0; i < inputs.size(); ++i) {
        base.frameNodes[i] = inputNodes[i];
        base.frameRest[i] = rest(inputs[i]);
    }
    // The weight is a column of its own, or held (its value read by holdParameters).
    if (const auto w = std::lower_bound(columns_.begin(), columns_.end(), c.weight);
        w != columns_.end() && *w == c.weight)
        base.weightColumn = static_cast<int>(w - columns_.begin());
    return base;
}

void ResidualStructure::baseTerms(Base& base, const std::array<int, 5>& inputNodes)
{
    // Every velocity that moves an input, by column: the unknown nodes up its path, and the base its path
    // begins with (whose columns' velocities come before this one's); a blend's weight column moves it directly.
    std::vector<std::pair<int, InputTerm>> found;  // (column, term)
    if (base.weightColumn >= 0) found.push_back({base.weightColumn, InputTerm{blendWeightInput, -1, -1}});
    for (std::size_t i = 0; i < inputNodes.size(); ++i)
        for (int m = inputNodes[i]; m >= 0; m = nodes_[static_cast<std::size_t>(m)].parent) {
            const Node& node = nodes_[static_cast<std::size_t>(m)];
            const int input = static_cast<int>(i);
            if (node.slot >= 0)
                found.push_back({slots_[static_cast<std::size_t>(node.slot)].column, InputTerm{input, m, -1}});
            if (node.base < 0) continue;
            const Base& up = bases_[static_cast<std::size_t>(node.base)];
            for (std::size_t j = 0; j < up.columns.size(); ++j)
                found.push_back({up.columns[j], InputTerm{input, -1, up.velocityOffset + static_cast<int>(j)}});
        }
    std::stable_sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    base.velocityOffset = baseVelocities_;
    for (const auto& [column, term] : found) {
        if (base.columns.empty() || base.columns.back() != column) {
            base.columns.push_back(column);
            base.termBegin.push_back(static_cast<int>(inputTerms_.size()));
        }
        inputTerms_.push_back(term);
    }
    base.termBegin.push_back(static_cast<int>(inputTerms_.size()));
    baseVelocities_ += static_cast<int>(base.columns.size());
}

void ResidualStructure::addBaseColumns()
{
    // A product that begins with a base moves with every column that moves the base's inputs.
    if (bases_.empty()) return;
    for (std::size_t o = 0; o < outputs_.size(); ++o) {
        if (outputBase_[o] < 0) continue;
        for (const int c : bases_[static_cast<std::size_t>(outputBase_[o])].columns)
            outputsOfColumn_[static_cast<std::size_t>(c)].push_back(static_cast<int>(o));
    }
    columnsOfOutput_.assign(outputs_.size(), {});
    for (std::size_t c = 0; c < outputsOfColumn_.size(); ++c) {
        auto& moved = outputsOfColumn_[c];
        std::sort(moved.begin(), moved.end());
        moved.erase(std::unique(moved.begin(), moved.end()), moved.end());
        for (const int o : moved) columnsOfOutput_[static_cast<std::size_t>(o)].push_back(static_cast<int>(c));
    }
}

void ResidualStructure::makePairs()
{
    unknownUp_.assign(nodes_.size(), -1);
    twistForm_ = true;
    for (std::size_t n = 0; n < nodes_.size(); ++n) {
        const Node& node = nodes_[n];
        if (node.parent >= 0) {
            const std::size_t parent = static_cast<std::size_t>(node.parent);
            unknownUp_[n] = nodes_[parent].slot >= 0 ? node.parent : unknownUp_[parent];
        }
        if (node.slot < 0) continue;
        unknownNodes_.push_back(static_cast<int>(n));
        twistForm_ = twistForm_ && node.rigid;
    }
    const int n = columnCount();
    const auto columnOfNode = [&](int node) {
        return slots_[static_cast<std::size_t>(nodes_[static_cast<std::size_t>(node)].slot)].column;
    };
    for (const int node : unknownNodes_) {
        const int c = columnOfNode(node);
        unknownColumn_.push_back(c);
        pairBegin_.push_back(static_cast<int>(pairNode_.size()));
        for (int m = node; m >= 0; m = unknownUp_[static_cast<std::size_t>(m)]) {
            const int a = columnOfNode(m);
            pairNode_.push_back(m);
            pairOffset_.push_back(std::min(a, c) * n + std::max(a, c));
            pairFactor_.push_back(m != node && a == c ? 2.0 : 1.0);
        }
    }
    pairBegin_.push_back(static_cast<int>(pairNode_.size()));
    outputDeepest_.assign(outputs_.size(), -1);
    for (std::size_t o = 0; o < outputs_.size(); ++o) {
        if (!outputVars_[o].empty()) outputDeepest_[o] = outputVars_[o].back();
        if (!outputVars_[o].empty() || outputBase_[o] >= 0) twistForm_ = twistForm_ && outputRigid_[o];
    }
    basePairs();
    // A planar chain's base is rigid and its velocity per column a twist (its inputs' rigid motions through the
    // chain): the normal equations still come from twists, the base's columns against what lies below it. The
    // fold of a BlockElimination (twistForm) needs each column's motion at one node, which a base's are not.
    twistNormals_ = twistForm_;
    for (const Base& base : bases_)
        twistNormals_ = twistNormals_ && approximation_->constraints[static_cast<std::size_t>(base.constraint)].kind ==
                                             ConstraintKind::planarChain;
    twistForm_ = twistNormals_ && bases_.empty();
}

void ResidualStructure::basePairs()
{
    // Per base, the unknown nodes below it: a product that begins with the base moves with them and with its columns.
    std::vector<int> baseOf(nodes_.size(), -1);
    for (std::size_t n = 0; n < nodes_.size(); ++n) {
        const Node& node = nodes_[n];
        baseOf[n] = node.base >= 0 ? node.base : node.parent >= 0 ? baseOf[static_cast<std::size_t>(node.parent)] : -1;
    }
    std::vector<std::vector<int>> below(bases_.size());
    for (const int n : unknownNodes_)
        if (const int b = baseOf[static_cast<std::size_t>(n)]; b >= 0) below[static_cast<std::size_t>(b)].push_back(n);
    baseUnknownBegin_.assign(1, 0);
    baseUnknown_.clear();
    for (const auto& nodes : below) {
        baseUnknown_.insert(baseUnknown_.end(), nodes.begin(), nodes.end());
        baseUnknownBegin_.push_back(static_cast<int>(baseUnknown_.size()));
    }
}

void ResidualStructure::attachTerms(std::span<const ResidualTerm* const> terms)
{
    if (!terms.empty() && terms.size() != approximation_->outputs.size())
        throw internalError(
            fmt::format("ResidualStructure: {} terms for {} outputs", terms.size(), approximation_->outputs.size()));
    const ResidualTerm* joint = &jointTargetTerm();
    rowOffset_.assign(1, 0);
    for (const int k : outputs_) {
        const ResidualTerm* term = terms.empty() ? nullptr : terms[static_cast<std::size_t>(k)];
        if (!term) term = joint;
        terms_.push_back(term);
        jointTargetsOnly_ = jointTargetsOnly_ && term == joint;
        jointTarget_.push_back(term == joint);
        rowOffset_.push_back(rowOffset_.back() + term->rows());
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
    held_.assign(s.heldParameters_.size(), 0.0);
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
    for (std::size_t i = 0; i < s.heldParameters_.size(); ++i)
        held_[i] = values[static_cast<std::size_t>(s.heldParameters_[i])];
    for (std::size_t b = 0; b < s.bases_.size(); ++b)
        if (const ConstraintBase& c = approx.constraints[static_cast<std::size_t>(s.bases_[b].constraint)];
            c.kind == ConstraintKind::blend && s.bases_[b].weightColumn < 0)
            blends_[b].weight = values[static_cast<std::size_t>(c.weight)];
    chainsHeld_ = false;
    for (std::size_t n = 0; n < s.nodes_.size(); ++n) {
        const auto& node = s.nodes_[n];
        if (node.slot >= 0 || node.base >= 0) continue;
        const ModelledParameter& m = approx.parameters[static_cast<std::size_t>(node.parameter)];
        heldMatrix_[n] = m.operators[static_cast<std::size_t>(node.op)].affineRows(
            values[static_cast<std::size_t>(node.parameter)] - m.parameter.defaultValue);
        if (node.constant)
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
    // An input's product is its node's (the identity without one): points move with it.
    const auto moved = [&](int node, const Eigen::Vector3d& p) -> Eigen::Vector3d {
        if (node < 0) return p;
        const Affine& m = nodeMatrix_[static_cast<std::size_t>(node)];
        return m.leftCols<3>() * p + m.col(3);
    };
    ChainPoints& points = basePoints_[b];
    points.root = moved(base.anchorNode, c.root);
    points.goal = moved(base.goalNode, base.goalRest);
    points.pole = c.pole >= 0 ? moved(base.poleNode, base.poleRest)
                  : c.worldUp ? Eigen::Vector3d(points.root + c.restPole - c.root)
                              : moved(base.anchorNode, c.restPole);
    points.normal =
        base.anchorNode < 0
            ? c.restNormal
            : Eigen::Vector3d(nodeMatrix_[static_cast<std::size_t>(base.anchorNode)].leftCols<3>() * c.restNormal);
    const Eigen::Matrix4d chain = constraintBase(c, points);
    if (c.orient < 0) return chain.topRows<3>();
    Eigen::Matrix4d orient = Eigen::Matrix4d::Identity();
    if (base.orientNode >= 0) orient.topRows<3>() = nodeMatrix_[static_cast<std::size_t>(base.orientNode)];
    baseCentres_[b] = chain.block<3, 3>(0, 0) * c.origin + chain.block<3, 1>(0, 3);
    return orientedBase(c, chain, orient).topRows<3>();
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

void ResidualWorkspace::baseVelocities()
{
    // Per base and column: each input's velocity (the sum of what moves it), its points' rates, then the base's.
    const auto& s = *structure_;
    for (std::size_t b = 0; b < s.bases_.size(); ++b) {
        const ResidualStructure::Base& base = s.bases_[b];
        const ConstraintBase& c = s.approximation_->constraints[static_cast<std::size_t>(base.constraint)];
        const ChainPoints& points = basePoints_[b];
        const bool twist = c.kind == ConstraintKind::twistShare, blend = c.kind == ConstraintKind::blend;
        const BaseLinearization at = twist || blend ? BaseLinearization{} : linearizeBase(c, points);
        for (std::size_t j = 0; j < base.columns.size(); ++j) {
            std::array<Affine, 5> x;
            x.fill(Affine::Zero());
            double dw = 0.0;
            for (int t = base.termBegin[j]; t < base.termBegin[j + 1]; ++t) {
                const ResidualStructure::InputTerm& term = s.inputTerms_[static_cast<std::size_t>(t)];
                if (term.input == ResidualStructure::blendWeightInput) {
                    dw = 1.0;
                    continue;
                }
                x[static_cast<std::size_t>(term.input)] +=
                    term.node >= 0 ? velocity_[static_cast<std::size_t>(term.node)]
                                   : baseVelocity_[static_cast<std::size_t>(term.baseVelocity)];
            }
            if (blend) {
                baseVelocity_[static_cast<std::size_t>(base.velocityOffset) + j] = blendVelocity(b, x, dw);
                continue;
            }
            if (twist) {
                baseVelocity_[static_cast<std::size_t>(base.velocityOffset) + j] =
                    twistVelocity(baseTwists_[b], x[0], x[1], x[2]);
                continue;
            }
            const auto rate = [](const Affine& v, const Eigen::Vector3d& p) -> Eigen::Vector3d {
                return v.leftCols<3>() * p + v.col(3);
            };
            // A world up moves with the root only; a fixed pole with the anchor.
            const Eigen::Vector3d poleRate = c.pole >= 0 ? rate(x[2], points.pole)
                                             : c.worldUp ? rate(x[0], points.root)
                                                         : rate(x[0], points.pole);
            const ChainPoints rates{rate(x[0], points.root), rate(x[1], points.goal), poleRate,
                                    x[0].leftCols<3>() * points.normal};
            const Affine chain = baseVelocity(at, rates);
            baseVelocity_[static_cast<std::size_t>(base.velocityOffset) + j] =
                c.orient < 0 ? chain : orientedVelocity(chain, x[3], baseCentres_[b]);
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
        // A rigid world is its own rotation: its quaternion is kept for the normal equations' rows.
        const PreparedTarget& t = targets_[o];
        rows.head<3>() = t.positionWeight * (worlds_[o].block<3, 1>(0, 3) - t.position);
        Eigen::Quaterniond& e = quaternion_[o];
        e = Eigen::Quaterniond(t.rotation.transpose() * worlds_[o].block<3, 3>(0, 0));
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
            q = a;
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
    for (auto* v :
         {&basePairFirst_, &basePairSecond_, &basePairTarget_, &baseNodeVelocity_, &baseNodeNode_, &baseNodeTarget_})
        v->clear();
    baseNodeFactor_.clear();
    for (std::size_t b = 0; b < s.bases_.size() && s.twistNormals_; ++b) {
        const ResidualStructure::Base& base = s.bases_[b];
        for (std::size_t j = 0; j < base.columns.size(); ++j) {
            const int vj = base.velocityOffset + static_cast<int>(j);
            for (std::size_t i = 0; i <= j; ++i) {
                basePairFirst_.push_back(base.velocityOffset + static_cast<int>(i));
                basePairSecond_.push_back(vj);
                basePairTarget_.push_back(target(base.columns[i], base.columns[j]));
            }
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
        for (int p = basePairBegin_[b]; p < basePairBegin_[b + 1]; ++p) {
            const std::size_t q = static_cast<std::size_t>(p);
            entries[basePairTarget_[q]] += baseTwist_[static_cast<std::size_t>(basePairFirst_[q])].dot(
                baseWeighted_[static_cast<std::size_t>(basePairSecond_[q])]);
        }
        for (int p = baseNodeBegin_[b]; p < baseNodeBegin_[b + 1]; ++p) {
            const std::size_t q = static_cast<std::size_t>(p);
            entries[baseNodeTarget_[q]] +=
                baseNodeFactor_[q] * baseTwist_[static_cast<std::size_t>(baseNodeVelocity_[q])].dot(
                                         weighted_[static_cast<std::size_t>(baseNodeNode_[q])]);
        }
    }
}

void ResidualWorkspace::baseTwistVelocities()
{
    // An unknown node's velocity Xi = [[omega]x, v] from its twist; the bases' through their chains' points.
    const auto& s = *structure_;
    for (const int n : s.unknownNodes_) {
        const Vector6d& t = twist_[static_cast<std::size_t>(n)];
        Affine& xi = velocity_[static_cast<std::size_t>(n)];
        xi.leftCols<3>() = skew(t.head<3>());
        xi.col(3) = t.tail<3>();
    }
    baseVelocities();
    for (std::size_t v = 0; v < baseVelocity_.size(); ++v) {
        const Affine& xi = baseVelocity_[v];
        baseTwist_[v] << 0.5 * (xi(2, 1) - xi(1, 2)), 0.5 * (xi(0, 2) - xi(2, 0)), 0.5 * (xi(1, 0) - xi(0, 1)),
            xi.col(3);
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
        q = a;
        kInverse = 0.5 * Eigen::Matrix3d::Identity();
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
    jacobian.setZero();
    if (method == JacobianMethod::analytic) {
        evaluateSlots(x, true);
        evaluateTree();
        residualRows(r);
        if (velocities()) {
            treeJacobian(jacobian);
            return;
        }
        // A singular operator or product has no inverse: the prefix and suffix products need none.
        jacobianFromSuffixes(x, r, jacobian);
        return;
    }
    if (s.hasBases()) {
        wholeDifferences(x, finiteDifferenceStep, r, jacobian);
        return;
    }
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
