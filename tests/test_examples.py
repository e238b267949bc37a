"""Every script in examples/ runs as a newcomer would run it (shortened by NEUROSLAM_EXAMPLE_FRAMES, which
each example documents; the code is the same), prints what it shows, and writes what it says it writes."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted((Path(__file__).resolve().parent.parent / "examples").glob("*.py"))


def test_the_examples_folder_holds_the_documented_scripts():
    names = {path.stem for path in EXAMPLES}
    assert {"drive_and_score", "slam_on_images", "gym_rollout", "custom_world", "multisession", "plot_cells"} <= names


@pytest.mark.parametrize("example", EXAMPLES, ids=[path.stem for path in EXAMPLES])
def test_the_example_runs(example, tmp_path):
    environment = {**os.environ, "NEUROSLAM_EXAMPLE_FRAMES": "60", "MUJOCO_GL": "egl"}
    result = subprocess.run([sys.executable, str(example)], cwd=tmp_path, env=environment, capture_output=True,
                            text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.strip(), "an example prints what it shows"
    docstring = example.read_text().split('"""')[1]
    assert "What you learn" in docstring and "Run:" in docstring
    # what an example writes goes into runs/examples/ (git-ignored), never the working directory itself
    for written in re.findall(r"writes (?:into )?``(runs/examples/[^`]+)``", " ".join(docstring.split())):
        assert (tmp_path / written).exists(), written
    assert {path.name for path in tmp_path.iterdir()} <= {"runs"}, "an example writes only under runs/"
