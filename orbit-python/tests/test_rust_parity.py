"""Stepping from Python gives the Rust env's observations and rewards, to the bit: the Rust
agent script records a rollout (`random_agent --record`), Python replays its actions."""

from __future__ import annotations

import os
import pathlib
import subprocess

import numpy as np
import pytest

import orbit_rs
from conftest import CARTPOLE

REPO = pathlib.Path(__file__).resolve().parents[2]


# 1 s episodes: the 150 steps cross two time-outs (Cart-pole ends early only off its rail).
EPISODE = "episode_length_s=1.0"


def record(tmp_path: pathlib.Path, task: str, backend: str, num_envs: int, seed: int, steps: int):
    """Runs the Rust script and loads what it recorded."""
    out = tmp_path / f"{task}-{backend}"
    cmd = ["cargo", "run", "--quiet", "--example", "random_agent", "--", "--task", task,
           "--backend", backend, "--num-envs", str(num_envs), "--seed", str(seed),
           "--steps", str(steps), "--set", EPISODE, "--record", str(out)]
    subprocess.run(cmd, cwd=REPO, check=True, env={**os.environ, "RUST_LOG": "warn"})
    return {name: np.load(out / f"{name}.npy") for name in
            ("actions", "observations", "rewards", "terminated", "time_outs")}


@pytest.mark.parametrize("backend", ["rapier", "wgpu"])
def test_python_steps_match_the_rust_env(tmp_path, backend):
    num_envs, steps = 32, 150
    rec = record(tmp_path, CARTPOLE, backend, num_envs, 11, steps)
    assert rec["actions"].shape == (steps, num_envs, 1)
    assert rec["observations"].shape == (steps + 1, num_envs, 4)
    env = orbit_rs.make(CARTPOLE, num_envs=num_envs, backend=backend, seed=11, overrides=[EPISODE])
    obs, _ = env.reset()
    assert np.array_equal(obs, rec["observations"][0])
    ends = 0
    for t in range(steps):
        obs, rewards, terminated, truncated, _ = env.step(rec["actions"][t])
        assert np.array_equal(obs, rec["observations"][t + 1]), f"observations of step {t + 1}"
        assert np.array_equal(rewards, rec["rewards"][t]), f"rewards of step {t + 1}"
        assert np.array_equal(terminated, rec["terminated"][t])
        assert np.array_equal(truncated, rec["time_outs"][t])
        ends += int((terminated | truncated).sum())
    assert ends > 0, "the rollout crosses episode ends, where the envs reset themselves"
