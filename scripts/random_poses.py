#!/usr/bin/env python3
"""Writes a JSON target clip of random poses of a rig, for rig-invert --clip (docs/rig-invert.md).

    scripts/random_poses.py APPROX.yaml --rig RIG.yaml --poses N -o CLIP.json [--values VALUES.json]
                            [--fraction F] [--seed S] [--graph-eval PATH]

Each pose sets every parameter of the approximation (rig-learn's file) to a uniform random value within
F (default 0.6) of its learned range on either side of its default, runs graph-eval on the rig with those
values, and keeps the world matrices of the approximation's outputs: frame k of the clip is pose k (from 1).
The poses are independent (not a motion): invert them with rig-invert --restart-every 1.
--values writes the values set, one entry per frame, in rig-invert's curves layout and user units (degrees
for angles), so that rig-invert's -o can be compared with them.
"""
import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile

import yaml


def parameters(approximation):
    """(name, default, min, max, angular) per parameter, internal units (radians)."""
    with open(approximation) as f:
        doc = yaml.safe_load(f)
    if not isinstance(doc, dict) or doc.get("format") != "rigInversionApproximation":
        sys.exit(f"error: {approximation}: not an approximation file (rig-learn -o writes one)")
    return [(p["name"], p["default"], p["min"], p["max"], p["angular"]) for p in doc["parameters"]], \
        [o["name"] for o in doc["outputs"]]


def pose(params, fraction, rng):
    """A random value per parameter in user units (degrees for angles)."""
    values = {}
    for name, default, lo, hi, angular in params:
        v = rng.uniform(default + fraction * (lo - default), default + fraction * (hi - default))
        values[name] = math.degrees(v) if angular else v
    return values


def evaluate(graph_eval, rig, values, outputs):
    """The outputs' world matrices at `values`: one graph-eval run."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "pose.json")
        command = [graph_eval, rig, "-o", out]
        for name, v in values.items():
            command += ["--set", f"{name}={v!r}"]
        for o in outputs:
            command += ["--get", f"{o}.worldMatrix"]
        result = subprocess.run(command, capture_output=True, text=True)
        if result.returncode != 0:
            sys.exit(result.stderr.strip() or f"error: {graph_eval} failed with exit code {result.returncode}")
        with open(out) as f:
            return json.load(f)[0]


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("approximation")
    parser.add_argument("--rig", required=True, help="the rig file the approximation was learned on")
    parser.add_argument("--poses", type=int, default=5)
    parser.add_argument("--fraction", type=float, default=0.6, help="of each parameter's range, 0..1")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--graph-eval", default=os.path.join(here, "..", "build", "bin", "graph-eval"))
    parser.add_argument("-o", "--output", required=True)
    parser.add_argument("--values", help="also write the values set (rig-invert's curves layout)")
    args = parser.parse_args()
    if args.poses < 1:
        parser.error("--poses needs at least 1")
    if not 0 <= args.fraction <= 1:
        parser.error("--fraction must be within 0..1")

    params, outputs = parameters(args.approximation)
    rng = random.Random(args.seed)
    frames, curves = [], []
    for k in range(1, args.poses + 1):
        values = pose(params, args.fraction, rng)
        record = evaluate(args.graph_eval, args.rig, values, outputs)
        record["frame"] = k
        frames.append(record)
        curves.append(dict({"frame": k}, **values))
    with open(args.output, "w") as f:
        json.dump(frames, f)
    if args.values:
        with open(args.values, "w") as f:
            json.dump(curves, f, indent=1)


if __name__ == "__main__":
    main()
