#include "inversion/solve/partition.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include <fmt/format.h>
#include <Eigen/SVD>

#include "core/error.h"
#include "inversion/solve/jacobian.h"

namespace rig {
namespace {

struct Group {
    std::vector<int> parameters;
    std::vector<int> outputs;
};

class Partitioner {
public:
    Partitioner(const Approximation& approximation, std::span<const unsigned char> rows)
        : approximation_(approximation), rows_(rows)
    {
        const std::size_t parameterCount = approximation.parameters.size();
        const std::size_t outputCount = approximation.outputs.size();
        parametersOf_.resize(outputCount);
        outputsOf_.resize(parameterCount);
        for (std::size_t p = 0; p < parameterCount; ++p)
            for (const int k : approximation.parameters[p].outputs)
                if (k < 0 || static_cast<std::size_t>(k) >= outputCount)
                    throw internalError(fmt::format("partitionProblem: parameter {} names output {} of {}",
                                                    approximation.parameters[p].parameter.name, k, outputCount));
        // A parameter reaches the relative outputs below those it affects directly.
        const std::vector<std::vector<int>> reach = approximation.reach();
        for (std::size_t p = 0; p < parameterCount; ++p)
            for (const int k : reach[p]) {
                if (rows[static_cast<std::size_t>(k)] == noRows) continue;
                parametersOf_[static_cast<std::size_t>(k)].push_back(static_cast<int>(p));
                outputsOf_[p].push_back(k);
            }
        inP_.assign(parameterCount, 0);
        inT_.assign(parameterCount, 0);
        count_.assign(parameterCount, 0);
        inK_.assign(outputCount, 0);
        inR_.assign(outputCount, 0);
        remaining_.assign(outputCount, 0);
        uf_.assign(parameterCount, 0);
    }

    Partition run(PartitionSplit split)
    {
        split_ = split;
        Partition partition;
        Group all;
        for (std::size_t p = 0; p < outputsOf_.size(); ++p) {
            if (outputsOf_[p].empty()) partition.unreached.push_back(static_cast<int>(p));
            else all.parameters.push_back(static_cast<int>(p));
        }
        for (std::size_t k = 0; k < parametersOf_.size(); ++k) {
            if (rows_[k] == noRows) continue;
            if (parametersOf_[k].empty()) partition.fixedOutputs.push_back(static_cast<int>(k));
            else all.outputs.push_back(static_cast<int>(k));
        }
        partition_ = &partition;
        if (!all.parameters.empty()) {
            if (split != PartitionSplit::none) {
                for (Group& g : components(all.parameters, all.outputs)) splitGroup(std::move(g), -1);
            } else {
                addBlock(std::move(all), -1);
            }
        }
        for (std::size_t b = 0; b < partition.blocks.size(); ++b)
            if (partition.blocks[b].parent < 0) partition.roots.push_back(static_cast<int>(b));
        return partition;
    }

private:
    int addBlock(Group group, int parent)
    {
        PartitionBlock block;
        block.parameters = std::move(group.parameters);
        block.outputs = std::move(group.outputs);
        block.parent = parent;
        const int index = static_cast<int>(partition_->blocks.size());
        partition_->blocks.push_back(std::move(block));
        if (parent >= 0) partition_->blocks[static_cast<std::size_t>(parent)].children.push_back(index);
        return index;
    }

    int find(int p)
    {
        while (uf_[static_cast<std::size_t>(p)] != p) {
            uf_[static_cast<std::size_t>(p)] = uf_[static_cast<std::size_t>(uf_[static_cast<std::size_t>(p)])];
            p = uf_[static_cast<std::size_t>(p)];
        }
        return p;
    }

    // Connected components of the incidence between `parameters` and `outputs` (every output reaches
    // at least one of the parameters), ordered by their smallest parameter.
    std::vector<Group> components(const std::vector<int>& parameters, const std::vector<int>& outputs)
    {
        for (const int p : parameters) {
            uf_[static_cast<std::size_t>(p)] = p;
            inP_[static_cast<std::size_t>(p)] = 1;
        }
        for (const int k : outputs) {
            int first = -1;
            for (const int p : parametersOf_[static_cast<std::size_t>(k)]) {
                if (!inP_[static_cast<std::size_t>(p)]) continue;
                if (first < 0) {
                    first = find(p);
                    continue;
                }
                const int a = find(p);
                // The smaller index as the root keeps the grouping independent of visiting order.
                if (a != first) {
                    const int lo = std::min(a, first), hi = std::max(a, first);
                    uf_[static_cast<std::size_t>(hi)] = lo;
                    first = lo;
                }
            }
        }
        std::vector<Group> groups;
        std::vector<int> groupOfRoot(uf_.size(), -1);
        for (const int p : parameters) {  // increasing: groups come out ordered by smallest parameter
            const int root = find(p);
            int& g = groupOfRoot[static_cast<std::size_t>(root)];
            if (g < 0) {
                g = static_cast<int>(groups.size());
                groups.emplace_back();
            }
            groups[static_cast<std::size_t>(g)].parameters.push_back(p);
        }
        for (const int k : outputs) {
            for (const int p : parametersOf_[static_cast<std::size_t>(k)]) {
                if (!inP_[static_cast<std::size_t>(p)]) continue;
                groups[static_cast<std::size_t>(groupOfRoot[static_cast<std::size_t>(find(p))])].outputs.push_back(k);
                break;
            }
        }
        for (const int p : parameters) inP_[static_cast<std::size_t>(p)] = 0;
        return groups;
    }

    // Grows the outer set T output by output (the output needing the fewest parameters not yet in T)
    // until removing T leaves two or more independent groups; splits there (PartitionSplit::determined: if T's own
    // outputs determine it, else keeps the group as one block).
    void splitGroup(Group group, int parent)
    {
        const auto& P = group.parameters;
        const auto& K = group.outputs;
        for (const int p : P) inP_[static_cast<std::size_t>(p)] = 1;
        for (const int k : K) {
            inK_[static_cast<std::size_t>(k)] = 1;
            inR_[static_cast<std::size_t>(k)] = 1;
            int n = 0;
            for (const int p : parametersOf_[static_cast<std::size_t>(k)]) n += inP_[static_cast<std::size_t>(p)];
            remaining_[static_cast<std::size_t>(k)] = n;
        }
        for (const int p : P) {
            int n = 0;
            for (const int k : outputsOf_[static_cast<std::size_t>(p)]) n += inK_[static_cast<std::size_t>(k)];
            count_[static_cast<std::size_t>(p)] = n;
        }
        std::vector<int> T, KT;
        int remainingOutputs = static_cast<int>(K.size());
        std::vector<Group> inner;
        auto cleanUp = [&] {
            for (const int p : P) inP_[static_cast<std::size_t>(p)] = inT_[static_cast<std::size_t>(p)] = 0;
            for (const int k : K) inK_[static_cast<std::size_t>(k)] = inR_[static_cast<std::size_t>(k)] = 0;
        };
        while (true) {
            int next = -1;
            for (const int k : K)
                if (inR_[static_cast<std::size_t>(k)] &&
                    (next < 0 || remaining_[static_cast<std::size_t>(k)] < remaining_[static_cast<std::size_t>(next)]))
                    next = k;
            for (const int p : parametersOf_[static_cast<std::size_t>(next)]) {
                if (!inP_[static_cast<std::size_t>(p)] || inT_[static_cast<std::size_t>(p)]) continue;
                inT_[static_cast<std::size_t>(p)] = 1;
                T.push_back(p);
                for (const int k : outputsOf_[static_cast<std::size_t>(p)]) {
                    if (!inK_[static_cast<std::size_t>(k)]) continue;
                    if (--remaining_[static_cast<std::size_t>(k)] == 0 && inR_[static_cast<std::size_t>(k)]) {
                        inR_[static_cast<std::size_t>(k)] = 0;
                        KT.push_back(k);
                        --remainingOutputs;
                        for (const int q : parametersOf_[static_cast<std::size_t>(k)])
                            if (inP_[static_cast<std::size_t>(q)]) --count_[static_cast<std::size_t>(q)];
                    }
                }
            }
            if (remainingOutputs == 0) break;
            // A parameter outside T reaching every remaining output keeps them one group: no need to
            // look for components (down a chain this is every step).
            bool spanning = false;
            for (const int p : P)
                if (!inT_[static_cast<std::size_t>(p)] && count_[static_cast<std::size_t>(p)] == remainingOutputs) {
                    spanning = true;
                    break;
                }
            if (spanning) continue;
            std::vector<int> restP, restK;
            for (const int p : P)
                if (!inT_[static_cast<std::size_t>(p)]) restP.push_back(p);
            for (const int k : K)
                if (inR_[static_cast<std::size_t>(k)]) restK.push_back(k);
            for (const int p : P) inP_[static_cast<std::size_t>(p)] = 0;  // components() uses inP_
            std::vector<Group> groups = components(restP, restK);
            for (const int p : P) inP_[static_cast<std::size_t>(p)] = 1;
            if (groups.size() < 2) continue;
            // The first branching decides: growing T past it would tie the outer block to one branch
            // (a root fitted to the left arm), so an undetermined T keeps the group whole where T is solved first
            // and held. Solved together, the blocks' step is the whole problem's: T need not be determined by its
            // own outputs (a world control above a body control, C_Robot_Rig's and the spider's).
            std::sort(T.begin(), T.end());
            std::sort(KT.begin(), KT.end());
            if (split_ == PartitionSplit::branching || determined(T, KT)) inner = std::move(groups);
            break;
        }
        cleanUp();
        if (inner.empty()) {
            addBlock(std::move(group), parent);
            return;
        }
        const int outer = addBlock(Group{T, KT}, parent);
        for (Group& g : inner) splitGroup(std::move(g), outer);
    }

    // Whether the outputs KT (their counted rows) determine the parameters T: full column rank of the
    // Jacobian at one of three poses (rest and two pseudo-random ones within the limits).
    bool determined(const std::vector<int>& T, const std::vector<int>& KT)
    {
        if (KT.empty()) return false;
        const ResidualStructure structure(approximation_, T, KT);
        ResidualWorkspace workspace(structure);
        for (std::size_t o = 0; o < KT.size(); ++o) {
            const unsigned char r = rows_[static_cast<std::size_t>(KT[o])];
            PreparedTarget target;
            target.positionWeight = (r & positionRows) ? 1.0 : 0.0;
            target.rotationWeight = (r & rotationRows) ? 10.0 : 0.0;
            workspace.setTarget(static_cast<int>(o), target);
        }
        std::mt19937_64 rng(20200817);
        auto uniform = [&rng] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
        std::vector<double> values = approximation_.defaults();
        std::vector<double> x(T.size());
        Eigen::VectorXd r(structure.rows());
        Eigen::MatrixXd J(structure.rows(), structure.columnCount());
        for (int pose = 0; pose < 3; ++pose) {
            if (pose > 0) {
                for (std::size_t p = 0; p < values.size(); ++p) {
                    const RigParameter& param = approximation_.parameters[p].parameter;
                    const double lo = std::isfinite(param.min) ? param.min : param.defaultValue - 1.0;
                    const double hi = std::isfinite(param.max) ? param.max : param.defaultValue + 1.0;
                    values[p] = lo + (hi - lo) * uniform();
                }
            }
            workspace.holdParameters(values);
            for (std::size_t c = 0; c < T.size(); ++c) x[c] = values[static_cast<std::size_t>(T[c])];
            workspace.jacobian(x, JacobianMethod::analytic, 0.0, false, r, J);
            if (!J.allFinite()) continue;
            const Eigen::JacobiSVD<Eigen::MatrixXd> svd(J);
            const auto& s = svd.singularValues();
            if (s.size() == 0 || !(s[0] > 0)) continue;
            int rank = 0;
            for (Eigen::Index i = 0; i < s.size(); ++i) rank += s[i] > 1e-8 * s[0];
            if (rank == static_cast<int>(T.size())) return true;
        }
        return false;
    }

    const Approximation& approximation_;
    std::span<const unsigned char> rows_;
    std::vector<std::vector<int>> parametersOf_;  // counted outputs: the parameters reaching them
    std::vector<std::vector<int>> outputsOf_;     // parameters: the counted outputs they reach
    std::vector<char> inP_, inT_, inK_, inR_;
    std::vector<int> count_;      // parameter: remaining outputs it reaches
    std::vector<int> remaining_;  // output: its parameters not yet in T
    std::vector<int> uf_;
    Partition* partition_ = nullptr;
    PartitionSplit split_ = PartitionSplit::none;
};

void describeBlock(const Partition& partition, const Approximation& approximation, int b, int depth, std::string& out)
{
    const PartitionBlock& block = partition.blocks[static_cast<std::size_t>(b)];
    std::string names;
    for (std::size_t i = 0; i < block.outputs.size(); ++i) {
        if (i == 6) {
            names += fmt::format(", ... ({} in all)", block.outputs.size());
            break;
        }
        if (i > 0) names += ", ";
        names += approximation.outputs[static_cast<std::size_t>(block.outputs[i])].name;
    }
    out += fmt::format("{:{}}block {}: {} parameter{} -> {}\n", "", 2 * depth, b, block.parameters.size(),
                       block.parameters.size() == 1 ? "" : "s", names);
    for (const int c : block.children) describeBlock(partition, approximation, c, depth + 1, out);
}

}  // namespace

std::string Partition::describe(const Approximation& approximation) const
{
    std::string out;
    for (const int root : roots) describeBlock(*this, approximation, root, 0, out);
    if (!unreached.empty())
        out += fmt::format("{} parameter(s) reach no target and are not solved\n", unreached.size());
    return out;
}

Partition partitionProblem(const Approximation& approximation, std::span<const unsigned char> rows,
                           PartitionSplit split)
{
    if (rows.size() != approximation.outputs.size())
        throw internalError(
            fmt::format("partitionProblem: {} row flags for {} outputs", rows.size(), approximation.outputs.size()));
    return Partitioner(approximation, rows).run(split);
}

}  // namespace rig
