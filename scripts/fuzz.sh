#!/usr/bin/env bash
# Fuzzes the rig loader, the BVH reader, the approximation loader, the target clip and map reader, the Maya .anim
# reader and the command lines with libFuzzer (clang, AddressSanitizer, UBSan).
# Usage: scripts/fuzz.sh [SECONDS]   (per target, default 60)
#   Configures and builds build-fuzz/ (clang++, RIG_FUZZ=ON; $RIG_FUZZ_BUILD_DIR for another folder, $RIG_JOBS
#   parallel compile jobs, default 1), seeds each fuzzer with the bad-input corpus and good inputs (the
#   bundled rigs, BVH files and maps, an approximation learned from rigs/examples/arm.yaml), runs it for
#   SECONDS, and exits non-zero if any target crashed, hung (10 s for one input),
#   or went past 2 GB. A crash leaves its input as build-fuzz/fuzz-crashes/TARGET-crash-*: reproduce it
#   with build-fuzz/bin/TARGET_fuzzer FILE, then add it to tests/corpus (docs/robustness.md).
#   New interesting inputs accumulate in build-fuzz/fuzz-corpus/TARGET/ and seed the next run.
set -euo pipefail
cd "$(dirname "$0")/.."

seconds=${1:-60}
build=${RIG_FUZZ_BUILD_DIR:-build-fuzz}
jobs=${RIG_JOBS:-1}

# libFuzzer comes with clang's runtime libraries: installed when missing, as scripts/setup.sh installs the rest
# (python3-yaml reads the corpus cases into command-line seeds).
if ! command -v clang++ >/dev/null || ! dpkg -s libclang-rt-14-dev python3-yaml >/dev/null 2>&1; then
  sudo=()
  [ "$(id -u)" -eq 0 ] || sudo=(sudo)
  echo "fuzz: installing clang, libclang-rt-14-dev (libFuzzer) and python3-yaml" >&2
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends clang libclang-rt-14-dev \
    python3-yaml >/dev/null
fi
if [ ! -f "$build/build.ninja" ]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ -DRIG_FUZZ=ON \
    >/dev/null
fi
if ! cmake --build "$build" --target rig_loader_fuzzer maya_loader_fuzzer bvh_reader_fuzzer \
    approximation_loader_fuzzer target_clip_fuzzer anim_file_fuzzer assimp_clip_fuzzer command_line_fuzzer rig-learn \
    -- -j"$jobs" \
    >"$build/build.log" 2>&1; then
  grep -E 'error|FAILED' "$build/build.log" | head -20 >&2
  echo "fuzz: the build failed; see $build/build.log" >&2
  exit 2
fi

# Seeds: the corpus of bad inputs, and good inputs to mutate from.
rig_seeds=(tests/corpus/rigs rigs)
maya_seeds=(tests/corpus/maya)
[ -d ../shared/maya ] && maya_seeds+=(../shared/maya)
bvh_seeds=(tests/corpus/bvh)
[ -d /usr/share/assimp/models/BVH ] && bvh_seeds+=(/usr/share/assimp/models/BVH)
[ -d ../shared/motion ] && bvh_seeds+=(../shared/motion)
# A good approximation to mutate from, learned by the instrumented rig-learn (a report would fail the run).
mkdir -p "$build/fuzz-seeds/approximation"
if ! "$build/bin/rig-learn" rigs/examples/arm.yaml --params 'shoulder.rotate?' 'elbow.rotate?' \
    -o "$build/fuzz-seeds/approximation/arm.approx.yaml" >"$build/fuzz-seeds/rig-learn.log" 2>&1; then
  echo "fuzz: learning the seed approximation failed; see $build/fuzz-seeds/rig-learn.log" >&2
  exit 1
fi
approximation_seeds=(tests/corpus/approx "$build/fuzz-seeds/approximation")
clip_seeds=(tests/corpus/clips tests/corpus/maps rigs/maps)
anim_seeds=(tests/corpus/anim)
# Clips through assimp: the hand-written legs and their broken copies, and assimp's own animated models.
assimp_seeds=(tests/corpus/clips)
for m in FBX Collada X glTF2/simple_skin; do
  [ -d "/usr/share/assimp/models/$m" ] && assimp_seeds+=("/usr/share/assimp/models/$m")
done
# The command lines: one seed per corpus case of the four tools (TOOL, its arguments, then its text files),
# {scratch} read as the fuzzer's own folder {dir}; and the README's good runs.
mkdir -p "$build/fuzz-seeds/command_line"
python3 - "$build/fuzz-seeds/command_line" <<'PY'
import sys, yaml, pathlib
out = pathlib.Path(sys.argv[1])
cases = yaml.safe_load(open("tests/corpus/cases.yaml"))["cases"]
n = 0
for case in cases:
    if case.get("tool") not in ("graph-eval", "bvh2rig", "rig-learn", "rig-invert"):
        continue
    lines = [case["tool"]] + [a.replace("{scratch}", "{dir}") for a in case.get("args", [])]
    for g in case.get("generate", []):
        if g.get("kind") == "text" and all("count" not in p for p in g.get("parts", [])):
            lines += ["--- " + g["file"], "".join(p["text"] for p in g["parts"]).rstrip("\n")]
    (out / f"case{n:04d}").write_text("\n".join(l for l in lines if "\n" not in l or l.startswith("---")) + "\n")
    n += 1
(out / "learn-arm").write_text("rig-learn\nrigs/examples/arm.yaml\n--params\nshoulder.rotate?\n-o\n{dir}/a.yaml\n")
(out / "eval-arm").write_text("graph-eval\nrigs/examples/arm.yaml\n--frames\n1:4\n--get\n*.rotateZ\n--format\ntable\n")
PY

failed=()
run_target() {
  local target=$1 dict=$2 max_len=$3
  shift 3
  local corpus="$build/fuzz-corpus/$target" crashes="$build/fuzz-crashes"
  mkdir -p "$corpus" "$crashes"
  echo "fuzz: $target for ${seconds}s (seeds: $*)" >&2
  local log="$build/fuzz-$target.log"
  # libassimp (5.2.5) leaks on some files it refuses (its X importer): its leaks, not ours, so not reported there.
  local extra=()
  [ "$target" = assimp_clip ] && extra=(-detect_leaks=0)
  # The first folder receives the new inputs; the others are only read.
  if "$build/bin/${target}_fuzzer" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=2048 \
      -max_len="$max_len" -dict="$dict" -artifact_prefix="$crashes/$target-" -print_final_stats=1 "${extra[@]}" \
      "$corpus" "$@" >"$log" 2>&1; then
    grep -E '^stat::number_of_executed_units|^stat::peak_rss_mb' "$log" | tr '\n' ' ' >&2
    echo >&2
  else
    echo "fuzz: $target FAILED; the log is $log, the input in $crashes/:" >&2
    grep -E '^==[0-9]+==ERROR|SUMMARY|runtime error|ALARM|out-of-memory|Test unit written' "$log" | head -8 >&2 || true
    failed+=("$target")
  fi
}
run_target rig_loader fuzz/rig.dict 65536 "${rig_seeds[@]}"
run_target maya_loader fuzz/maya.dict 4194304 "${maya_seeds[@]}"
run_target bvh_reader fuzz/bvh.dict 65536 "${bvh_seeds[@]}"
run_target approximation_loader fuzz/approximation.dict 65536 "${approximation_seeds[@]}"
run_target target_clip fuzz/target_clip.dict 65536 "${clip_seeds[@]}"
run_target anim_file fuzz/anim.dict 65536 "${anim_seeds[@]}"
run_target assimp_clip fuzz/assimp.dict 1048576 "${assimp_seeds[@]}"
run_target command_line fuzz/command_line.dict 8192 "$build/fuzz-seeds/command_line"

if ((${#failed[@]})); then
  echo "fuzz: failed: ${failed[*]}" >&2
  exit 1
fi
echo "fuzz: no crash" >&2
