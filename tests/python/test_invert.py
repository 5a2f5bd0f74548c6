"""Approximation.invert against rig-invert: the same values bit for bit and the same report, arrays checked,
the same errors, the GIL released while solving."""

import _thread
import ast
import json
import re
import shutil
import signal
import threading
import time

import numpy as np
import pytest

import riginv
from conftest import (ARM, BIPED, CMU_CLIP, CMU_MAP, SOURCE, biped_spec, error_line, need_cmu_clip, raises_like,
                      read_json, run, share_of_time_another_thread_runs)

# Differs from run to run (solver time per frame) or says where the curves were written.
VOLATILE = ("ms_per_frame", "setup_ms", "curves")


def rig_invert(approximation, folder, *args):
    """rig-invert's curves (as rows in the approximation's parameter order) and report."""
    curves, report = folder / "curves.json", folder / "report.json"
    code, _, err = run("rig-invert", approximation, "--rig", BIPED, "-o", curves, "--report-json", report, "-q", *args)
    assert code == 0, err
    frames = read_json(curves)
    names = [key for key in frames[0] if key != "frame"]
    return np.array([[frame[n] for n in names] for frame in frames]), names, read_json(report)


def without(report, *keys):
    return {k: v for k, v in report.items() if k not in keys}


def test_a_cmu_clip_equals_rig_invert(learned_biped, tmp_path):
    need_cmu_clip()
    file, _ = learned_biped
    expected, names, report = rig_invert(file, tmp_path, "--clip", CMU_CLIP, "--map", CMU_MAP, "--threads", "1")
    approx = riginv.Approximation.load(file)
    values, our_names, our_report = approx.invert(str(CMU_CLIP), rig=BIPED, map=CMU_MAP)
    assert our_names == names == approx.parameters
    assert values.dtype == np.float64 and values.shape == (2752, len(names))
    assert np.array_equal(values, expected)  # bit for bit: JSON numbers read back the same doubles
    assert without(our_report, *VOLATILE) == without(report, *VOLATILE)
    # The fingerprint of the curves rig-invert would write: the same text.
    assert our_report["curves"] == {"file": None, "fnv1a64": report["curves"]["fnv1a64"]}
    assert our_report["ms_per_frame"] > 0
    assert our_report["setup_ms"] > 0
    # Each residual joint's worst position (cm) and rotation (deg) apart, in rig-invert's order (the largest error on
    # the target tolerance's scale first); the clip's worst rotation is its joint's own.
    assert list(our_report["residual_joints"]) == list(report["residual_joints"])
    hand = our_report["residual_joints"][our_report["worst_rotation_joint"]]
    assert list(hand) == ["frames", "worst_position_error_cm", "worst_rotation_error_deg"]
    assert hand["worst_rotation_error_deg"] == our_report["max_rotation_error_deg"]
    assert hand["worst_position_error_cm"] < our_report["max_position_error_cm"]


def test_options_equal_rig_invert_flags(learned_biped, tmp_path):
    need_cmu_clip()
    file, _ = learned_biped
    expected, names, report = rig_invert(file, tmp_path, "--clip", CMU_CLIP, "--map", CMU_MAP, "--frames", "100:220",
                                         "--threads", "2", "--restart-every", "50", "--polish", "1")
    values, _, ours = riginv.Approximation.load(file).invert(CMU_CLIP, rig=BIPED, map=CMU_MAP, threads=2,
                                                             restart_every=50, polish=1, frames="100:220")
    assert np.array_equal(values, expected)
    assert without(ours, *VOLATILE) == without(report, *VOLATILE)
    assert ours["lead_in_frames"] == 49 and ours["frames"] == 121  # from the restart at clip index 50 (frame 51)


def test_arrays_equal_the_same_targets_as_a_json_clip(learned_biped, tmp_path):
    need_cmu_clip()
    file, _ = learned_biped
    # The clip's own skeleton driven by it (bvh2rig --with-motion): world matrices per joint, as arrays here
    # and as graph-eval's JSON for rig-invert.
    rig = tmp_path / "cmu.yaml"
    code, _, err = run("bvh2rig", CMU_CLIP, "-o", rig, "--with-motion")
    assert code == 0, err
    worlds = riginv.Graph.load(rig).evaluate(get="*.worldMatrix", frames="1:90")
    targets = {plug[: -len(".worldMatrix")]: matrices for plug, matrices in worlds.items()}
    clip = tmp_path / "clip.json"
    code, _, err = run("graph-eval", rig, "--get", "*.worldMatrix", "--frames", "1:90", "-o", clip)
    assert code == 0, err
    expected, _, report = rig_invert(file, tmp_path, "--clip", clip, "--map", CMU_MAP)

    values, _, ours = riginv.Approximation.load(file).invert(targets, rig=BIPED, map=CMU_MAP)
    assert np.array_equal(values, expected)
    # Arrays number their frames from 0, the JSON clip from 1; the curves' text holds the numbers.
    assert ours["clip"] is None and report["clip"] == str(clip)
    # Arrays have no file to say where they come from.
    assert ours["clip_source"] is None
    # The map's scale is the units of the targets, said on the clip's line.
    assert report["clip_source"] == ("JSON world matrices (Y up, as graph-eval writes them), units x5.64444 to cm "
                                     f"(by the map {CMU_MAP})")
    assert [f["frame"] for f in ours["per_frame"]] == list(range(90))
    assert ours["worst_frame"] == report["worst_frame"] - 1
    assert ours["worst_rotation_frame"] == report["worst_rotation_frame"] - 1
    shifted = [dict(f, frame=f["frame"] - 1) for f in report["per_frame"]]
    assert ours["per_frame"] == shifted
    frames = ("clip", "clip_source", "per_frame", "worst_frame", "worst_rotation_frame")
    assert without(ours, *VOLATILE, *frames) == without(report, *VOLATILE, *frames)


def test_learned_in_python_inverts_as_rig_learn_s_file(learned_biped):
    need_cmu_clip()
    file, _ = learned_biped
    spec = biped_spec()
    learned = riginv.learn(BIPED, params=spec["params"], outputs=spec["outputs"], ranges=spec["ranges"])
    ours, _, _ = learned.invert(CMU_CLIP, rig=BIPED, map=CMU_MAP, frames="1:240")
    theirs, _, report = riginv.Approximation.load(file).invert(CMU_CLIP, rig=BIPED, map=CMU_MAP, frames="1:240")
    assert np.array_equal(ours, theirs)
    assert report["approximation"] == str(file)


def test_progress_and_its_exceptions(learned_biped):
    need_cmu_clip()
    approx = riginv.Approximation.load(learned_biped[0])
    calls = []
    approx.invert(CMU_CLIP, rig=BIPED, map=CMU_MAP, frames="1:30", progress=lambda d, t: calls.append((d, t)))
    assert calls == [(done, 30) for done in range(1, 31)]

    def stop(done, total):
        if done == 5:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        approx.invert(CMU_CLIP, rig=BIPED, map=CMU_MAP, frames="1:30", progress=stop)


def test_the_gil_is_released_while_solving(learned_biped):
    need_cmu_clip()
    approx = riginv.Approximation.load(learned_biped[0])
    # The whole clip on one thread: about a second.
    share = share_of_time_another_thread_runs(lambda: approx.invert(CMU_CLIP, rig=BIPED, map=CMU_MAP))
    assert share > 0.3


def test_ctrl_c_stops_a_solve(learned_biped):
    need_cmu_clip()
    approx = riginv.Approximation.load(learned_biped[0])

    class Stop(Exception):
        pass

    def handler(signum, frame):
        raise Stop

    previous = signal.signal(signal.SIGINT, handler)
    try:
        # SIGINT's handler runs in the solving thread within 0.1 s of the signal (no progress callable given).
        threading.Timer(0.1, _thread.interrupt_main).start()
        start = time.perf_counter()
        with pytest.raises(Stop):
            approx.invert(CMU_CLIP, rig=BIPED, map=CMU_MAP)  # about a second
        assert time.perf_counter() - start < 0.6
    finally:
        signal.signal(signal.SIGINT, previous)


def identity_frames(count):
    return np.repeat(np.eye(4)[None], count, axis=0)


@pytest.mark.parametrize("value, message", [
    (np.zeros((2, 3, 4)), "targets['Hips']: expected an array of shape (F, 4, 4), got shape (2, 3, 4)"),
    (np.zeros(16), "targets['Hips']: expected an array of shape (F, 4, 4), got shape (16,)"),
    (np.zeros((2, 16)), "targets['Hips']: expected an array of shape (F, 4, 4), got shape (2, 16)"),
    (np.zeros((0, 4, 4)), "targets['Hips']: no frames (shape (0, 4, 4)); give at least one"),
    (identity_frames(2).astype(np.float32),
     "targets['Hips']: expected dtype float64, got float32 (shape (2, 4, 4)); convert it with .astype(numpy.float64)"),
    (np.zeros((2, 4, 4), dtype=np.int64),
     "targets['Hips']: expected dtype float64, got int64 (shape (2, 4, 4)); convert it with .astype(numpy.float64)"),
    (identity_frames(2).tolist(),
     "targets['Hips']: expected a NumPy array of shape (F, 4, 4) and dtype float64, got a list"),
])
def test_wrong_arrays_are_refused(learned_biped, value, message):
    approx = riginv.Approximation.load(learned_biped[0])
    with pytest.raises(riginv.Error) as caught:
        approx.invert({"Hips": value}, rig=BIPED)
    assert str(caught.value) == message


def test_wrong_dicts_are_refused(learned_biped):
    approx = riginv.Approximation.load(learned_biped[0])
    cases = [
        ({"Hips": identity_frames(3), "Spine": identity_frames(2)},
         "targets['Spine']: 2 frames where targets['Hips'] has 3; every joint needs the same frames"),
        ({}, "targets: an empty dict; give joint names with (F, 4, 4) float64 arrays"),
        ({1: identity_frames(2)}, "targets: a key is a int, not a joint name (str)"),
    ]
    for targets, message in cases:
        with pytest.raises(riginv.Error) as caught:
            approx.invert(targets, rig=BIPED)
        assert str(caught.value) == message
    with pytest.raises(riginv.Error, match="^targets: "):  # no joint is an output of the approximation
        approx.invert({"nobody": identity_frames(2)}, rig=BIPED)
    with pytest.raises(riginv.Error, match="^targets: expected a dict"):
        approx.invert(42, rig=BIPED)


def test_errors_are_rig_invert_messages(learned_biped, tmp_path):
    need_cmu_clip()
    file, _ = learned_biped
    approx = riginv.Approximation.load(file)
    base = [file, "-o", tmp_path / "c.json", "--map", CMU_MAP]
    raises_like("rig-invert", [*base, "--rig", BIPED, "--clip", "no_such.bvh"],
                lambda: approx.invert("no_such.bvh", rig=BIPED, map=CMU_MAP))
    raises_like("rig-invert", [file, "-o", tmp_path / "c.json", "--rig", BIPED, "--clip", CMU_CLIP, "--map",
                               "no_such_map.yaml"],
                lambda: approx.invert(CMU_CLIP, rig=BIPED, map="no_such_map.yaml"))
    raises_like("rig-invert", [*base, "--rig", "rigs/examples/arm.yaml", "--clip", CMU_CLIP],
                lambda: approx.invert(CMU_CLIP, rig="rigs/examples/arm.yaml", map=CMU_MAP))
    raises_like("rig-invert", [*base, "--rig", BIPED, "--clip", CMU_CLIP, "--frames", "1:99999"],
                lambda: approx.invert(CMU_CLIP, rig=BIPED, map=CMU_MAP, frames="1:99999"))
    raises_like("rig-invert", [*base, "--rig", BIPED, "--clip", "rigs/biped.yaml"],
                lambda: approx.invert("rigs/biped.yaml", rig=BIPED, map=CMU_MAP))
    # A map naming a joint the targets lack names the targets as the command line names the clip.
    bad_map = tmp_path / "map.yaml"
    bad_map.write_text("joints:\n  Nobody: Hips\n")
    with pytest.raises(riginv.Error) as caught:
        approx.invert({"Hips": identity_frames(2)}, rig=BIPED, map=bad_map)
    assert str(caught.value) == \
        f"{bad_map}:2: the map renames 'Nobody', which targets does not have; check the joint name"


# The solve settings (app/common/solve_settings.h): each keyword and rig-invert's flag of the same name ('_' for '-').
SETTINGS = [
    (["--threads", "3"], {"threads": 3}),
    (["--no-partition"], {"no_partition": True}),
    (["--block-by-block"], {"block_by_block": True}),
    (["--jacobian", "fd"], {"jacobian": "fd"}),
    (["--polish", "1"], {"polish": 1}),
    (["--restart-every", "7"], {"restart_every": 7}),
    (["--rest-starts"], {"rest_starts": True}),
    (["--hybrid"], {"hybrid": True}),
    (["--term", "position"], {"term": "position"}),
]


@pytest.mark.parametrize("flags, keywords", SETTINGS, ids=[flags[0] for flags, _ in SETTINGS])
def test_each_setting_keyword_equals_rig_invert_s_flag(learned_biped, tmp_path, flags, keywords):
    need_cmu_clip()
    file, _ = learned_biped
    expected, _, report = rig_invert(file, tmp_path, "--clip", CMU_CLIP, "--map", CMU_MAP, "--frames", "1:20", *flags)
    values, _, ours = riginv.Approximation.load(file).invert(CMU_CLIP, rig=BIPED, map=CMU_MAP, frames="1:20",
                                                             **keywords)
    assert np.array_equal(values, expected)
    assert without(ours, *VOLATILE) == without(report, *VOLATILE)


def keyword_message(line):
    """rig-invert's message with each flag spelled as its keyword: '--restart-every 0' as 'restart_every 0'."""
    return re.sub(r"--([a-z-]+)", lambda flag: flag.group(1).replace("-", "_"), line)


BAD_SETTINGS = [
    (["--threads", "2000"], {"threads": 2000}),
    (["--polish", "-1"], {"polish": -1}),
    (["--restart-every", "0"], {"restart_every": 0}),
    (["--jacobian", "exact"], {"jacobian": "exact"}),
    (["--term", "aim"], {"term": "aim"}),
    (["--hybrid", "--polish", "2"], {"hybrid": True, "polish": 2}),
]


@pytest.mark.parametrize("flags, keywords", BAD_SETTINGS, ids=[" ".join(flags) for flags, _ in BAD_SETTINGS])
def test_a_bad_setting_is_rig_invert_s_message_naming_the_keyword(learned_biped, tmp_path, flags, keywords):
    file, _ = learned_biped
    expected = error_line("rig-invert", file, "--rig", BIPED, "--clip", "no_such.bvh", "-o", tmp_path / "c.json",
                          *flags)
    with pytest.raises(riginv.Error) as caught:
        riginv.Approximation.load(file).invert({"Hips": identity_frames(2)}, rig=BIPED, **keywords)
    assert str(caught.value) == keyword_message(expected)


def test_the_stub_has_the_module_s_keywords_and_defaults():
    """riginv.pyi's invert() against the module's own signature (pybind11's first docstring line)."""
    stub = ast.parse((SOURCE / "python/riginv.pyi").read_text())
    approximation = next(node for node in stub.body if isinstance(node, ast.ClassDef) and node.name == "Approximation")
    invert = next(node for node in approximation.body if isinstance(node, ast.FunctionDef) and node.name == "invert")
    positional = [(a.arg, ast.literal_eval(d)) for a, d in
                  zip(invert.args.args[-len(invert.args.defaults):], invert.args.defaults)]
    keywords = [(a.arg, ast.literal_eval(d)) for a, d in zip(invert.args.kwonlyargs, invert.args.kw_defaults)]
    signature = riginv.Approximation.invert.__doc__.splitlines()[0]
    module = [(name, ast.literal_eval(value)) for name, value in re.findall(r"(\w+): object = ([^,)]+)", signature)]
    assert positional + keywords == module
    assert "*, plugins" in signature


def test_a_changed_rig_is_a_warning_as_in_rig_invert(learned_biped, tmp_path):
    need_cmu_clip()
    file, _ = learned_biped
    rig = tmp_path / "biped.yaml"
    shutil.copy(SOURCE / BIPED, rig)
    with open(rig, "a") as f:
        f.write("# edited since learning\n")
    code, _, err = run("rig-invert", file, "--rig", rig, "--clip", CMU_CLIP, "--map", CMU_MAP, "--frames", "1:5",
                       "-o", tmp_path / "c.json", "-q")
    assert code == 0 and err.startswith("warning: "), err
    with pytest.warns(RuntimeWarning) as warned:
        riginv.Approximation.load(file).invert(CMU_CLIP, rig=rig, map=CMU_MAP, frames="1:5")
    assert [str(w.message) for w in warned] == [err.strip()[len("warning: "):]]


def test_an_unsaved_approximation_is_named_by_its_rig():
    approx = riginv.learn("rigs/examples/arm.yaml", params=["shoulder.rotate?"])
    with pytest.raises(riginv.Error) as caught:
        approx.invert({"shoulder": identity_frames(1)}, rig=BIPED)
    assert str(caught.value).startswith("the approximation learned from rigs/examples/arm.yaml: ")


def test_a_shared_clip_from_another_skeleton(tmp_path):
    """Mocap from another source (../shared/motion, absent on a fresh clone): its bvh2rig rig learned here and by
    rig-learn, inverted here and by rig-invert, gives the same curves."""
    clip = SOURCE.parent / "shared/motion/rotate_hip.bvh"
    if not clip.exists():
        pytest.skip(f"{clip} is not here (the shared folder)")
    rig = tmp_path / "skeleton.yaml"
    code, _, err = run("bvh2rig", clip, "-o", rig)
    assert code == 0, err
    params = ["*.rotate?"]
    approx_file = tmp_path / "skeleton.approx.yaml"
    code, _, err = run("rig-learn", rig, "--params", *params, "-o", approx_file)
    assert code == 0, err
    learned = riginv.learn(rig, params=params)
    curves = tmp_path / "curves.json"
    code, _, err = run("rig-invert", approx_file, "--rig", rig, "--clip", clip, "-o", curves, "-q")
    assert code == 0, err
    values, names, _ = learned.invert(clip, rig=rig)
    assert np.array_equal(values, np.array([[frame[n] for n in names] for frame in json.loads(curves.read_text())]))


def test_whole_number_options_take_numpy_integers_and_refuse_the_rest(learned_biped):
    approx = riginv.Approximation.load(learned_biped[0])
    targets = {"Hips": identity_frames(2)}
    plain, _, _ = approx.invert(targets, rig=BIPED, threads=1, restart_every=120, polish=0)
    numpy, _, _ = approx.invert(targets, rig=BIPED, threads=np.int64(1), restart_every=np.int32(120),
                                polish=np.uint8(0))
    assert np.array_equal(plain, numpy)
    cases = [
        ({"threads": 10**400},
         f"threads: {str(10**400)[:80]}... (401 characters) is out of range; give a whole number from -2147483648 "
         "to 2147483647"),
        ({"threads": 1.5}, "threads: expected a whole number, got a float"),
        ({"polish": np.float64(1)}, "polish: expected a whole number, got a float64"),
        ({"restart_every": "10"}, "restart_every: expected a whole number, got a str"),
        ({"restart_every": True}, "restart_every: expected a whole number, got a bool"),
        ({"frames": 3}, "frames: expected a str, got a int"),
        ({"plugins": "p"}, "plugins: expected a list of str, got a str; put it in a list: ['p']"),
        ({"progress": 3}, "progress: expected None or a callable, got a int"),
        ({"map": 3}, "map: expected a path (str or os.PathLike), got a int"),
    ]
    for arguments, message in cases:
        with pytest.raises(riginv.Error) as caught:
            approx.invert(targets, rig=BIPED, **arguments)
        assert str(caught.value) == message


@pytest.mark.parametrize("shift", [1e160, 1e300])
def test_targets_too_far_for_the_cost_fail_every_frame_with_their_error(shift):
    """The arm's world matrices with every translation 1e160 (residuals finite, their squares not) or 1e300 cm
    away: every frame non-finite (its cost overflows), counted as failed, the error reported as it is, as
    rig-invert does (tests/tools/far_targets_test.cpp)."""
    worlds = riginv.Graph.load(ARM).evaluate(get="*.worldMatrix", frames="1:4")
    targets = {plug[: -len(".worldMatrix")]: matrices.copy() for plug, matrices in worlds.items()}
    for matrices in targets.values():
        matrices[:, :3, 3] += shift
    approx = riginv.learn(ARM, params=["shoulder.rotate?", "wrist.rotate?"])
    values, _, report = approx.invert(targets, rig=ARM)
    assert values.shape[0] == 4
    assert report["failed_frames"] == 4
    assert report["status_frames"]["non_finite"] == 4 and report["status_frames"]["best_fit"] == 0
    assert report["first_failure"] == {"frame": 0, "status": "non-finite", "joint": "shoulder", "left_range": None}
    # sqrt(3) * shift: a shift on each axis, measured without overflow.
    assert 1.7 * shift <= report["max_position_error_cm"] <= 1.8 * shift
    assert all(f["termination"] == "noConvergence" for f in report["per_frame"])


def test_targets_of_nan_measure_nothing_and_report_null_not_0():
    """NaN arrays: every frame invalid targets, and nothing measured reads as null (None), never as an exact 0."""
    worlds = riginv.Graph.load(ARM).evaluate(get="*.worldMatrix", frames="1:3")
    targets = {plug[: -len(".worldMatrix")]: np.full_like(matrices, np.nan) for plug, matrices in worlds.items()}
    approx = riginv.learn(ARM, params=["shoulder.rotate?", "wrist.rotate?"])
    _, _, report = approx.invert(targets, rig=ARM)
    assert report["status_frames"]["invalid_targets"] == 3 and report["failed_frames"] == 3
    for key in ("max_position_error_cm", "worst_joint", "worst_frame", "mean_position_error_cm",
                "max_rotation_error_deg", "worst_rotation_joint", "worst_rotation_frame", "mean_rotation_error_deg",
                "max_model_gap_cm"):
        assert report[key] is None, key
    for frame in report["per_frame"]:
        assert [frame[key] for key in ("position_error_cm", "worst_joint", "rotation_error_deg",
                                       "worst_rotation_joint", "model_gap_cm")] == [None] * 5


def test_an_empty_take_or_contacts_is_refused_not_read_as_none():
    approx = riginv.learn(ARM, params=["shoulder.rotate?", "elbow.rotate?"])
    clip = SOURCE / "tests/corpus/clips/arm.json"
    with pytest.raises(riginv.Error) as caught:
        approx.invert(clip, rig=ARM, take="")
    assert str(caught.value) == "take: the value is empty; give a take's name or 0-based index, or None for the first"
    with pytest.raises(riginv.Error) as caught:
        approx.invert(clip, rig=ARM, contacts="")
    assert str(caught.value) == "contacts: the value is empty; give 'auto' or a contacts file, or None"


def test_an_fbx_take_equals_rig_invert(tmp_path):
    """An animation assimp reads (the hand-written Z-up leg in inches, tests/corpus/clips), its take by name or
    index: the values and report of rig-invert --take, and the same one-line error for a take it lacks."""
    leg = SOURCE / "tests/corpus/clips/leg_z_up_inches.fbx"
    rig = tmp_path / "leg.yaml"
    code, _, err = run("skel2rig", leg, "-o", rig)
    assert code == 0, err
    learned = riginv.learn(str(rig), params=["knee.rotate?", "hip.rotate?"], outputs=["hip", "knee", "ankle"])
    file = tmp_path / "leg.approx.yaml"
    learned.save(str(file))
    curves, report = tmp_path / "curves.json", tmp_path / "report.json"
    code, _, err = run("rig-invert", file, "--rig", rig, "--clip", leg, "--take", "bend", "-o", curves,
                       "--report-json", report, "-q")
    assert code == 0, err
    expected = read_json(report)
    for take in ("bend", "0"):
        values, names, ours = learned.invert(str(leg), rig=str(rig), take=take)
        assert values.shape == (3, len(names))
        assert ours["clip_source"] == expected["clip_source"] == (
            "FBX, units x2.54 to cm (FBX UnitScaleFactor 2.54), up axis Z, take 0 'bend' of 1, 2 fps")
        assert ours["max_position_error_cm"] < 1e-6
    raises_like("rig-invert", [file, "--rig", rig, "--clip", leg, "--take", "run", "-o", curves],
                lambda: learned.invert(str(leg), rig=str(rig), take="run"))


def test_contacts_equal_rig_invert_s(learned_biped, tmp_path):
    need_cmu_clip()
    file, _ = learned_biped
    expected, _, report = rig_invert(file, tmp_path, "--clip", CMU_CLIP, "--map", CMU_MAP, "--frames", "1:300",
                                     "--threads", "1", "--contacts", "auto")
    values, _, ours = riginv.Approximation.load(file).invert(CMU_CLIP, rig=BIPED, map=CMU_MAP, frames="1:300",
                                                             contacts="auto")
    assert np.array_equal(values, expected)
    assert without(ours, *VOLATILE) == without(report, *VOLATILE)
    assert ours["contacts"]["count"] >= 2 and ours["contacts"]["max_slide_cm"] < 0.01
    missing = tmp_path / "missing.yaml"
    code, _, err = run("rig-invert", file, "--rig", BIPED, "--clip", CMU_CLIP, "--map", CMU_MAP, "-o",
                       tmp_path / "c.json", "--contacts", missing)
    assert code == 2 and err.startswith(f"error: --contacts: {missing}: cannot open")
    # The same line, naming the keyword.
    with pytest.raises(riginv.Error) as caught:
        riginv.Approximation.load(file).invert(CMU_CLIP, rig=BIPED, map=CMU_MAP, contacts=missing)
    assert "error: " + str(caught.value) + "\n" == err.replace("--contacts", "contacts", 1)
