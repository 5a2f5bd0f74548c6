#!/usr/bin/env bash
# rig-batch's figures for docs/cluster.md: the local backend's throughput with 1 and 2 processes, the Slurm
# path's overhead per task (on a private one-node cluster, scripts/slurm_localhost.sh: needs root), and a
# projection for a 10,000-clip library on 100 nodes from them. The library is COPIES copies of the bundled
# CMU clips 01_01 and 01_03 (2752 and 4511 frames) inverted on the biped.
# Usage: scripts/batch_figures.sh [COPIES]   (default 4; Release build in build/, or $RIG_BUILD_DIR)
# Writes $RIG_BUILD_DIR/batch_figures.json and prints the table docs/cluster.md shows.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${RIG_BUILD_DIR:-build}
bin=$build/bin
copies=${1:-4}
cmu=/usr/share/assimp/models/BVH
for f in "$bin/rig-batch" "$cmu/01_01.bvh" "$cmu/01_03.bvh"; do
  [ -e "$f" ] || { echo "batch_figures: $f is missing (build first; assimp-testmodels for the clips)" >&2; exit 2; }
done

work=$(mktemp -d /tmp/rig-batch-figures.XXXXXX)
chmod 711 "$work"  # munged wants every folder above its socket open to all
trap 'scripts/slurm_localhost.sh stop "$work/slurm"; rm -rf "$work"' EXIT
"$bin/rig-learn" rigs/biped.yaml --spec rigs/biped_inversion.yaml -o "$work/biped.approx.yaml" >/dev/null
mkdir "$work/clips"
for i in $(seq "$copies"); do
  for clip in 01_01 01_03; do ln -s "$cmu/$clip.bvh" "$work/clips/${clip}_$i.bvh"; done
done
batch() {  # NAME FLAGS...: one batch from scratch into $work/NAME
  local name=$1
  shift
  "$bin/rig-batch" "$work/biped.approx.yaml" --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml \
    --out "$work/$name" -q "$@"
}

echo "batch_figures: local backend, $((2 * copies)) clips" >&2
batch one --clips "$work/clips/01_01_1.bvh" --jobs 1
batch local1 --clips "$work/clips" --jobs 1
batch local2 --clips "$work/clips" --jobs 2
batch local2-small --clips "$work/clips" --jobs 2 --shard-frames 240
slurm=0
scripts/slurm_localhost.sh start "$work/slurm" >&2 || slurm=$?
if [ $slurm -eq 0 ]; then
  echo "batch_figures: Slurm backend" >&2
  export SLURM_CONF=$work/slurm/slurm.conf
  batch slurm2 --clips "$work/clips" --backend slurm --jobs 2
  batch slurm2-small --clips "$work/clips" --backend slurm --jobs 2 --shard-frames 240
fi

python3 - "$work" "$build/batch_figures.json" "$copies" <<'EOF'
import json, math, os, platform, subprocess, sys
work, out, copies = sys.argv[1], sys.argv[2], int(sys.argv[3])
def totals(name):
    path = os.path.join(work, name, "report.json")
    return json.load(open(path))["totals"] if os.path.exists(path) else None
one, local1, local2, small = totals("one"), totals("local1"), totals("local2"), totals("local2-small")
slurm2, slurm_small = totals("slurm2"), totals("slurm2-small")
slots = 2
frames = local1["frames"]
clips = local1["clips"]
# What a task costs beyond its frames on this machine (a process, the approximation and the rig loaded):
# the same frames in more, smaller shards, two at a time.
local_task = slots * (small["run_seconds"] - local2["run_seconds"]) / (small["shards"] - local2["shards"])
figures = {
    "machine": {"cpus": os.cpu_count(), "system": platform.platform(),
                "compiler": subprocess.run(["c++", "--version"], capture_output=True,
                                           text=True).stdout.splitlines()[0]},
    "library": {"clips": clips, "frames": frames, "copies": copies},
    "local": {
        "frames_per_second_1_process": local1["frames_per_second"],
        "frames_per_second_2_processes": local2["frames_per_second"],
        "shards": local2["shards"],
        "seconds_per_task_beyond_its_frames": local_task,
        # Planning loads the rig once, then reads and checks every clip: a batch of one clip gives the first.
        "plan_seconds_per_clip": (local2["plan_seconds"] - one["plan_seconds"]) / (clips - 1),
        "plan_seconds_once": one["plan_seconds"],
        "merge_seconds_per_frame": local2["merge_seconds"] / frames,
    },
}
if slurm2 and slurm_small:
    # Slurm's own cost per task: the same shards two at a time on Slurm and on the local backend.
    overhead = slots * (slurm_small["run_seconds"] - small["run_seconds"]) / small["shards"]
    figures["slurm"] = {
        "frames_per_second_2_tasks": slurm2["frames_per_second"],
        "frames_per_second_2_tasks_240_frame_shards": slurm_small["frames_per_second"],
        "shards_240_frames": slurm_small["shards"],
        "overhead_seconds_per_task": overhead,
    }
    # 10,000 clips of this library's mean length on 100 nodes with this machine's cores, one task per core
    # at a time: the frames at the 2-process rate per core, each task's costs, then the merge on one machine.
    library_clips, nodes = 10000, 100
    cores = nodes * os.cpu_count()
    library_frames = library_clips * frames / clips
    tasks = library_clips * local2["shards"] / clips
    per_core = local2["frames_per_second"] / slots
    solve = library_frames / (per_core * cores)
    queue = tasks * overhead / cores
    plan = one["plan_seconds"] + (library_clips - 1) * figures["local"]["plan_seconds_per_clip"]
    merge = library_frames * local2["merge_seconds"] / frames
    figures["projection"] = {
        "clips": library_clips, "nodes": nodes, "cores": cores, "frames": library_frames, "tasks": tasks,
        "solve_seconds": solve, "slurm_overhead_seconds": queue, "plan_seconds": plan, "merge_seconds": merge,
        "total_seconds": solve + queue + plan + merge,
        "one_core_seconds": library_frames / local1["frames_per_second"],
    }
json.dump(figures, open(out, "w"), indent=2)
l = figures["local"]
print(f"| local, 1 process | {l['frames_per_second_1_process']:.0f} frames/s |")
print(f"| local, 2 processes | {l['frames_per_second_2_processes']:.0f} frames/s |")
print("| a task beyond its frames (process, approximation and rig loaded) | "
      f"{l['seconds_per_task_beyond_its_frames']:.3f} s |")
print(f"| planning (every clip read and checked), per clip | {l['plan_seconds_per_clip'] * 1000:.1f} ms |")
print(f"| merging, per frame | {l['merge_seconds_per_frame'] * 1e6:.2f} us |")
if "slurm" in figures:
    s, p = figures["slurm"], figures["projection"]
    print(f"| Slurm, 2 tasks at once | {s['frames_per_second_2_tasks']:.0f} frames/s |")
    print(f"| Slurm's overhead per task | {s['overhead_seconds_per_task']:.2f} s |")
    minutes = {k: p[k] / 60 for k in ("total_seconds", "solve_seconds", "slurm_overhead_seconds", "plan_seconds",
                                      "merge_seconds")}
    print(f"| projection: {p['clips']} clips ({p['frames'] / 1e6:.1f} M frames, {p['tasks']:.0f} tasks) on "
          f"{p['nodes']} nodes ({p['cores']} cores) | {minutes['total_seconds']:.1f} min (solve "
          f"{minutes['solve_seconds']:.1f}, Slurm {minutes['slurm_overhead_seconds']:.1f}, plan "
          f"{minutes['plan_seconds']:.1f}, merge {minutes['merge_seconds']:.1f}); one core: "
          f"{p['one_core_seconds'] / 3600:.1f} h |")
else:
    print("| Slurm | not measured: the private cluster did not start (root needed) |")
EOF
