#!/usr/bin/env python3
"""Writes a crowd of N bipeds that look at one moving target, each inverted by its own rigInversion node.

    scripts/make_crowd.py N [-o FILE] [--start-step 37] [--rig ../biped.yaml]
        [--approximation ../../build/biped.approx.yaml] [--map ../maps/cmu_to_biped_lookat.yaml] [--clip BVH]

Member i (0 first) is the biped included under the namespace cNNNN (c0000:Head, c0000:L_arm_fk_ctrl, ...),
with its own nodes under the same namespace: an offset that plays the clip from frame 1 + i * start-step
(wrapped within the clip), the clip, a lookAt of Spine1, Neck, Neck1 and Head toward the shared target, the
arms carried by Spine1's turn, and a rigInversion node that reads the one approximation file and drives
that member's controls (connect: {parameters: true, namespace: cNNNN}). Every member is wired as
rigs/examples/biped_lookat.yaml wires its one biped (docs/crowds.md). The target is one camera path for
the whole crowd: it sweeps left to right in front of the heads over frames 1..120 and back (oscillate).
Paths are written as given: relative to the output file's folder, as every path in a rig file is.

rigs/examples/crowd_lookat.yaml is `scripts/make_crowd.py 2 -o rigs/examples/crowd_lookat.yaml`;
rig-bench's crowd_realtime row writes larger crowds with it.
"""
import argparse
import sys

CLIP = "/usr/share/assimp/models/BVH/01_01.bvh"
CLIP_FRAMES = 2752  # 01_01.bvh's frames: start frames wrap so that each member has 240 frames to play

# The lookAt chain (clip joint index, name), root first, and the joints under Spine1 that follow its turn;
# the clip's joints in file order are the approximation's outputs (rigs/biped_inversion.yaml).
CHAIN = [(13, "Spine1"), (14, "Neck"), (15, "Neck1"), (16, "Head")]
ARMS = ["LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand", "LeftFingerBase", "LFingers", "LThumb",
        "RightShoulder", "RightArm", "RightForeArm", "RightHand", "RightFingerBase", "RFingers", "RThumb"]
FIRST_ARM = 17
JOINTS = 31


def start_frame(member, step):
    """Member's first clip frame: 1 + member * step, wrapped so that 240 frames remain to play."""
    return 1 + (member * step) % (CLIP_FRAMES - 240)


def member(ns, start, args):
    """The nodes and connections of one biped under namespace `ns`, playing the clip from `start`."""
    nodes = [
        f"  # {ns}: the clip from frame {start} (scene frame t plays clip frame t + {start - 1})",
        f"  - {{name: {ns}:clipTime, type: plusMinusAverage, input1D: [{start - 1}]}}",
        f"  - {{name: {ns}:clip, type: bvhClip, file: {args.clip}}}",
        f"  - name: {ns}:look",
        "    type: lookAt",
        "    share: [0.2, 0.25, 0.4, 1]  # root first: Spine1, Neck, Neck1, Head",
        "    limit: [15, 15, 30, 60]      # degrees",
        "    aimAxis: [0, 0, 1]",
        "    upMode: world",
    ]
    nodes += [f"  - {{name: {ns}:follow_{arm}, type: multMatrix}}" for arm in ARMS]
    nodes += [
        f"  - name: {ns}:inverter",
        "    type: rigInversion",
        f"    file: {args.approximation}",
        f"    map: {args.map}",
        "    threads: 1         # the crowd's members are solved in parallel, each on one thread",
        f"    startFrame: {start}  # the inverter's time is the clip's: restarts as rig-invert's from {start}",
        f"    connect: {{parameters: true, namespace: {ns}}}",
    ]
    links = [
        f"  - time1.outTime -> {ns}:clipTime.input1D[1]",
        f"  - {ns}:clipTime.output1D -> {ns}:clip.time",
        f"  - {ns}:clipTime.output1D -> {ns}:inverter.time",
        f"  - camera.translate -> {ns}:look.target",
    ]
    chain = dict(CHAIN)
    for k in range(JOINTS):
        if k in chain:
            i = [j for j, _ in CHAIN].index(k)
            links.append(f"  - {ns}:clip.worldMatrix[{k}] -> {ns}:look.inMatrix[{i}]  # {chain[k]}")
            links.append(f"  - {ns}:look.outMatrix[{i}] -> {ns}:inverter.target[{k}]")
        elif k >= FIRST_ARM:
            follow = f"{ns}:follow_{ARMS[k - FIRST_ARM]}"
            links.append(f"  - {ns}:clip.worldMatrix[{k}] -> {follow}.matrixIn[0]")
            links.append(f"  - {ns}:look.deltaMatrix[0] -> {follow}.matrixIn[1]")
            links.append(f"  - {follow}.matrixSum -> {ns}:inverter.target[{k}]")
        else:
            links.append(f"  - {ns}:clip.worldMatrix[{k}] -> {ns}:inverter.target[{k}]")
    return nodes, links


def crowd(args):
    header = [
        f"# {args.count} bipeds look at one moving target, each inverted by its own rigInversion node",
        "# (written by scripts/make_crowd.py; docs/crowds.md). Learn the biped first (README.md), then:",
        f"#   graph-eval FILE --frames 1:120 --get 'c*:inverter.value[*]'",
        "plugins: [rigInversion]",
        "include:",
    ]
    names = [f"c{i:04d}" for i in range(args.count)]
    header += [f"  - {{file: {args.rig}, namespace: {ns}}}" for ns in names]
    nodes = [
        "nodes:",
        "  - {name: time1, type: time}",
        "  # The camera path every head follows: left to right in front of the heads (the clip's units), and back.",
        "  - {name: camera, type: transform, translate: [0, 25, 30]}",
        "  - {name: camera_x, type: animCurveTL, keys: [[1, -60], [120, 60]], tangents: linear, "
        "postInfinity: oscillate}",
    ]
    links = ["connections:", "  - time1.outTime -> camera_x.input", "  - camera_x.output -> camera.translateX"]
    for i, ns in enumerate(names):
        n, c = member(ns, start_frame(i, args.start_step), args)
        nodes += n
        links += c
    return "\n".join(header + nodes + links) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("count", type=int, help="bipeds in the crowd (1 or more)")
    parser.add_argument("-o", "--output", default="-")
    parser.add_argument("--start-step", type=int, default=37, help="clip frames between two members' starts")
    parser.add_argument("--rig", default="../biped.yaml")
    parser.add_argument("--approximation", default="../../build/biped.approx.yaml")
    parser.add_argument("--map", default="../maps/cmu_to_biped_lookat.yaml")
    parser.add_argument("--clip", default=CLIP)
    args = parser.parse_args()
    if args.count < 1:
        parser.error(f"the crowd has {args.count} bipeds; give 1 or more")
    if args.start_step < 0:
        parser.error(f"--start-step is {args.start_step}; give 0 (every member in step) or more")
    text = crowd(args)
    if args.output == "-":
        sys.stdout.write(text)
    else:
        with open(args.output, "w") as out:
            out.write(text)


if __name__ == "__main__":
    main()
