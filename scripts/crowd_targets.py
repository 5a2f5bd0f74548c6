#!/usr/bin/env python3
"""Splits a crowd's edited targets, as graph-eval wrote them, into one rig-invert clip per member.

    graph-eval rigs/examples/crowd_lookat.yaml --frames 1:120 \\
        --get '*:inverter.target[*]' --get '*:inverter.outputNames' -o crowd_targets.json
    scripts/crowd_targets.py crowd_targets.json -o targets/       # targets/c0000.json, targets/c0001.json, ...
    rig-invert build/biped.approx.yaml --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml \\
        --clip targets/c0001.json --key-tolerance 0.1 -o c0001.anim

Each member NS's `NS:inverter.target[k]` becomes the joint named on line k of `NS:inverter.outputNames`
(`JOINT.worldMatrix`, the JSON clip rig-invert reads: docs/rig-invert.md), frame for frame: the targets its
rigInversion node solved for, after the look-at. rig-invert on that clip gives the node's curves (its
restarts count from the clip's first frame, as the node's from its startFrame) and, on request, sparse
keys and a Maya .anim file for that member (docs/crowds.md).
"""
import argparse
import json
import os
import re
import sys

TARGET = re.compile(r"^(?P<ns>.+):inverter\.target\[(?P<k>\d+)\]$")


def split(frames):
    """{namespace: [frame objects of JOINT.worldMatrix]} from graph-eval's frames."""
    if not isinstance(frames, list) or not frames:
        raise ValueError("not graph-eval's JSON output: a list of frames")
    members = {}
    for frame in frames:
        for plug, value in frame.items():
            m = TARGET.match(plug)
            if not m:
                continue
            names = frame.get(f"{m['ns']}:inverter.outputNames")
            if names is None:
                raise ValueError(f"{m['ns']}:inverter.outputNames is missing; add --get '*:inverter.outputNames'")
            joint = names.split("\n")[int(m["k"])]
            per = members.setdefault(m["ns"], {})
            per.setdefault(frame["frame"], {"frame": frame["frame"]})[f"{joint}.worldMatrix"] = value
    if not members:
        raise ValueError("no NS:inverter.target[k] plug; run graph-eval with --get '*:inverter.target[*]'")
    return {ns: [per[f] for f in sorted(per)] for ns, per in members.items()}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("input", help="graph-eval's JSON output (-o FILE.json)")
    parser.add_argument("-o", "--output", required=True, help="folder for one NS.json clip per member")
    args = parser.parse_args()
    try:
        with open(args.input) as f:
            members = split(json.load(f))
    except (OSError, ValueError) as e:
        sys.exit(f"error: {args.input}: {e}")
    os.makedirs(args.output, exist_ok=True)
    for ns, frames in members.items():
        with open(os.path.join(args.output, f"{ns.replace(':', '_')}.json"), "w") as out:
            json.dump(frames, out)
            out.write("\n")


if __name__ == "__main__":
    main()
