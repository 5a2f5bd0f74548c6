"""riginv.learn against rig-learn: the same approximation and report, the same errors."""

import shutil

import numpy as np
import pytest
import yaml

import riginv
from conftest import (ARM, ARM_PARAMS, BIPED, CMU_CLIP, CMU_MAP, biped_spec, need_cmu_clip, raises_like, read_json, run,
                      share_of_time_another_thread_runs)

# Wall times: they differ from run to run.
TIMES = ("seconds", "load_seconds")


def without(report, *keys):
    return {k: v for k, v in report.items() if k not in keys}


def approximation_file(path):
    """An approximation file without its training time (the only figure that differs from run to run)."""
    with open(path) as f:
        data = yaml.safe_load(f)
    del data["training"]["seconds"]
    return data


def test_biped_report_equals_rig_learn(learned_biped, tmp_path):
    cli_file, cli_report = learned_biped
    spec = biped_spec()
    approx = riginv.learn(BIPED, params=spec["params"], outputs=spec["outputs"], ranges=spec["ranges"])
    report = approx.report
    assert report["approximation"] is None and report["written"] is False
    named = ("approximation", "written")
    assert without(report, *TIMES, *named) == without(cli_report, *TIMES, *named)
    assert report["within_epsilon"] is True
    assert approx.parameters == cli_report["modelled"]
    assert approx.outputs == [frame["name"] for frame in cli_report["frames"]]
    assert approx.rig_file == BIPED and approx.file is None

    # Saved, the file is rig-learn's, and the report names it as rig-learn's does.
    saved = tmp_path / "biped.approx.yaml"
    approx.save(saved)
    assert approximation_file(saved) == approximation_file(cli_file)
    assert approx.file == str(saved)
    assert approx.report["approximation"] == str(saved) and approx.report["written"] is True
    loaded = riginv.Approximation.load(saved)
    assert loaded.parameters == approx.parameters and loaded.report is None and loaded.file == str(saved)


def test_arm_with_options_equals_rig_learn(tmp_path):
    out, json_report = tmp_path / "arm.yaml", tmp_path / "arm.json"
    code, _, err = run("rig-learn", ARM, "--params", *ARM_PARAMS, "--epsilon", "0.01", "--orderer", "talk",
                       "--world-space", "-o", out, "--report-json", json_report)
    assert code == 0, err
    approx = riginv.learn(ARM, params=ARM_PARAMS, epsilon=0.01, orderer="talk", world_space=True)
    approx.save(tmp_path / "ours.yaml")
    assert without(approx.report, *TIMES, "approximation") == without(read_json(json_report), *TIMES, "approximation")
    assert approximation_file(tmp_path / "ours.yaml") == approximation_file(out)


def test_set_holds_plugs_as_rig_learn_does(tmp_path):
    out = tmp_path / "ik.yaml"
    params, outputs = ["root_ctrl.translate?", "L_foot_fk_ctrl.rotate?"], ["Hips", "LeftFoot"]
    code, _, err = run("rig-learn", BIPED, "--params", *params, "--outputs", *outputs, "--set",
                       "L_leg_settings.ikFk=1", "-o", out)
    assert code == 0, err
    approx = riginv.learn(BIPED, params=params, outputs=outputs, set={"L_leg_settings.ikFk": 1})
    assert approx.held == {"L_leg_settings.ikFk": 1.0}
    approx.save(tmp_path / "ours.yaml")
    assert approximation_file(tmp_path / "ours.yaml") == approximation_file(out)
    assert riginv.Approximation.load(out).held == approx.held
    raises_like("rig-learn", [BIPED, "--params", *params, "--set", "L_leg_settings.ikFk=2", "-o", out],
                lambda: riginv.learn(BIPED, params=params, set={"L_leg_settings.ikFk": 2}))
    with pytest.raises(riginv.Error) as caught:
        riginv.learn(BIPED, params=params, set={"L_leg_settings.ikFk": "on"})
    assert str(caught.value) == "set['L_leg_settings.ikFk']: expected a number (the rig file's units), got a str"


def test_progress_is_called_with_the_fraction_done():
    calls = []
    riginv.learn(ARM, params=ARM_PARAMS, progress=lambda done, total: calls.append((done, total)))
    assert calls and all(total == 1.0 and 0.0 <= done <= 1.0 for done, total in calls)
    assert calls[-1] == (1.0, 1.0)


def test_an_exception_in_progress_stops_learning():
    def stop(done, total):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        riginv.learn(ARM, params=ARM_PARAMS, progress=stop)


def test_over_epsilon_is_returned_but_not_saved(tmp_path):
    # The nasty rig's sliding knee misses 1e-5 even with its raised budget (docs/rig-learn.md).
    args = ["rigs/nasty.yaml", "--params", "nasty_ctrl.kneeBend", "--epsilon", "0.00001"]
    code, _, err = run("rig-learn", *args, "-o", tmp_path / "k.yaml")
    assert code == 3
    approx = riginv.learn("rigs/nasty.yaml", params=["nasty_ctrl.kneeBend"], epsilon=0.00001)
    assert approx.report["within_epsilon"] is False
    target = tmp_path / "k.yaml"
    failure = err.strip()[len("error: "):].split(f"; {target} not written")[0]
    with pytest.raises(riginv.Error) as caught:
        approx.save(target)
    assert str(caught.value) == f"{failure}; {target} not written (save(path, allow_inexact=True) writes it anyway)"
    assert not target.exists()
    approx.save(target, allow_inexact=True)
    assert target.exists()


def test_errors_are_rig_learn_messages(tmp_path):
    out = tmp_path / "a.yaml"
    raises_like("rig-learn", [ARM, "--params", "shoulder.rotatq?", "-o", out],
                lambda: riginv.learn(ARM, params=["shoulder.rotatq?"]))
    raises_like("rig-learn", ["rigs/no_such_rig.yaml", "--params", "a.b", "-o", out],
                lambda: riginv.learn("rigs/no_such_rig.yaml", params=["a.b"]))
    raises_like("rig-learn", [ARM, "--params", *ARM_PARAMS, "--outputs", "nothing*", "-o", out],
                lambda: riginv.learn(ARM, params=ARM_PARAMS, outputs=["nothing*"]))
    raises_like("rig-learn", [ARM, "--params", *ARM_PARAMS, "--epsilon", "0", "-o", out],
                lambda: riginv.learn(ARM, params=ARM_PARAMS, epsilon=0))
    raises_like("rig-learn", [ARM, "--params", *ARM_PARAMS, "--epsilon", "nan", "-o", out],
                lambda: riginv.learn(ARM, params=ARM_PARAMS, epsilon=float("nan")))
    # CLI11 checks --orderer on the command line, with the same words and its usage hint.
    cli = raises_like_prefix("rig-learn", [ARM, "--params", *ARM_PARAMS, "--orderer", "fast", "-o", out],
                             lambda: riginv.learn(ARM, params=ARM_PARAMS, orderer="fast"))
    assert cli.endswith("; run 'rig-learn --help' for usage")
    with pytest.raises(riginv.Error, match="^params: give one or more parameter plug globs"):
        riginv.learn(ARM, params=[])
    raises_like("rig-invert", ["rigs/biped.yaml", "--rig", BIPED, "--clip", "x.bvh", "-o", tmp_path / "c.json"],
                lambda: riginv.Approximation.load("rigs/biped.yaml"))
    # Never over the rig it was learned from (a copy here: the check is what is tested).
    rig = tmp_path / "arm.yaml"
    shutil.copy(ARM, rig)
    with pytest.raises(riginv.Error, match="is the rig file"):
        riginv.learn(rig, params=ARM_PARAMS).save(rig)


def raises_like_prefix(tool, args, call):
    """As conftest.raises_like, for a message the command line ends with its usage hint."""
    code, _, err = run(tool, *args)
    assert code == 2
    line = err.strip()[len("error: "):]
    with pytest.raises(riginv.Error) as caught:
        call()
    assert line.startswith(str(caught.value) + "; ")
    return line


def test_the_gil_is_released_while_learning():
    # Every joint of the biped as an output, every pair tested on the rig: about a second of learning, long
    # beside the switch interval (the result is over epsilon: docs/rig-learn.md, the trap).
    params = biped_spec()["params"]
    assert share_of_time_another_thread_runs(lambda: riginv.learn(BIPED, params=params, orderer="talk")) > 0.3


def test_numpy_numbers_are_numbers_and_bad_arguments_are_one_line_errors(tmp_path):
    params = ["root_ctrl.translate?"]
    for value in (np.int64(1), np.float32(1.0), np.float64(1.0)):
        approx = riginv.learn(BIPED, params=params, outputs=["Hips"], epsilon=np.float64(0.001),
                              set={"L_leg_settings.ikFk": value})
        assert approx.held == {"L_leg_settings.ikFk": 1.0}
    with pytest.raises(riginv.Error) as caught:
        approx.save(tmp_path / "a.yaml", allow_inexact="yes")
    assert str(caught.value) == "allow_inexact: expected True or False, got a str"
    approx.save(tmp_path / "a.yaml", allow_inexact=np.bool_(False))
    assert (tmp_path / "a.yaml").exists()
    cases = [
        ({"set": {"L_leg_settings.ikFk": 10**400}},
         f"set['L_leg_settings.ikFk']: {str(10**400)[:80]}... (401 characters) is not a finite number; give a finite "
         "number in the rig file's units (degrees for angles)"),
        ({"set": {"L_leg_settings.ikFk": float("inf")}},
         "set['L_leg_settings.ikFk']: inf is not a finite number; give a finite number in the rig file's units "
         "(degrees for angles)"),
        ({"set": {"L_leg_settings.ikFk": np.bool_(True)}},
         "set['L_leg_settings.ikFk']: expected a number (the rig file's units), got a bool_"),
        ({"epsilon": "small"}, "epsilon: expected a number, got a str"),
        ({"params": "root_ctrl.translate?"},
         "params: expected a list of str, got a str; put it in a list: ['root_ctrl.translate?']"),
        ({"params": params, "outputs": [1]}, "outputs: expected a list of str, got a list holding a int"),
        ({"orderer": 1}, "orderer: expected a str, got a int"),
        ({"world_space": 1}, "world_space: expected True or False, got a int"),
        ({"set": [1]}, "set: expected None or a dict {plug: value}, got a list"),
        ({"progress": "yes"}, "progress: expected None or a callable, got a str"),
    ]
    for arguments, message in cases:
        with pytest.raises(riginv.Error) as caught:
            riginv.learn(BIPED, **{"params": params, **arguments})
        assert str(caught.value) == message
    # An int past the largest double is infinite, refused as rig-learn refuses --epsilon inf.
    raises_like("rig-learn", [BIPED, "--params", *params, "--epsilon", "inf", "-o", "/dev/null"],
                lambda: riginv.learn(BIPED, params=params, epsilon=10**400))


def test_auto_on_a_maya_scene_learns_as_rig_learn(tmp_path):
    """params=["auto"] is rig-learn --params auto; a Maya scene's outputs are auto by default, as rig-learn's."""
    scene = "tests/corpus/maya/auto_controls.ma"
    cli_file, cli_json = tmp_path / "auto.yaml", tmp_path / "report.json"
    code, _, _ = run("rig-learn", scene, "--params", "auto", "-o", cli_file, "--report-json", cli_json,
                     "--allow-inexact")
    assert code == 0
    approx = riginv.learn(scene, params=["auto"])
    assert approx.parameters == read_json(cli_json)["modelled"]
    assert "elbow.rotateZ" in approx.parameters  # keyed by a time curve: cut, and learned
    assert approx.held == {"arm_ctrl.mode": 1.0}
    approx.save(tmp_path / "py.yaml", allow_inexact=True)
    assert approximation_file(tmp_path / "py.yaml") == approximation_file(cli_file)


def test_ranges_from_equals_rig_learn(tmp_path):
    """learn(ranges_from=) is rig-learn --ranges-from: the same ranges widened, the same approximation."""
    need_cmu_clip()
    spec = biped_spec()
    out, json_report = tmp_path / "cli.yaml", tmp_path / "cli.json"
    spec_file = tmp_path / "spec.yaml"
    spec_file.write_text(yaml.safe_dump({"params": spec["params"], "outputs": spec["outputs"]}))
    code, _, err = run("rig-learn", BIPED, "--spec", spec_file, "--ranges-from", CMU_CLIP, "--map", CMU_MAP,
                       "--frames", "1:240", "-o", out, "--report-json", json_report)
    assert code == 0, err
    approx = riginv.learn(BIPED, params=spec["params"], outputs=spec["outputs"], ranges_from=CMU_CLIP,
                          ranges_map=CMU_MAP, ranges_frames="1:240")
    cli = read_json(json_report)["ranges_from"]
    assert approx.report["ranges_from"] == cli
    widened = {w["parameter"]: w["range"] for w in cli["widened"]}
    assert widened["L_knee_fk_ctrl.rotateX"] == [-90, 111] and widened["R_knee_fk_ctrl.rotateX"] == [-90, 112]
    approx.save(tmp_path / "ours.yaml")
    assert approximation_file(tmp_path / "ours.yaml") == approximation_file(out)


def test_ranges_errors():
    with pytest.raises(riginv.Error) as caught:
        riginv.learn(ARM, params=ARM_PARAMS, ranges={"nothing.*": (0, 1)})
    assert str(caught.value) == ("ranges nothing.*: matches no parameter; name one of those the parameter globs "
                                 "choose (--params, the spec's params:)")
    with pytest.raises(riginv.Error) as caught:
        riginv.learn(ARM, params=ARM_PARAMS, ranges_map=CMU_MAP)
    assert str(caught.value) == "ranges_map, ranges_take and ranges_frames: give ranges_from, the clip they are about"
