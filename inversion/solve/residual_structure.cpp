#include "inversion/solve/jacobian.h"

#include <algorithm>
#include <map>
#include <tuple>

#include <fmt/format.h>
#include <Eigen/Dense>

#include "core/error.h"
#include "core/rotation_math.h"
#include "inversion/model/operators.h"

// The structure of a sub-problem (jacobian.h, ResidualStructure): the tree of the outputs' operator products, the
// bases their products begin with, and which columns meet in J^T J, built once and shared by every solve.

namespace rig {
namespace {

bool rigidKind(OperatorKind kind) { return operatorTraits(kind).rigid; }

}  // namespace

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
    base.orientNode = c.kind == ConstraintKind::planarChain || c.kind == ConstraintKind::oriented ? inputNodes[3] : -1;
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

}  // namespace rig
