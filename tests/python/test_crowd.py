"""A crowd from Python (docs/crowds.md; docs/python.md, A crowd): riginv.Graph plays the look-at crowd of two and
reads each character's curves, graph-eval's bit for bit on any thread count; the docs' crowd script runs."""

import json
import re
import subprocess
import sys

import numpy as np
import pytest

import riginv
from conftest import ARM, SOURCE, need_cmu_clip, run


@pytest.fixture(scope="module")
def crowd(tmp_path_factory, learned_biped):
    """scripts/make_crowd.py 2 with the learned biped, as rigs/examples/crowd_lookat.yaml is written."""
    need_cmu_clip()
    approximation, _ = learned_biped
    file = tmp_path_factory.mktemp("crowd") / "crowd.yaml"
    done = subprocess.run([sys.executable, "scripts/make_crowd.py", "2", "--rig", str(SOURCE / "rigs/biped.yaml"),
                           "--approximation", str(approximation),
                           "--map", str(SOURCE / "rigs/maps/cmu_to_biped_lookat.yaml"), "-o", str(file)],
                          cwd=SOURCE, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return file


def test_each_characters_curves_equal_graph_eval(crowd):
    code, out, err = run("graph-eval", crowd, "--frames", "1:5", "--get", "*:inverter.value[*]", "--get",
                         "*:inverter.status")
    assert code == 0, err
    frames = json.loads(out)
    for threads in (1, 2):
        played = riginv.Graph.load(crowd).evaluate(get=["*:inverter.value[*]", "*:inverter.status"], frames="1:5",
                                                   threads=threads)
        assert list(played) == [key for key in frames[0] if key != "frame"]
        for character in ("c0000", "c0001"):
            values = [played[f"{character}:inverter.value[{i}]"] for i in range(79)]
            assert f"{character}:inverter.value[79]" not in played
            for f, frame in enumerate(frames):
                expected = np.array([frame[f"{character}:inverter.value[{i}]"] for i in range(79)])
                assert np.array_equal(np.array([v[f] for v in values]), expected), (threads, character, f)
            # The status, an enum: its index here, its name in graph-eval (reached 0, bestFit 1, ...).
            names = ["reached", "bestFit"]
            assert [names[s] for s in played[f"{character}:inverter.status"]] == \
                [frame[f"{character}:inverter.status"] for frame in frames]


def test_a_negative_thread_count_is_refused():
    with pytest.raises(riginv.Error) as caught:
        riginv.Graph.load(ARM).evaluate(get="elbow.rotateZ", threads=-1)
    assert str(caught.value) == ("threads: -1 is not a thread count; give a whole number from 0 (all cores) to 1024, "
                                 "as graph-eval --threads")


def test_the_docs_crowd_script_runs(crowd, tmp_path):
    text = (SOURCE / "docs/python.md").read_text()
    scripts = re.findall(r"```py\n(.*?)```", text, re.S)
    assert len(scripts) == 1
    script = tmp_path / "crowd.py"
    script.write_text(scripts[0])
    done = subprocess.run([sys.executable, str(script), str(crowd)], cwd=SOURCE, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert [line.split(":")[0] for line in lines] == ["c0000", "c0001"]
    assert all("120 frames of 79 controls, 120 reached or best fit" in line for line in lines)
    # The output docs/python.md shows, with the committed example's approximation learned the same way.
    assert all(line in text for line in lines), done.stdout
