#!/usr/bin/env python3
"""Turns a rig-bench JSON report into the tables and plots of docs/performance.md.

    scripts/bench_report.py BENCH.json [--doc docs/performance.md] [--plots docs/performance]
                            [--format svg|png] [--no-plots]

The page keeps its prose; the script rewrites only what lies between marker lines

    <!-- bench:NAME -->
    ...
    <!-- /bench:NAME -->

for NAME in machine, headline, jacobian, invert, ceres, cold_start, train, accuracy, scaling, growth. Plots
of the scaling rows go to the plots folder (gnuplot: apt-get install gnuplot-nox); --no-plots leaves them.
"""
import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

# The talk's figures (Gustafson, Lo and Kanyuk, SIGGRAPH 2020 talk, section 6) and issue 7's goals.
TALK_JACOBIAN_SPEEDUP = 5000      # 3.5 s -> 6e-4 s
TALK_MS_PER_FRAME = 2.0
TALK_TRAIN_EVALUATIONS = 3000
TALK_TRAIN_SECONDS = 120.0
GOAL_MS_PER_FRAME = 0.1           # on one core, on the biped
SOLVER_GOAL_MS_PER_FRAME = 0.05   # issue #15's, the same measure
SOLVER_GOAL_CROWD_EXPONENT = 1.05  # issue #15's: time per frame ~ parameters^k over the crowds


def num(x, digits=3):
    """A figure for a table: 3 significant digits, '-' for null."""
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return f"{x:,}".replace(",", " ")
    if x == 0:
        return "0"
    if abs(x) >= 1e5 or abs(x) < 1e-3:
        return f"{x:.{digits - 1}e}"
    return f"{x:.{digits}g}" if abs(x) < 10 ** digits else f"{x:.0f}"


def table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(out)


def get(d, path, default=None):
    for key in path.split("."):
        if not isinstance(d, dict) or key not in d:
            return default
        d = d[key]
    return d


def status(ok):
    return "met" if ok else "not met"


def machine_block(b):
    m = b["machine"]
    load = lambda v: " / ".join(num(x) for x in v) if v else "-"
    rows = [
        ("cores", m.get("cores")), ("CPU", m.get("cpu")), ("memory", f"{num(m.get('memory_gb'))} GB"),
        ("OS", m.get("os")), ("compiler", m.get("compiler")),
        ("build", f"{m.get('build_type')} ({m.get('cxx_flags', '').strip()})"),
        ("Eigen / oneTBB / Ceres", f"{m.get('eigen')} / {m.get('tbb')} / {get(b, 'ceres.version') or 'not built'}"),
        ("run", f"{b.get('mode')}, {num(b.get('seconds'))} s, {m.get('date')}"),
        ("load average (1/5/15 min)",
         f"start {load(m.get('load_average_at_start'))}, end {load(b.get('load_average_at_end'))}"),
    ]
    return table(["", "this run"], [(k, v) for k, v in rows])


def headline_block(b):
    jac, inv, ceres, train = b["jacobian"], b["invert"], b["ceres"], b["train"]
    growth = get(b, "growth.crowd.ms_per_frame")
    rows = []
    sa = jac["speedup_analytic"]
    rows.append(("Jacobian speed-up over black-box FD (analytic)", f"> {TALK_JACOBIAN_SPEEDUP}x",
                 f"{num(jac['blackbox_fd_ms'])} ms -> {num(jac['approx_analytic_ms'])} ms = {num(sa)}x",
                 status(sa >= TALK_JACOBIAN_SPEEDUP)))
    rows.append(("Jacobian speed-up (parallel FD on the approximation)", f"> {TALK_JACOBIAN_SPEEDUP}x",
                 f"{num(jac['speedup_fd'])}x", status(jac["speedup_fd"] >= TALK_JACOBIAN_SPEEDUP)))
    ms = inv["ms_per_frame"]
    bbb = inv.get("block_by_block_ms_per_frame")
    rows.append(("inversion per frame, biped, 1 thread",
                 f"{TALK_MS_PER_FRAME} ms (talk); < {GOAL_MS_PER_FRAME} ms (goal); "
                 f"{SOLVER_GOAL_MS_PER_FRAME} ms (#15)",
                 f"{num(ms)} ms coupled blocks (block by block {num(bbb)} ms, whole problem "
                 f"{num(inv.get('whole_ms_per_frame'))} ms)",
                 f"talk: {status(ms <= TALK_MS_PER_FRAME)}; goal: {status(ms < GOAL_MS_PER_FRAME)}; "
                 f"#15: {status(ms <= SOLVER_GOAL_MS_PER_FRAME)}"))
    ik = b.get("ik_legs")
    if ik:
        rows.append(("IK legs, hybrid solve (rigs/biped_inversion_ik.yaml), 1 thread", "2 ms (talk); leg joints "
                     "within 0.1 cm of FK's (goal)",
                     f"{num(ik['cpu_ms_per_frame'])} ms, {num(ik['real_rig_evaluations_per_frame'])} real-rig "
                     f"evaluations per frame, real rig worst {num(ik['real_rig']['max_position_error_cm'])} cm; leg "
                     f"joints {num(ik['leg_joints_vs_fk_max_cm'])} cm from FK's at worst, "
                     f"{num(ik['leg_joints_vs_fk_mean_cm'])} cm mean",
                     f"talk: {status(ik['cpu_ms_per_frame'] <= 2.0)}; goal: "
                     f"{status(ik['leg_joints_vs_fk_max_cm'] <= 0.1)}"))
    rows.append(("inversion vs Gauss-Newton on the real rig (same frames)", "-",
                 f"{num(inv['speedup_vs_blackbox_same_frames'])}x faster", "-"))
    if ceres.get("ms_per_frame") is not None:
        ours_cost, ceres_cost = ceres["ours_mean_final_cost"], ceres["mean_final_cost"]
        equal = ours_cost <= ceres_cost * (1 + 1e-3)
        bbb_ms = ceres.get("ours_block_by_block_ms_per_frame")
        bbb_speedup = ceres["ms_per_frame"] / bbb_ms if bbb_ms else None
        rows.append(("faster than Ceres at equal accuracy (goal)", "-",
                     f"Ceres {num(ceres['ms_per_frame'])} ms, ours {num(ceres['ours_ms_per_frame'])} ms coupled blocks "
                     f"({num(ceres['speedup_ours'])}x), {num(bbb_ms)} ms block by block ({num(bbb_speedup)}x), "
                     f"{num(ceres['ours_whole_ms_per_frame'])} ms whole ({num(ceres['speedup_ours_whole'])}x); "
                     f"mean cost Ceres {num(ceres_cost, 4)}, ours coupled {num(ours_cost, 4)}, whole "
                     f"{num(ceres['ours_whole_mean_final_cost'], 4)}, block by block "
                     f"{num(ceres.get('ours_block_by_block_mean_final_cost'), 4)}",
                     status(ceres["speedup_ours"] > 1 and equal)))
    else:
        rows.append(("faster than Ceres at equal accuracy (goal)", "-", "Ceres not built", "not measured"))
    ev = train["evaluations"]
    rows.append(("training evaluations (biped)", f"~{TALK_TRAIN_EVALUATIONS} (production rig)", num(ev),
                 status(ev < TALK_TRAIN_EVALUATIONS)))
    rows.append(("training time (biped)", f"~{num(TALK_TRAIN_SECONDS)} s", f"{num(train['seconds'])} s",
                 status(train["seconds"] < TALK_TRAIN_SECONDS)))
    if growth is not None:
        rows.append(("time per frame grows linearly with independent limbs (goal)",
                     f"k <= 1.1 (goal); k <= {SOLVER_GOAL_CROWD_EXPONENT} (#15)", f"crowd exponent {num(growth)}",
                     f"goal: {status(growth <= 1.1)}; #15: {status(growth <= SOLVER_GOAL_CROWD_EXPONENT)}"))
    return table(["figure", "talk / goal", "measured", "status"], rows)


def jacobian_block(b):
    j = b["jacobian"]
    rows = [
        ("black box: forward differences on the real graph, serial", num(j["blackbox_fd_ms"]), "1"),
        ("black box: central differences on the real graph, serial", num(j["blackbox_central_fd_ms"]),
         num(j["blackbox_central_fd_ms"] / j["blackbox_fd_ms"])),
        (f"approximation: central differences, {j['approx_fd_threads']} threads", num(j["approx_fd_ms"]),
         num(j["approx_fd_ms"] / j["blackbox_fd_ms"])),
        ("approximation: central differences, 1 thread", num(j["approx_fd_serial_ms"]),
         num(j["approx_fd_serial_ms"] / j["blackbox_fd_ms"])),
        ("approximation: analytic", num(j["approx_analytic_ms"]), num(j["approx_analytic_ms"] / j["blackbox_fd_ms"])),
    ]
    text = table(["Jacobian (%d x %d, at rest, first frame's targets)" % (j["rows"], j["columns"]), "ms",
                  "x black box"], rows)
    text += (f"\n\nBlack box: {num(j['blackbox_evaluations_per_jacobian'])} real-rig evaluations per Jacobian, "
             f"{num(j['blackbox_fd_ms'] / j['blackbox_evaluations_per_jacobian'] * 1000)} us each. "
             f"Largest difference between the real rig's Jacobian and the analytic one, relative to its largest "
             f"entry: {num(j['analytic_vs_blackbox_relative_difference'])}.")
    return text


def blocks_label(v):
    """How a variant's partition is solved: its blocks coupled, one after another, or no partition."""
    if not v.get("partition", True):
        return "whole problem"
    return "coupled" if v.get("coupled_blocks", True) else "block by block"


def invert_block(b):
    inv = b["invert"]
    rows = []
    # The three ways of solving the partition (coupled, block by block, whole problem) side by side first.
    order = {"coupled": 0, "block by block": 1, "whole problem": 2}
    plain = lambda v: v["threads"] == 1 and v["jacobian"] == "analytic" and v["polish"] == 0
    variants = sorted(inv["variants"], key=lambda v: (not plain(v), order[blocks_label(v)]))
    for v in variants:
        r = v["real_rig"]
        ms = v["cpu_ms_per_frame"] if v.get("cpu_ms_per_frame") is not None else v["ms_per_frame"]
        rows.append((v["name"], blocks_label(v), num(ms), f"{v['converged_frames']}/{v['frames']}",
                     num(v["mean_iterations"]), num(v["mean_final_cost"], 4), num(r["max_position_error_cm"]),
                     num(r["mean_position_error_cm"]), num(r["max_rotation_error_deg"]),
                     num(r["mean_rotation_error_deg"])))
    bb = b["blackbox"]
    rbb = bb["real_rig"]
    rows.append(("Gauss-Newton on the real rig (black box), 1 thread", "whole problem", num(bb["cpu_ms_per_frame"]),
                 f"{bb['converged_frames']}/{bb['frames']}", num(bb["mean_iterations"]), num(bb["mean_final_cost"], 4),
                 num(rbb["max_position_error_cm"]), num(rbb["mean_position_error_cm"]),
                 num(rbb["max_rotation_error_deg"]), num(rbb["mean_rotation_error_deg"])))
    text = table(["solver", "blocks", "ms/frame", "converged", "iterations", "mean cost", "worst cm", "mean cm",
                  "worst deg", "mean deg"], rows)
    text += (f"\n\nOur variants over {inv['frames']} frames; the black box over the first {bb['frames']} frames "
             f"({num(bb['evaluations_per_frame'])} real-rig evaluations per frame), where ours takes "
             f"{num(bb['ours_cpu_ms_per_frame'])} ms per frame: {num(bb['speedup'])}x faster (the whole problem, as "
             f"the black box solves it: {num(bb['ours_whole_cpu_ms_per_frame'])} ms, {num(bb['speedup_whole'])}x). "
             "Iterations: "
             f"the coupled solve's own (its blocks step together); block by block, summed over the partition's "
             f"blocks. Converged: to the targets (the other frames end stuck, stationary with a residual, or not "
             f"converged).")
    return text


def ceres_block(b):
    c = b["ceres"]
    if c.get("ms_per_frame") is None:
        return f"Not measured: {c.get('note', 'rig-bench was built without Ceres')}."
    rows = []
    for v in c["variants"]:
        r = v["real_rig"]
        rows.append((f"Ceres {c['version']}, {v['linear_solver']}, {v['tolerances']} tolerances",
                     num(v["cpu_ms_per_frame"]),
                     f"{v['converged_frames']}/{v['frames']}", num(v["mean_iterations"]), num(v["mean_final_cost"], 4),
                     num(r["max_position_error_cm"]), num(r["mean_position_error_cm"])))
    rows.append(("ours, coupled blocks, analytic, 1 thread", num(c["ours_ms_per_frame"]), "", "",
                 num(c["ours_mean_final_cost"], 4), "", ""))
    rows.append(("ours, block by block, analytic, 1 thread", num(c.get("ours_block_by_block_ms_per_frame")), "", "",
                 num(c.get("ours_block_by_block_mean_final_cost"), 4), "", ""))
    rows.append(("ours, whole problem, analytic, 1 thread", num(c["ours_whole_ms_per_frame"]), "", "",
                 num(c["ours_whole_mean_final_cost"], 4), "", ""))
    return table(["solver (first %d frames)" % c["frames"], "ms/frame", "converged", "iterations", "mean cost",
                  "worst cm", "mean cm"], rows)


def cold_start_block(b):
    c = b.get("cold_start")
    if c is None:
        return "Not measured: this run has no cold-start row."
    n = c["poses"]
    rows = [
        ("Solver::initialGuess, then solve", f"{c['recovered_from_guess']}/{n}", num(c["rate_from_guess"]),
         num(c["guess_ms"]), num(c["solve_after_guess_ms"])),
        ("solve from rest alone", f"{c['recovered_from_rest']}/{n}", num(c["rate_from_rest"]), "-", "-"),
    ]
    text = table(["start (biped's approximation, random poses)", "recovered", "rate", "guess ms", "solve ms"], rows)
    return text + f"\n\n{c['note'][0].upper()}{c['note'][1:]}."


def train_block(b):
    rows = []
    for name, t in b["train"]["orderers"].items():
        if t is None:
            rows.append((name, "not run", "", "", "", "", ""))
            continue
        rows.append((name.replace("_", " "), num(t["evaluations"]), num(t["order_evaluations"]), num(t["seconds"]),
                     f"{t['modelled']}/{t['parameters']}", t.get("relative_outputs", ""),
                     num(t["validation_max_position_error_cm"]), num(t["validation_max_rotation_error_deg"]),
                     num(t["validation_max_relative_error"]), "yes" if t["within_epsilon"] else "NO"))
    out = table(["orderer", "rig evaluations", "of which ordering", "seconds", "modelled", "relative outputs",
                 "validation worst cm", "validation worst deg", "worst cm per unit", "within epsilon"], rows)
    # Training on 1 and 2 rig instances (rig-learn --threads): the biped, and the largest crowd.
    threads = [("biped", b["train"]["threads"])] + [
        (f"{r['rig']} {r['count']}", r["train_threads"]) for r in b["scaling"] if r.get("train_threads")]
    rows = [(name, num(t["seconds_1_threads"]), num(t["seconds_2_threads"]),
             num(t["seconds_1_threads"] / t["seconds_2_threads"]), "yes" if t["same_approximation"] else "NO")
            for name, t in threads]
    return out + "\n\n" + table(["rig", "1 instance s", "2 instances s", "speed-up", "same approximation"], rows)


def accuracy_block(b):
    a = b["accuracy"]
    names = {
        "approximation": "ours (coupled blocks, analytic)",
        "approximation_block_by_block": "ours (block by block, analytic)",
        "approximation_whole": "ours (whole problem, analytic)",
        "approximation_fd": "ours (finite differences)",
        "approximation_world_space":
            "ours, world-space approximation (the talk's frames; it discards what it cannot order)",
        "approximation_polish1": "ours + 1 real-rig polish",
        "ceres": "Ceres (headline variant)",
        "blackbox": "Gauss-Newton on the real rig",
        "approximation_on_blackbox_frames": "ours, on the black box's frames",
        "approximation_whole_on_blackbox_frames": "ours (whole problem), on the black box's frames",
    }
    # Block by block has no accuracy entry of its own: its variant's real-rig errors.
    block_by_block = next((v for v in get(b, "invert.variants", [])
                           if v.get("partition") and v.get("coupled_blocks") is False), None)
    a = dict(a, approximation_block_by_block=block_by_block["real_rig"] if block_by_block else None)
    rows = []
    for key, label in names.items():
        e = a.get(key)
        if e is None:
            rows.append((label, "not measured", "", "", "", ""))
            continue
        rows.append((label, e["frames"], num(e["max_position_error_cm"]), num(e["mean_position_error_cm"]),
                     num(e["max_rotation_error_deg"]), num(e["mean_rotation_error_deg"])))
    return table(["method", "frames", "worst cm", "mean cm", "worst deg", "mean deg"], rows)


def scaling_block(b):
    rows = []
    for r in b["scaling"]:
        rows.append((f"{r['rig']} {r['count']}", r["parameters"], r["modelled"], r["blocks"], num(r["ms_per_frame"]),
                     f"{r['status_frames']['reached']}/{r['frames']}", num(r["jacobian_ms"]),
                     num(r["blackbox_jacobian_ms"]),
                     num(r["train_evaluations"]), num(r["train_seconds"]), num(r["memory_mb"]),
                     num(r["approximation_kb"]), num(r["max_position_error_cm"])))
    return table(["rig", "parameters", "modelled", "blocks", "ms/frame", "reached", "Jacobian ms", "black-box "
                  "Jacobian ms", "training evaluations", "training s", "peak memory MB", "approximation KB",
                  "worst cm"], rows)


def growth_block(b):
    g = b.get("growth") or {}
    keys = [("ms_per_frame", "time per frame"), ("jacobian_ms", "Jacobian (analytic, blocks)"),
            ("blackbox_jacobian_ms", "black-box Jacobian"), ("train_evaluations", "training evaluations"),
            ("train_seconds", "training time"), ("memory_mb", "peak memory"),
            ("approximation_kb", "approximation size")]
    kinds = [k for k in ("crowd", "chain") if k in g]
    rows = [(label, *[num(g[k].get(key)) for k in kinds]) for key, label in keys]
    return table(["cost ~ parameters^k", *[f"k, {k}" for k in kinds]], rows)


BLOCKS = {
    "machine": machine_block, "headline": headline_block, "jacobian": jacobian_block, "invert": invert_block,
    "ceres": ceres_block, "cold_start": cold_start_block, "train": train_block, "accuracy": accuracy_block,
    "scaling": scaling_block, "growth": growth_block,
}


def replace_blocks(text, bench):
    for name, make in BLOCKS.items():
        pattern = re.compile(r"(<!-- bench:%s -->\n).*?(<!-- /bench:%s -->)" % (name, name), re.S)
        if not pattern.search(text):
            raise SystemExit(f"error: the page has no '<!-- bench:{name} -->' ... '<!-- /bench:{name} -->' block")
        text = pattern.sub(lambda m: m.group(1) + make(bench) + "\n" + m.group(2), text)
    return text


PLOTS = [
    ("scaling_time", "time per frame (ms)", "ms_per_frame", None),
    ("scaling_jacobian", "Jacobian (ms)", "jacobian_ms", "blackbox_jacobian_ms"),
    ("scaling_training", "training rig evaluations", "train_evaluations", None),
    ("scaling_memory", "peak memory (MB)", "memory_mb", None),
]


def plot(bench, folder, fmt):
    if shutil.which("gnuplot") is None:
        raise SystemExit("error: gnuplot not found: apt-get install gnuplot-nox (or give --no-plots)")
    os.makedirs(folder, exist_ok=True)
    rows = bench["scaling"]
    kinds = sorted({r["rig"] for r in rows})
    written = []
    with tempfile.TemporaryDirectory() as tmp:
        for kind in kinds:
            with open(os.path.join(tmp, f"{kind}.dat"), "w") as f:
                for r in rows:
                    if r["rig"] != kind:
                        continue
                    values = [r["parameters"]] + [r.get(key) for _, _, key, _ in PLOTS] + \
                             [r.get(extra) for _, _, _, extra in PLOTS if extra]
                    f.write(" ".join("NaN" if v is None or (isinstance(v, float) and not math.isfinite(v)) or v <= 0
                                     else repr(v) for v in values) + "\n")
        terminal = "svg size 640,420 dynamic font 'sans,12'" if fmt == "svg" else "pngcairo size 640,420"
        for index, (name, label, _, extra) in enumerate(PLOTS):
            out = os.path.join(folder, f"{name}.{fmt}")
            series = []
            for kind in kinds:
                data = os.path.join(tmp, f"{kind}.dat")
                series.append(f"'{data}' using 1:{index + 2} with linespoints title '{kind}, ours'"
                              if extra else f"'{data}' using 1:{index + 2} with linespoints title '{kind}'")
                if extra:
                    column = 2 + len(PLOTS) + [p[3] for p in PLOTS if p[3]].index(extra)
                    series.append(f"'{data}' using 1:{column} with linespoints dashtype 2 title '{kind}, black box'")
            script = "\n".join([
                f"set terminal {terminal}", f"set output '{out}'", "set logscale xy", "set grid",
                "set key top left", "set xlabel 'rig parameters'", f"set ylabel '{label}'",
                "plot " + ", ".join(series), ""])
            subprocess.run(["gnuplot"], input=script, text=True, check=True)
            written.append(out)
    return written


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("bench", help="rig-bench --json output")
    parser.add_argument("--doc", default="docs/performance.md")
    parser.add_argument("--plots", default="docs/performance")
    parser.add_argument("--format", choices=["svg", "png"], default="svg")
    parser.add_argument("--no-plots", action="store_true")
    args = parser.parse_args()
    with open(args.bench) as f:
        bench = json.load(f)
    with open(args.doc) as f:
        text = f.read()
    text = replace_blocks(text, bench)
    written = [] if args.no_plots or not bench.get("scaling") else plot(bench, args.plots, args.format)
    with open(args.doc + ".tmp", "w") as f:
        f.write(text)
    os.replace(args.doc + ".tmp", args.doc)
    print(f"wrote {args.doc}" + "".join(f", {w}" for w in written))


if __name__ == "__main__":
    sys.exit(main())
