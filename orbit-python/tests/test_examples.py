"""The training examples in orbit-python/examples run: each trains Cart-pole briefly (16 envs,
2 iterations) through its library's adapter, evaluates the mean-action policy and prints its
return."""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import need

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.parametrize(
    ("script", "library", "log_dir"),
    [
        ("train_rsl_rl.py", "rsl_rl", True),
        ("train_sb3.py", "stable_baselines3", False),
        ("train_skrl.py", "skrl", True),
    ],
    ids=["rsl_rl", "sb3", "skrl"],
)
def test_example_trains_and_reports_a_return(script, library, log_dir, tmp_path):
    need("torch")
    need(library)
    command = [sys.executable, str(EXAMPLES / script), "--task", "Isaac-Cartpole-v0"]
    command += ["--num-envs", "16", "--iterations", "2", "--backend", "rapier", "--seed", "1"]
    if log_dir:
        command += ["--log-dir", str(tmp_path / "logs")]
    # Run from tmp_path, so nothing an example writes lands in the checkout.
    done = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, f"{script} failed:\n{done.stdout[-4000:]}\n{done.stderr[-4000:]}"
    found = re.findall(r"^final return: (\S+)$", done.stdout, re.MULTILINE)
    assert found, f"{script} printed no `final return:` line:\n{done.stdout[-4000:]}"
    assert math.isfinite(float(found[-1])), f"{script}: final return {found[-1]}"
