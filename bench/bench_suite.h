#pragma once
// rig-bench's measurements (issue 7, docs/performance.md): the biped against the talk's figures, and
// generated rigs for how each cost grows. Results are JSON (tools/bench_common.h).

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "bench/bench_characters.h"
#include "bench/bench_common.h"

namespace rig::bench {

struct BenchOptions {
    // Inputs, relative to the working folder (the source folder, as every tool's examples).
    std::filesystem::path rig = "rigs/biped.yaml";
    std::filesystem::path mayaFolder = "../shared/maya";       // the maya_load row's scenes (no row where absent)
    std::filesystem::path spec = "rigs/biped_inversion.yaml";  // params and outputs to invert
    std::filesystem::path longLegsRig = "rigs/biped_long_legs.yaml";  // the contacts row's other proportions
    std::filesystem::path longLegsMap = "rigs/maps/cmu_to_biped_long_legs.yaml";  // the clip retargeted onto it
    std::filesystem::path clip = "/usr/share/assimp/models/BVH/01_01.bvh";
    std::filesystem::path map = "rigs/maps/cmu_to_biped.yaml";
    // The look-at crowd's (crowd_realtime): the same scale, the head weighted (docs/crowds.md).
    std::filesystem::path crowdMap = "rigs/maps/cmu_to_biped_lookat.yaml";
    std::filesystem::path makeRigs = "scripts/make_rigs.py";
    std::string python = "python3";
    std::filesystem::path workDir;  // generated rigs are written here

    int frames = 2752;            // clip frames for our solver (capped by the clip)
    int ceresFrames = 600;        // for Ceres (each linear solver)
    int blackBoxFrames = 240;     // for Gauss-Newton on the real rig
    int coldStartPoses = 1000;    // random poses solved from rest, with and without the initial guess
    double timingBudget = 1.0;    // seconds per timed operation
    bool talkOrderer = true;      // also train with the talk's orderer
    std::vector<int> crowdSizes;  // bipeds per crowd rig (79 parameters each)
    std::vector<int> chainSizes;  // joints per chain rig (3 parameters each)
    int scalingFrames = 60;       // frames inverted per scaling row (after a cold first frame, not timed)
    bool scalingBlackBox = true;  // a black-box Jacobian per scaling row (serial graph evaluations)
    int realtimeFrames = 60;      // crowd_realtime: frames played per crowd (after an untimed first frame)
    int realtimeMaxAgents = 512;  // crowd_realtime: the largest crowd tried (0: no crowd_realtime row)
    bool mayaScenes = true;       // the maya_scenes row: the animated public scenes learned and inverted

    // The random_characters row (none: no row).
    CharactersBenchOptions characters;

    std::function<void(std::string_view)> log;  // one line per step; may be empty
};

BenchOptions quickOptions();  // under a minute on two cores
BenchOptions fullOptions();   // under ten minutes

// Jacobian, inversion, Ceres, training and accuracy on the biped: the objects "biped", "jacobian",
// "invert", "blackbox", "ceres", "cold_start", "train", "accuracy" and "contacts" are set in `report`.
void runBipedBench(const BenchOptions& options, Json& report);

// Generated rigs: "scaling" (one row per rig) and "growth" (fitted exponents) are set in `report`.
void runScaling(const BenchOptions& options, Json& report);

}  // namespace rig::bench
