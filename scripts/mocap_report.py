#!/usr/bin/env python3
"""The main job's short report: the biped driven through the rigInversion node, checked against rig-invert.

Usage: scripts/mocap_report.py GRAPH_CURVES.json INVERT_CURVES.json INVERT_REPORT.json GRAPH_STATS.txt

GRAPH_CURVES.json: graph-eval's output for the controls the node drives (rigs/examples/biped_mocap.yaml);
INVERT_CURVES.json and INVERT_REPORT.json: rig-invert's curves and --report-json for the same clip and
approximation; GRAPH_STATS.txt: graph-eval --stats. The real-rig errors are rig-invert's, which re-evaluates
the rig with the recovered values: they hold for the graph's curves because the two are the same curves
(checked here, to 1e-9 degrees or cm: the graph stores angles in radians and prints them in degrees).
Exits 1 if the curves differ.
"""
import json
import re
import sys


STATUS_WORDS = {"reached": "reached", "best_fit": "best fit", "model_mismatch": "model mismatch",
                "not_converged": "not converged", "non_finite": "non-finite", "invalid_targets": "invalid targets"}


def residual_joints(report, shown=4):
    """The joints the real rig leaves off their targets, in the report's order (rig-invert's: the largest error on
    the target tolerance's scale first), each with its worst position and rotation errors apart:
    'A (0.27 cm, 34.9 deg, 239 frames), B (...) and N more'."""
    joints = list(report["residual_joints"].items())

    def figure(value, unit):
        return f"{value:.3g} {unit}" if value is not None else f"nan {unit}"

    text = ", ".join(f"{name} ({figure(j['worst_position_error_cm'], 'cm')}, "
                     f"{figure(j['worst_rotation_error_deg'], 'deg')}, "
                     f"{j['frames']} frame{'' if j['frames'] == 1 else 's'})"
                     for name, j in joints[:shown])
    if len(joints) > shown:
        text += f" and {len(joints) - shown} more"
    return text


def main(graph_curves, invert_curves, invert_report, graph_stats):
    graph = json.load(open(graph_curves))
    invert = json.load(open(invert_curves))
    report = json.load(open(invert_report))
    stats = open(graph_stats).read()
    worst = 0.0
    if len(graph) != len(invert):
        sys.exit(f"mocap_report: {graph_curves} has {len(graph)} frames, {invert_curves} {len(invert)}")
    for g, i in zip(graph, invert):
        for name, value in i.items():
            if name == "frame":
                continue
            worst = max(worst, abs(g[name] - value))
    per_frame = re.search(r"([0-9.e+-]+) ms per frame", stats)
    counts = ", ".join(f"{n} {STATUS_WORDS[key]}" for key, n in report["status_frames"].items() if n)
    print(f"frames            {report['frames']}: {counts} (judged on the real rig: reached, every target within "
          "1e-3 cm; best fit, a least-squares optimum with a residual, where the approximation agrees with it)")
    if report["residual_joints"]:
        print(f"residual joints   {residual_joints(report)}")
    print(f"real-rig error    worst {report['max_position_error_cm']:.3g} cm ({report['worst_joint']} at frame "
          f"{report['worst_frame']}), {report['max_rotation_error_deg']:.3g} deg ({report['worst_rotation_joint']} "
          f"at frame {report['worst_rotation_frame']}); mean {report['mean_position_error_cm']:.3g} cm, "
          f"{report['mean_rotation_error_deg']:.3g} deg")
    print(f"time per frame    {per_frame.group(1) if per_frame else '?'} ms through the graph (clip, solve and rig);"
          f" {report['ms_per_frame']:.3g} ms solving (rig-invert)")
    print(f"graph = rig-invert  {'yes' if worst <= 1e-9 else 'NO'} (largest difference {worst:.2g})")
    print(f"curves            {graph_curves}")
    return 0 if worst <= 1e-9 else 1


if __name__ == "__main__":
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    sys.exit(main(*sys.argv[1:]))
