"""riginv.Graph against graph-eval: the same values bit for bit, the same errors."""

import json
import os
import signal
import subprocess
import time

import numpy as np
import pytest

import riginv
from conftest import ARM, BIPED, raises_like, run


def graph_eval_json(*args):
    code, out, err = run("graph-eval", *args)
    assert code == 0, err
    return json.loads(out)


def assert_same_as_graph_eval(result, frames_json):
    """Every plug graph-eval printed, frame by frame, equals the module's array row exactly."""
    assert list(result) == [key for key in frames_json[0] if key != "frame"]
    for f, frame in enumerate(frames_json):
        for plug, value in frame.items():
            if plug == "frame":
                continue
            ours = result[plug][f]
            if isinstance(ours, str):
                assert ours == value, plug
                continue
            if isinstance(value, str):  # an enum: its name in graph-eval, its index here
                assert np.issubdtype(result[plug].dtype, np.integer), plug
                continue
            expected = np.array(value, dtype=float)  # null (not finite) as NaN
            assert np.array_equal(np.asarray(ours, dtype=float), expected, equal_nan=True), (plug, f, ours, value)


def test_every_output_over_frames_equals_graph_eval():
    result = riginv.Graph.load(ARM).evaluate(frames="1:24")
    assert_same_as_graph_eval(result, graph_eval_json(ARM, "--frames", "1:24"))


def test_shapes_and_units():
    graph = riginv.Graph.load(ARM)
    result = graph.evaluate(get=["wrist.worldMatrix", "elbow.rotateZ", "shoulder.rotate", "*.rotateOrder"],
                            frames=[1, 2, 3])
    assert result["wrist.worldMatrix"].shape == (3, 4, 4)
    assert result["wrist.worldMatrix"].dtype == np.float64
    assert result["elbow.rotateZ"].shape == (3,)
    assert result["shoulder.rotate"].shape == (3, 3)
    assert result["wrist.rotateOrder"].dtype == np.int64
    # Degrees, as graph-eval prints them (docs/graph-eval.md: frames 1 to 3 of the elbow's driven key).
    assert result["elbow.rotateZ"][1] == pytest.approx(2.794891059353869, abs=0)
    assert graph.time == 3
    # No frames: one frame at the current time.
    assert graph.evaluate(get="elbow.rotateZ")["elbow.rotateZ"].shape == (1,)


def test_sets_and_biped_world_matrices_equal_graph_eval():
    sets = {"spine_ctrl.bendForward": 30, "L_arm_fk_ctrl.rotate": [10, -20.5, 45], "root_ctrl.translateX": 12.25}
    result = riginv.Graph.load(BIPED).evaluate(get=["*.worldMatrix", "spine_ctrl.bend*"], set=sets)
    args = [f"--set={plug}={json.dumps(value)}" for plug, value in sets.items()]
    expected = graph_eval_json(BIPED, *args, "--get", "*.worldMatrix", "--get", "spine_ctrl.bend*")
    assert_same_as_graph_eval(result, expected)
    assert result["spine_ctrl.bendForward"][0] == pytest.approx(30, rel=1e-15)  # degrees to radians and back


def test_numpy_values_can_be_set():
    graph = riginv.Graph.load(ARM)
    via_numpy = graph.evaluate(get="wrist.worldMatrix", set={"wrist.rotate": np.array([10.0, 20.0, 30.0]),
                                                             "shoulder.rotateZ": np.float32(15)})
    again = riginv.Graph.load(ARM).evaluate(get="wrist.worldMatrix", set={"wrist.rotate": [10, 20, 30],
                                                                          "shoulder.rotateZ": 15})
    assert np.array_equal(via_numpy["wrist.worldMatrix"], again["wrist.worldMatrix"])


def test_plugs_and_node_types():
    graph = riginv.Graph.load(ARM)
    assert graph.plugs("*.rotateZ") == ["arm_ctrl.rotateZ", "shoulder.rotateZ", "elbow.rotateZ", "wrist.rotateZ"]
    assert "wrist.worldMatrix" in graph.plugs()
    code, reference, err = run("graph-eval", "--types")
    assert code == 0, err
    types = graph.node_types()
    assert "joint" in types and "bvhClip" in types
    for name in types:
        assert f"## {name}" in reference


def test_errors_are_graph_eval_messages():
    raises_like("graph-eval", ["rigs/no_such_rig.yaml"], lambda: riginv.Graph.load("rigs/no_such_rig.yaml"))
    graph = riginv.Graph.load(ARM)
    raises_like("graph-eval", [ARM, "--get", "shoulder.rotatq"], lambda: graph.evaluate(get=["shoulder.rotatq"]))
    raises_like("graph-eval", [ARM, "--set", "shoulder.rotateZ=abc"],
                lambda: graph.evaluate(set={"shoulder.rotateZ": "abc"}))
    raises_like("graph-eval", [ARM, "--set", "wrist_world.outputTranslate=[1, 2, 3]"],
                lambda: graph.evaluate(set={"wrist_world.outputTranslate": [1, 2, 3]}))
    raises_like("graph-eval", [ARM, "--frames", "3:1"], lambda: graph.evaluate(frames="3:1"))
    with pytest.raises(riginv.Error, match=r"^frames: nan is not a frame number$"):
        graph.evaluate(frames=[1, float("nan")])
    with pytest.raises(riginv.Error, match=r"^frames: an empty list"):
        graph.evaluate(frames=[])
    with pytest.raises(riginv.Error, match=r"^frames: expected None, 'A:B\[:STEP\]' or a list of frame numbers"):
        graph.evaluate(frames={"a": 1})
    with pytest.raises(riginv.Error, match=r"^get: expected None, a plug name or glob, or a list of them; got a int$"):
        graph.evaluate(get=3)
    # graph-eval looks beside its own libraries too: the same message but for that folder.
    message = (r"^plugin 'no_such_plugin' not found \(looked for .*/lib/no_such_plugin.so\); build it, or add its "
               r"folder to RIG_PLUGIN_PATH$")
    with pytest.raises(riginv.Error, match=message):
        riginv.Graph.load(ARM, plugins=["no_such_plugin"])


def test_output_past_graph_eval_limit_is_refused_up_front():
    # 10 million frames of the biped's 131 world matrices: 150 GB of JSON for graph-eval, 24 GB of arrays here,
    # refused after one frame with graph-eval's own line.
    graph = riginv.Graph.load(BIPED)
    raises_like("graph-eval", [BIPED, "--get", "*.worldMatrix", "--frames", "1:10000000"],
                lambda: graph.evaluate(get="*.worldMatrix", frames="1:10000000"))
    assert graph.evaluate(get="Hips.worldMatrix", frames="1:3")["Hips.worldMatrix"].shape == (3, 4, 4)


def test_numpy_numbers_are_numbers_and_huge_ones_are_errors():
    graph = riginv.Graph.load(ARM)
    plain = graph.evaluate(get="wrist.worldMatrix", set={"shoulder.rotateZ": 30}, frames=[1, 2])
    numpy = graph.evaluate(get="wrist.worldMatrix", set={"shoulder.rotateZ": np.int64(30)},
                           frames=[np.int64(1), np.float32(2)])
    assert np.array_equal(plain["wrist.worldMatrix"], numpy["wrist.worldMatrix"])
    assert np.array_equal(plain["wrist.worldMatrix"],
                          graph.evaluate(get="wrist.worldMatrix", frames=np.array([1, 2]))["wrist.worldMatrix"])
    with pytest.raises(riginv.Error) as caught:
        graph.evaluate(frames=[1, 10**400])
    assert str(caught.value) == f"frames: {str(10**400)[:80]}... (401 characters) is not a frame number"
    with pytest.raises(riginv.Error, match=r"^frames: expected None, 'A:B\[:STEP\]' or a list of frame numbers; "
                                           r"got a list holding a str$"):
        graph.evaluate(frames=[1, "2"])


def test_arguments_of_the_wrong_type_are_one_line_errors():
    graph = riginv.Graph.load(ARM)
    cases = [
        (lambda: riginv.Graph.load(3), "path: expected a path (str or os.PathLike), got a int"),
        (lambda: riginv.Graph.load(ARM, plugins="p"), "plugins: expected a list of str, got a str; put it in a list: "
                                                      "['p']"),
        (lambda: riginv.Graph.load(ARM, plugins=[1]), "plugins: expected a list of str, got a list holding a int"),
        (lambda: graph.evaluate(set=[("shoulder.rotateZ", 1)]), "set: expected None or a dict {plug: value}, got a "
                                                                 "list"),
        (lambda: graph.plugs(3), "glob: expected a str, got a int"),
    ]
    for call, message in cases:
        with pytest.raises(riginv.Error) as caught:
            call()
        assert str(caught.value) == message


def test_threads_is_a_thread_count_as_graph_eval_s():
    graph = riginv.Graph.load(ARM)
    cases = [(1.5, "threads: expected a whole number, got a float"),
             (10000, "threads: 10000 is not a thread count; give a whole number from 0 (all cores) to 1024, as "
                     "graph-eval --threads"),
             (-1, "threads: -1 is not a thread count; give a whole number from 0 (all cores) to 1024, as graph-eval "
                  "--threads")]
    for threads, message in cases:
        with pytest.raises(riginv.Error) as caught:
            graph.evaluate(get="wrist.worldMatrix", threads=threads)
        assert str(caught.value) == message
    assert graph.evaluate(get="wrist.worldMatrix", threads=np.int64(2))["wrist.worldMatrix"].shape == (1, 4, 4)


def test_ctrl_c_stops_a_long_evaluation():
    graph = riginv.Graph.load(ARM)

    class Stop(Exception):
        pass

    def handler(signum, frame):
        raise Stop

    previous = signal.signal(signal.SIGINT, handler)
    try:
        # A real SIGINT from another process, as Ctrl-C sends: the evaluation holds the GIL, so no Python thread
        # of this process could send it.
        killer = subprocess.Popen(["sh", "-c", f"sleep 0.2; kill -INT {os.getpid()}"])
        start = time.perf_counter()
        with pytest.raises(Stop):
            graph.evaluate(get="wrist.worldMatrix", frames="1:1000000")  # about 2.5 s on a 2-core Xeon VM
        assert time.perf_counter() - start < 0.8
        killer.wait()
    finally:
        signal.signal(signal.SIGINT, previous)


def test_array_elements_by_index_glob():
    graph = riginv.Graph.load(BIPED)
    assert graph.plugs("L_thumb2_curl_sum.input1D[*]") == ["L_thumb2_curl_sum.input1D[0]",
                                                          "L_thumb2_curl_sum.input1D[1]"]
    assert graph.plugs("[LR]_thumb2_curl_sum.input1D[1]") == ["L_thumb2_curl_sum.input1D[1]",
                                                             "R_thumb2_curl_sum.input1D[1]"]
