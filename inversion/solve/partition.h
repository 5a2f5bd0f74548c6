#pragma once
// Splitting an inversion into blocks from the approximation's structure (docs/solver.md).
//
// Parameter p reaches output k when one of its operators acts on k. Restricted to the counted
// outputs (active targets with a weight above zero):
//  - parameters reaching none of them are not solved (they keep their values);
//  - independent groups (connected components of the parameter-output incidence) are separate blocks;
//  - within a group, the outer set T of parameters (a root, a spine: grown from the outputs that need
//    the fewest parameters until removing T first splits the rest into two or more independent groups,
//    left arm and right arm) becomes a block of its own, and the inner groups are split the same way.
// How the blocks are solved decides where a group splits (PartitionSplit): together, by block elimination (the
// default), a group splits at its first branching whatever T's own outputs say, since the step is the whole
// problem's; one after another, T solved first on the outputs only T reaches and then held, only where those outputs
// determine T (the Jacobian of T on them has full column rank at generic poses), else the group stays one block. On
// targets the rig reaches exactly, that block-triangular order gives the solution of the whole problem; on
// unreachable ones it fits the outer block first and leaves the remaining error to the inner blocks.

#include <span>
#include <string>
#include <vector>

#include "inversion/model/approximation.h"

namespace rig {

// Which residual rows of an output count (a weight above zero): bit flags.
enum TargetRows : unsigned char { noRows = 0, positionRows = 1, rotationRows = 2, allRows = 3 };

struct PartitionBlock {
    std::vector<int> parameters;  // solved in this block: indices into Approximation::parameters, increasing
    std::vector<int> outputs;     // the counted outputs only its parameters and its ancestors' move, increasing
                                  // (PartitionSplit::branching: an outer block may have none)
    int parent = -1;              // the block solved before it (its parameters also move these outputs); -1: none
    std::vector<int> children;    // solved after it, independent of each other
};

struct Partition {
    std::vector<PartitionBlock> blocks;  // every parent before its children
    std::vector<int> roots;              // blocks without a parent, independent of each other
    std::vector<int> unreached;          // parameters that reach no counted output: not solved
    std::vector<int> fixedOutputs;       // counted outputs no parameter reaches: their error is what it is

    // One line per block, indented under its parent: parameter count and output names.
    std::string describe(const Approximation& approximation) const;
};

// Where a group of parameters splits into an outer block and inner ones.
enum class PartitionSplit {
    none,        // one block holding every reached parameter and counted output (the whole solve)
    determined,  // only where the outer block's own outputs determine it (blocks solved one after another)
    branching,   // at its first branching (blocks solved together, by elimination)
};

// `rows`: one entry per Approximation::outputs (TargetRows flags; 0 for outputs without a target; bits above
// the flags, a residual term's kind as termRowsKey puts it, are not read).
// Deterministic: the same approximation, rows and split give the same partition.
Partition partitionProblem(const Approximation& approximation, std::span<const unsigned char> rows,
                           PartitionSplit split);

}  // namespace rig
