// Partitions: root then independent limbs when the root's own outputs determine it, one block when
// they do not, unreached parameters left out, and the block-triangular structure on the bundled rigs.
#include <doctest/doctest.h>

#include <set>

#include <fmt/format.h>

#include "inversion/solve/partition.h"
#include "inversion/solve/solver.h"
#include "inversion/solver_rigs.h"

using namespace rig;

namespace {

std::set<std::string> parameterNames(const Approximation& a, const PartitionBlock& b)
{
    std::set<std::string> names;
    for (const int p : b.parameters) names.insert(a.parameters[static_cast<std::size_t>(p)].parameter.name);
    return names;
}

std::set<std::string> outputNames(const Approximation& a, const PartitionBlock& b)
{
    std::set<std::string> names;
    for (const int k : b.outputs) names.insert(a.outputs[static_cast<std::size_t>(k)].name);
    return names;
}

std::vector<unsigned char> rowsWhere(const Approximation& a, auto predicate, unsigned char rows = allRows)
{
    std::vector<unsigned char> r(a.outputs.size());
    for (std::size_t k = 0; k < r.size(); ++k)
        r[k] = predicate(a.outputs[k].name) ? rows : static_cast<unsigned char>(noRows);
    return r;
}

// What makes the order valid: every parameter reaching a block's outputs is in the block or in one
// of its ancestors; every reached parameter is in exactly one block; each counted output in one block.
// `ownOutputs`: every block has outputs of its own (PartitionSplit::branching may leave an outer block none).
void checkStructure(const Approximation& a, const Partition& partition, std::span<const unsigned char> rows,
                    bool ownOutputs = true)
{
    std::vector<int> blockOf(a.parameters.size(), -1);
    for (std::size_t b = 0; b < partition.blocks.size(); ++b)
        for (const int p : partition.blocks[b].parameters) {
            CHECK(blockOf[static_cast<std::size_t>(p)] == -1);
            blockOf[static_cast<std::size_t>(p)] = static_cast<int>(b);
        }
    std::vector<int> outputBlock(a.outputs.size(), -1);
    for (std::size_t b = 0; b < partition.blocks.size(); ++b) {
        const PartitionBlock& block = partition.blocks[b];
        CHECK(block.parent < static_cast<int>(b));
        CHECK(!block.parameters.empty());
        CHECK((!block.outputs.empty() || !ownOutputs));
        for (const int k : block.outputs) {
            CHECK(outputBlock[static_cast<std::size_t>(k)] == -1);
            outputBlock[static_cast<std::size_t>(k)] = static_cast<int>(b);
        }
    }
    for (std::size_t p = 0; p < a.parameters.size(); ++p) {
        bool reaches = false;
        for (const int k : a.parameters[p].outputs) {
            if (rows[static_cast<std::size_t>(k)] == noRows) continue;
            reaches = true;
            // The parameter's block is the output's block or one of its ancestors.
            int b = outputBlock[static_cast<std::size_t>(k)];
            while (b >= 0 && b != blockOf[p]) b = partition.blocks[static_cast<std::size_t>(b)].parent;
            CAPTURE(a.parameters[p].parameter.name);
            CAPTURE(a.outputs[static_cast<std::size_t>(k)].name);
            CHECK(b == blockOf[p]);
        }
        CHECK(reaches == (blockOf[p] >= 0));
    }
    for (std::size_t k = 0; k < rows.size(); ++k) {
        if (rows[k] == noRows) continue;
        const bool fixed = std::find(partition.fixedOutputs.begin(), partition.fixedOutputs.end(),
                                     static_cast<int>(k)) != partition.fixedOutputs.end();
        CHECK((outputBlock[k] >= 0) != fixed);
    }
}

// An approximation from structure alone: parameter i translates along axis i % 3 the outputs listed.
Approximation translations(int outputs, const std::vector<std::vector<int>>& reaches)
{
    Approximation a;
    for (int k = 0; k < outputs; ++k) a.outputs.push_back({fmt::format("out{}", k), Eigen::Matrix4d::Identity()});
    for (std::size_t i = 0; i < reaches.size(); ++i) {
        ModelledParameter m;
        m.parameter = {fmt::format("p{}", i), 0.0, -10.0, 10.0, false};
        Operator op;
        op.kind = OperatorKind::translation;
        op.axis = Eigen::Vector3d::Unit(static_cast<Eigen::Index>(i % 3));
        op.slope = 1.0;
        m.operators.push_back(op);
        m.outputs = reaches[i];
        m.operatorOfOutput.assign(m.outputs.size(), 0);
        a.parameters.push_back(std::move(m));
    }
    return a;
}

}  // namespace

TEST_CASE("partition: two arms split into the root, then the left and the right arm")
{
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    const auto rows = rowsWhere(a, [](const std::string&) { return true; });
    const Partition p = partitionProblem(a, rows, PartitionSplit::determined);
    REQUIRE(p.blocks.size() == 3);
    CHECK(p.roots == std::vector<int>{0});
    CHECK(parameterNames(a, p.blocks[0]) ==
          std::set<std::string>{"root.translateX", "root.translateY", "root.translateZ", "root.rotateY"});
    CHECK(outputNames(a, p.blocks[0]) == std::set<std::string>{"hips"});
    CHECK(p.blocks[0].children == std::vector<int>{1, 2});
    for (int b : {1, 2}) {
        const std::string side = b == 1 ? "L_" : "R_";
        CHECK(p.blocks[static_cast<std::size_t>(b)].parent == 0);
        CHECK(parameterNames(a, p.blocks[static_cast<std::size_t>(b)]).size() == 5);
        for (const auto& name : parameterNames(a, p.blocks[static_cast<std::size_t>(b)])) CHECK(name.starts_with(side));
        CHECK(outputNames(a, p.blocks[static_cast<std::size_t>(b)]) ==
              std::set<std::string>{side + "shoulder", side + "elbow", side + "wrist", side + "hand"});
    }
    CHECK(p.unreached.empty());
    CHECK(p.fixedOutputs.empty());
    checkStructure(a, p, rows);
    CHECK(p.describe(a) ==
          "block 0: 4 parameters -> hips\n"
          "  block 1: 5 parameters -> L_shoulder, L_elbow, L_wrist, L_hand\n"
          "  block 2: 5 parameters -> R_shoulder, R_elbow, R_wrist, R_hand\n");
    // The whole solve when asked.
    const Partition whole = partitionProblem(a, rows, PartitionSplit::none);
    REQUIRE(whole.blocks.size() == 1);
    CHECK(whole.blocks[0].parameters.size() == 14);
    CHECK(whole.blocks[0].outputs.size() == 9);
    checkStructure(a, whole, rows);
}

TEST_CASE("partition: the root stays with the arms when its own outputs do not determine it")
{
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    SUBCASE("no target on the hips")
    {
        const auto rows = rowsWhere(a, [](const std::string& n) { return n != "hips"; });
        const Partition p = partitionProblem(a, rows, PartitionSplit::determined);
        REQUIRE(p.blocks.size() == 1);
        CHECK(p.blocks[0].parameters.size() == 14);
        checkStructure(a, p, rows);
    }
    SUBCASE(
        "the hips' rotation only: the root's translation is not determined by it (nor by one arm: no lopsided split)")
    {
        auto rows = rowsWhere(a, [](const std::string&) { return true; });
        rows[static_cast<std::size_t>(test::outputIndex(a, "hips"))] = rotationRows;
        const Partition p = partitionProblem(a, rows, PartitionSplit::determined);
        CHECK(p.blocks.size() == 1);
        checkStructure(a, p, rows);
    }
    SUBCASE("the hips' position only: the root's rotation is not determined by it")
    {
        auto rows = rowsWhere(a, [](const std::string&) { return true; });
        rows[static_cast<std::size_t>(test::outputIndex(a, "hips"))] = positionRows;
        const Partition p = partitionProblem(a, rows, PartitionSplit::determined);
        CHECK(p.blocks.size() == 1);
        checkStructure(a, p, rows);
    }
    SUBCASE("targets on the left arm only: the right arm's parameters are not solved")
    {
        const auto rows = rowsWhere(a, [](const std::string& n) { return n.starts_with("L_"); });
        const Partition p = partitionProblem(a, rows, PartitionSplit::determined);
        REQUIRE(p.blocks.size() == 1);
        CHECK(p.blocks[0].parameters.size() == 9);
        CHECK(p.unreached.size() == 5);
        for (const int u : p.unreached)
            CHECK(a.parameters[static_cast<std::size_t>(u)].parameter.name.starts_with("R_"));
        checkStructure(a, p, rows);
    }
    SUBCASE("no targets")
    {
        const auto rows = rowsWhere(a, [](const std::string&) { return false; });
        const Partition p = partitionProblem(a, rows, PartitionSplit::determined);
        CHECK(p.blocks.empty());
        CHECK(p.unreached.size() == 14);
    }
}

TEST_CASE("partition: solved together, the root splits from the arms whatever its own outputs determine")
{
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    auto hipsRotation = rowsWhere(a, [](const std::string&) { return true; });
    hipsRotation[static_cast<std::size_t>(test::outputIndex(a, "hips"))] = rotationRows;
    for (const auto& rows : {rowsWhere(a, [](const std::string& n) { return n != "hips"; }), hipsRotation}) {
        const Partition p = partitionProblem(a, rows, PartitionSplit::branching);
        REQUIRE(p.blocks.size() == 3);
        CHECK(p.blocks[0].children.size() == 2);
        checkStructure(a, p, rows, false);
        // With the hips' rotation, the root alone, then each arm below it; with no target on the hips, the outer set
        // grows from the first shoulder (4 root and 3 shoulder parameters) to the first branching.
        const bool hipsCounted = rows[static_cast<std::size_t>(test::outputIndex(a, "hips"))] != noRows;
        CHECK(p.blocks[0].parameters.size() == (hipsCounted ? 4 : 7));
        // Solved one after another, the root would be fitted on what does not determine it: one block.
        CHECK(partitionProblem(a, rows, PartitionSplit::determined).blocks.size() == 1);
    }
}

TEST_CASE("partition: independent groups, nested splits, outputs no parameter reaches")
{
    // p0..p2 move everything (a root); p3..p5 move out1, out2 and p6..p8 out3, out4 (two limbs);
    // p9 moves out2 only and p10 out4 only; out5 is moved by nothing; p11 moves out6 alone (a separate
    // group); p12 moves nothing counted.
    const Approximation a = translations(8, {{0, 1, 2, 3, 4},
                                             {0, 1, 2, 3, 4},
                                             {0, 1, 2, 3, 4},
                                             {1, 2},
                                             {1, 2},
                                             {1, 2},
                                             {3, 4},
                                             {3, 4},
                                             {3, 4},
                                             {2},
                                             {4},
                                             {6},
                                             {7}});
    std::vector<unsigned char> rows(8, positionRows);
    rows[7] = noRows;
    const Partition p = partitionProblem(a, rows, PartitionSplit::determined);
    checkStructure(a, p, rows);
    CHECK(p.fixedOutputs == std::vector<int>{5});
    CHECK(p.unreached == std::vector<int>{12});
    REQUIRE(p.roots.size() == 2);
    const PartitionBlock& root = p.blocks[static_cast<std::size_t>(p.roots[0])];
    CHECK(root.parameters == std::vector<int>{0, 1, 2});
    CHECK(root.outputs == std::vector<int>{0});
    CHECK(root.children.size() == 2);
    CHECK(p.blocks[static_cast<std::size_t>(p.roots[1])].parameters == std::vector<int>{11});
    // Each limb: its three parameters on its first output determine them, but nothing else hangs
    // there but one more output: the limb stays whole.
    for (const int c : root.children) CHECK(p.blocks[static_cast<std::size_t>(c)].parameters.size() == 4);
}

TEST_CASE("partition: a long chain stays one block, found without quadratic rescans")
{
    // 400 outputs down a chain, three parameters per joint moving everything below.
    constexpr int joints = 400;
    std::vector<std::vector<int>> reaches;
    for (int j = 0; j < joints; ++j)
        for (int axis = 0; axis < 3; ++axis) {
            std::vector<int> below;
            for (int k = j; k < joints; ++k) below.push_back(k);
            reaches.push_back(below);
        }
    const Approximation a = translations(joints, reaches);
    const std::vector<unsigned char> rows(joints, allRows);
    const Partition p = partitionProblem(a, rows, PartitionSplit::determined);
    REQUIRE(p.blocks.size() == 1);
    CHECK(p.blocks[0].parameters.size() == 3 * joints);
}

TEST_CASE("partition: bundled rigs are block-triangular, and the biped's root comes first, then legs and upper body")
{
    SUBCASE("rigs/biped.yaml")
    {
        test::GraphRig rig("rigs/biped.yaml", test::bipedInversionGlobs(), test::bipedCmuJoints());
        const Approximation a = test::learn(rig, "biped");
        const auto rows = rowsWhere(a, [](const std::string&) { return true; });
        const Partition p = partitionProblem(a, rows, PartitionSplit::determined);
        checkStructure(a, p, rows);
        REQUIRE(p.roots.size() == 1);
        const PartitionBlock& root = p.blocks[static_cast<std::size_t>(p.roots[0])];
        for (const auto& name : parameterNames(a, root)) CHECK(name.starts_with("root_ctrl."));
        CHECK(outputNames(a, root) == std::set<std::string>{"Hips"});
        CHECK(root.children.size() == 3);  // left leg, right leg, upper body
        // The spine block branches into the arms and the neck.
        int spine = -1;
        for (std::size_t b = 0; b < p.blocks.size(); ++b)
            if (outputNames(a, p.blocks[b]).contains("LowerBack")) spine = static_cast<int>(b);
        REQUIRE(spine >= 0);
        CHECK(p.blocks[static_cast<std::size_t>(spine)].parent == p.roots[0]);
        CHECK(p.blocks[static_cast<std::size_t>(spine)].children.size() == 3);
        CHECK(p.blocks.size() >= 6);
        // The Solver uses the same partition.
        std::vector<JointTarget> targets(a.outputs.size());
        for (auto& t : targets) t.active = true;
        CHECK(Solver(a, SolverOptions{}).partition(targets).blocks.size() == p.blocks.size());
    }
    SUBCASE("rigs/nasty.yaml")
    {
        test::GraphRig rig("rigs/nasty.yaml", test::nastyGlobs());
        const Approximation a = test::learn(rig, "nasty");
        const auto rows = rowsWhere(a, [](const std::string&) { return true; });
        const Partition p = partitionProblem(a, rows, PartitionSplit::determined);
        checkStructure(a, p, rows);
        // The root's translation first; every branch of the rig after it, on its own.
        REQUIRE(p.roots.size() == 1);
        CHECK(p.blocks[static_cast<std::size_t>(p.roots[0])].parameters.size() == 3);
        CHECK(p.blocks[static_cast<std::size_t>(p.roots[0])].children.size() >= 5);
    }
}
