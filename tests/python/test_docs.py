"""docs/python.md's example script runs as written (a CMU clip on the biped, its error per frame plotted)."""

import importlib.util
import os
import re
import subprocess
import sys

from conftest import SOURCE, need_cmu_clip


def test_the_example_script_runs(tmp_path):
    need_cmu_clip()
    text = (SOURCE / "docs/python.md").read_text()
    scripts = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(scripts) == 1
    script = tmp_path / "cmu_error.py"
    script.write_text(scripts[0])
    plot = tmp_path / "error.png"
    done = subprocess.run([sys.executable, str(script), str(plot)], cwd=SOURCE, capture_output=True, text=True,
                          env=dict(os.environ, MPLCONFIGDIR=str(tmp_path / "matplotlib")))
    assert done.returncode == 0, done.stderr
    assert "learned 79 controls, within epsilon: True" in done.stdout
    assert "  2752 / 2752 frames\n2752 frames: " in done.stdout
    if importlib.util.find_spec("matplotlib"):
        assert plot.stat().st_size > 0 and done.stdout.endswith(f"plot: {plot}\n")
    else:
        assert "matplotlib is not installed" in done.stdout
