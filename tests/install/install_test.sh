#!/usr/bin/env bash
# The installable package end to end (CTest install.package): installs the build into a temporary prefix, builds
# this folder out of tree with find_package(rig) (a node plugin and a program), then runs the installed graph-eval
# with the plugin and the program, and checks what they print.
# Usage: install_test.sh SOURCE_DIR BUILD_DIR SCRATCH_DIR
set -euo pipefail
source_dir=$1
build_dir=$2
scratch=$3
rm -rf "$scratch"
mkdir -p "$scratch"
prefix=$scratch/prefix

fail() {
  echo "install test: $*" >&2
  exit 1
}
expect() {  # expect WHAT EXPECTED ACTUAL
  [ "$2" = "$3" ] || fail "$1: expected
$2
got
$3"
}

cmake --install "$build_dir" --prefix "$prefix" >"$scratch/install.log"
for file in bin/graph-eval bin/rig-invert bin/skel2rig bin/bvh2rig lib/rigInversion.so include/rig/graph/node.h \
            include/rig/app/eval/eval_run.h include/rig/inversion/model/approximation.h \
            include/rig/adapter/graph_rig_function.h \
            lib/cmake/rig/rigConfig.cmake lib/cmake/rig/rigConfigVersion.cmake lib/cmake/rig/rigTargets.cmake; do
  [ -e "$prefix/$file" ] || fail "$file was not installed"
done
# bvh2rig is skel2rig under its former name: a relative link, so the prefix can move, that runs.
expect "bin/bvh2rig" "skel2rig" "$(readlink "$prefix/bin/bvh2rig")"
"$prefix/bin/bvh2rig" --help | head -1 | grep -q '^bvh2rig: write a forward-kinematics rig' ||
  fail "the installed bvh2rig does not run as bvh2rig"

launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S "$source_dir/tests/install" -B "$scratch/build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$prefix" "${launcher[@]}" >"$scratch/configure.log" ||
  fail "configuring against the package failed (log: $scratch/configure.log)"
cmake --build "$scratch/build" >"$scratch/build.log" 2>&1 || fail "building failed (log: $scratch/build.log)"

# The plugin, loaded by the installed graph-eval: 1.5 * 4.
graph_eval=$prefix/bin/graph-eval
actual=$("$graph_eval" --plugin "$scratch/build/installScale.so" "$source_dir/tests/install/scale_rig.yaml" \
         --get scaler.output --format csv)
expect "the plugin's node in the installed graph-eval" "frame,scaler.output
0,6" "$actual"

# The program prints what the installed graph-eval prints for the same rig, plugs and frames.
arm=$source_dir/rigs/examples/arm.yaml
actual=$("$scratch/build/evaluate_rig" "$arm" 1 3 wrist_world.outputTranslate elbow.rotateZ)
expected=$("$graph_eval" "$arm" --get wrist_world.outputTranslate --get elbow.rotateZ --frames 1:3 --format csv)
expect "the program's values" "$expected" "$actual"
lines=$(echo "$actual" | wc -l)
[ "$lines" = 4 ] || fail "the program printed $lines lines, not a header and 3 frames"

# The installed rigInversion plugin is the one beside the installed libraries, found without a path.
# (The reference is read whole before grep: under pipefail, grep -q stopping early would fail graph-eval's write.)
types=$("$graph_eval" --plugin rigInversion --types)
grep -qx '### rigInversion' <<<"$types" ||
  fail "the installed graph-eval does not load the installed rigInversion plugin"
echo "install test: passed ($prefix)"
