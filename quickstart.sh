#!/usr/bin/env bash
# Sets everything up and runs the main job on the bundled example.
set -euo pipefail
cd "$(dirname "$0")"
scripts/setup.sh Release
echo "== rigs/examples/arm.yaml: the control's bend drives the elbow through a set-driven key =="
build/bin/graph-eval rigs/examples/arm.yaml --frames 1:24:2 --format table \
  --get arm_ctrl.bend --get elbow.rotateZ --get shoulder.rotateY --get wrist_world.outputTranslate
