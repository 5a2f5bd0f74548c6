"""Shared fixtures of the riginv tests (docs/python.md).

CTest runs them from the source folder with PYTHONPATH=<build>/python and RIG_BIN_DIR=<build>/bin, the
command lines the tests compare the module with. Data a fresh machine may lack (Debian's
assimp-testmodels) skips the tests that need it.
"""

import json
import os
import pathlib
import subprocess
import threading
import time

import pytest
import yaml

import riginv

SOURCE = pathlib.Path(os.environ.get("RIG_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
BIN = pathlib.Path(os.environ.get("RIG_BIN_DIR", SOURCE / "build" / "bin"))
CMU_CLIP = pathlib.Path("/usr/share/assimp/models/BVH/01_01.bvh")
BIPED = "rigs/biped.yaml"
ARM = "rigs/examples/arm.yaml"
ARM_PARAMS = ["shoulder.rotate?", "elbow.rotate?", "wrist.rotate?"]
CMU_MAP = "rigs/maps/cmu_to_biped.yaml"


@pytest.fixture(autouse=True)
def _source_folder(monkeypatch):
    # Rig, map and clip names are relative to the source folder, as in the command lines' messages.
    monkeypatch.chdir(SOURCE)


def run(tool, *args):
    """Runs a command line from the source folder: (exit code, stdout, stderr)."""
    done = subprocess.run([str(BIN / tool), *map(str, args)], cwd=SOURCE, capture_output=True, text=True)
    return done.returncode, done.stdout, done.stderr


def error_line(tool, *args):
    """The one-line message a command line prints for bad input (exit code 2), without 'error: '."""
    code, _, err = run(tool, *args)
    assert code == 2, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0][len("error: "):]


def raises_like(tool, args, call):
    """Checks that `call` raises riginv.Error with the message the command line prints for `args`."""
    expected = error_line(tool, *args)
    with pytest.raises(riginv.Error) as caught:
        call()
    assert str(caught.value) == expected
    return expected


def read_json(path):
    with open(path) as f:
        return json.load(f)


def biped_spec():
    """rigs/biped_inversion.yaml: the biped's parameters and outputs to invert (rig-learn --spec)."""
    with open(SOURCE / "rigs/biped_inversion.yaml") as f:
        return yaml.safe_load(f)


def need_cmu_clip():
    if not CMU_CLIP.exists():
        pytest.skip(f"{CMU_CLIP} is not installed (Debian package assimp-testmodels)")


@pytest.fixture(scope="session")
def learned_biped(tmp_path_factory):
    """The biped's approximation learned once by rig-learn: (file, its --report-json)."""
    folder = tmp_path_factory.mktemp("learned_biped")
    approximation, report = folder / "biped.approx.yaml", folder / "learn.json"
    code, _, err = run("rig-learn", BIPED, "--spec", "rigs/biped_inversion.yaml", "-o", approximation,
                       "--report-json", report)
    assert code == 0, err
    return approximation, read_json(report)


def share_of_time_another_thread_runs(call):
    """Runs `call` while a Python thread counts, and returns how much the thread counted during the call
    against what it counts in the same time with the GIL free (during a sleep). A call that holds the GIL
    lets it count only around its start and end (the interpreter's switch interval, 5 ms): near 0 for a
    call of a second; one that releases the GIL lets it count all along: near 1."""
    counter, stop = [0], threading.Event()

    def count():
        while not stop.is_set():
            counter[0] += 1

    thread = threading.Thread(target=count)
    thread.start()
    try:
        before, start = counter[0], time.perf_counter()
        time.sleep(0.2)
        free_rate = (counter[0] - before) / (time.perf_counter() - start)
        before, start = counter[0], time.perf_counter()
        call()
        return (counter[0] - before) / (time.perf_counter() - start) / free_rate
    finally:
        stop.set()
        thread.join()
