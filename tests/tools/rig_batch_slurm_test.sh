#!/usr/bin/env bash
# rig-batch on a real Slurm (docs/cluster.md), run by CTest as batch.slurm: a private one-node cluster on
# this machine (scripts/slurm_localhost.sh installs slurm-wlm and munge when missing, and starts munged,
# slurmctld and slurmd from a generated slurm.conf), a batch of two bundled CMU clips submitted as an sbatch
# array, the merged curves checked byte for byte against rig-invert on the whole clips, a second run that
# submits nothing, and a shard that fails on Slurm, is retried, is listed in the report, and is solved by
# the next run. The daemons are stopped by their process ids on any exit.
# Usage: rig_batch_slurm_test.sh SOURCE_DIR BIN_DIR SCRATCH_DIR. Prints "[skipped] why" where it cannot run.
set -euo pipefail
src=$1
bin=$2
scratch=$3
cmu=/usr/share/assimp/models/BVH
if [ ! -f "$cmu/01_01.bvh" ] || [ ! -f "$cmu/01_03.bvh" ]; then
  echo "[skipped] $cmu/01_01.bvh and 01_03.bvh are not installed (Debian package assimp-testmodels)"
  exit 0
fi
fail() { echo "FAIL: $*" >&2; exit 1; }

cluster=$(mktemp -d /tmp/rig-slurm.XXXXXX)
trap '"$src/scripts/slurm_localhost.sh" stop "$cluster"; rm -rf "$cluster"' EXIT
started=0
"$src/scripts/slurm_localhost.sh" start "$cluster" || started=$?
[ $started -eq 77 ] && exit 0  # it printed "[skipped] why"
[ $started -eq 0 ] || fail "the private Slurm cluster did not start (exit code $started; logs in $cluster)"
export SLURM_CONF=$cluster/slurm.conf
rm -rf "$scratch"
mkdir -p "$scratch/clips"

"$bin/rig-learn" "$src/rigs/biped.yaml" --spec "$src/rigs/biped_inversion.yaml" -o "$scratch/biped.approx.yaml" \
  >/dev/null
# The clips' first frames: 01_01 (a walk) and 01_03, which turns round, so that its shards from frame 481 on
# are shifted by whole turns in the merge.
cut_clip() {  # BVH FRAMES OUT: the file with its first FRAMES motion lines
  awk -v n="$2" '/^Frames:/ { print "Frames: " n; next } /^Frame Time:/ { print; m = 1; next }
                 m { if (c++ < n) print; next } { print }' "$1" >"$3"
}
cut_clip "$cmu/01_01.bvh" 600 "$scratch/clips/walk.bvh"
cut_clip "$cmu/01_03.bvh" 720 "$scratch/clips/turn.bvh"
inputs=("$scratch/biped.approx.yaml" --rig "$src/rigs/biped.yaml" --map "$src/rigs/maps/cmu_to_biped.yaml")
batch() {  # OUT [FLAGS...]: rig-batch on Slurm over both clips, 240-frame shards, two tasks at once
  local out=$1
  shift
  timeout 90 "$bin/rig-batch" "${inputs[@]}" --clips "$scratch/clips" --out "$out" --backend slurm --jobs 2 \
    --shard-frames 240 -q "$@"
}
totals() {  # OUT KEY...: the report's totals
  python3 -c 'import json, sys
t = json.load(open(sys.argv[1] + "/report.json"))["totals"]
print(*(t[k] for k in sys.argv[2:]))' "$@"
}

# One batch: six array tasks (3 shards of 240 frames per clip); the curves are rig-invert's on the whole clip.
batch "$scratch/out" || fail "rig-batch --backend slurm exited with $?"
[ "$(totals "$scratch/out" shards_run shards_failed clips_complete)" = "6 0 2" ] ||
  fail "expected 6 shards run, none failed, 2 clips: $(totals "$scratch/out" shards_run shards_failed clips_complete)"
ls "$scratch"/out/logs/slurm-*_5.out >/dev/null || fail "no Slurm task output (logs/slurm-JOB_5.out)"
for clip in walk turn; do
  "$bin/rig-invert" "${inputs[@]}" --clip "$scratch/clips/$clip.bvh" -o "$scratch/$clip.json" -q
  cmp "$scratch/$clip.json" "$scratch/out/$clip.json" || fail "$clip: the merged curves differ from rig-invert's"
done
# The merge shifted turn's last shard: alone, rig-invert reports those frames otherwise.
"$bin/rig-invert" "${inputs[@]}" --clip "$scratch/clips/turn.bvh" --frames 481:720 -o "$scratch/alone.json" -q
python3 -c 'import json, sys
alone, whole = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))[480:]
sys.exit(0 if alone != whole else "turn frames 481:720 alone equal the whole clip: no shift was tested")' \
  "$scratch/alone.json" "$scratch/turn.json"
echo "slurm: 6 shards as an sbatch array; merged curves equal rig-invert's byte for byte"

# A second run finds every shard done and submits nothing.
rm -rf "$scratch/out/slurm"
batch "$scratch/out" || fail "the second run exited with $?"
[ "$(totals "$scratch/out" shards_reused shards_run)" = "6 0" ] || fail "the second run solved shards again"
[ ! -e "$scratch/out/slurm" ] || fail "the second run submitted a job"
cmp "$scratch/walk.json" "$scratch/out/walk.json" || fail "walk: the second run's curves differ"

# A shard whose output cannot be written (a folder in its place) fails on Slurm, is submitted again (round 1),
# fails again: exit code 3, the report lists it with the task's error line, its clip has no curves.
key=$(python3 -c 'import json, sys
print(json.load(open(sys.argv[1] + "/manifest.json"))["shards"][4]["key"])' "$scratch/out")
rm "$scratch/out/shards/$key.shard"
mkdir "$scratch/out/shards/$key.shard"
code=0
batch "$scratch/out" 2>"$scratch/failed.err" || code=$?
[ $code -eq 3 ] || fail "a failed shard gave exit code $code, not 3"
grep -q "^error: 1 of 6 shards failed (shard 4 (walk frames 241:480): error: .*is a folder" "$scratch/failed.err" ||
  fail "unexpected error line: $(cat "$scratch/failed.err")"
ls "$scratch"/out/slurm/round-1-0.sh >/dev/null || fail "the failed shard was not submitted again"
python3 -c 'import json, sys
r = json.load(open(sys.argv[1] + "/report.json"))
f = r["failed_shards"]
assert len(f) == 1 and f[0]["shard"] == 4 and "is a folder" in f[0]["error"], f
assert [c["complete"] for c in r["clips"]] == [True, False], r["clips"]' "$scratch/out"
[ ! -e "$scratch/out/walk.json" ] || fail "walk.json left in place for a clip with a failed shard"
rmdir "$scratch/out/shards/$key.shard"
batch "$scratch/out" || fail "the run after the failure exited with $?"
[ "$(totals "$scratch/out" shards_reused shards_run)" = "5 1" ] || fail "the rerun did not solve the one shard left"
cmp "$scratch/walk.json" "$scratch/out/walk.json" || fail "walk: the resumed curves differ from rig-invert's"
echo "slurm: a failed shard is retried, reported (exit code 3) and solved by the next run alone"
