"""Shared helpers of the orbit_rs tests: small CPU envs (rapier) of the registered tasks."""

from __future__ import annotations

import importlib
import os

import numpy as np
import pytest

import orbit_rs

CARTPOLE = "Isaac-Cartpole-v0"


def cartpole(num_envs: int = 16, seed: int = 3, **kwargs) -> orbit_rs.OrbitVectorEnv:
    """Cart-pole envs on rapier."""
    return orbit_rs.make(CARTPOLE, num_envs=num_envs, backend="rapier", seed=seed, **kwargs)


def actions_for(step: int, num_envs: int, width: int) -> np.ndarray:
    """Deterministic actions in [-1, 1], exact in float32, different per env, value and step."""
    e = np.arange(num_envs)[:, None]
    j = np.arange(width)[None, :]
    return (((7 * e + 3 * j + 5 * step) % 11) / 5.0 - 1.0).astype(np.float32)


@pytest.fixture
def env():
    envs = cartpole()
    yield envs
    envs.close()


def need(module: str):
    """Imports a learning library, or skips the test without it; with
    ORBIT_REQUIRE_CLIENTS=1 (as CI runs) a missing library fails the test instead."""
    if os.environ.get("ORBIT_REQUIRE_CLIENTS") == "1":
        return importlib.import_module(module)
    return pytest.importorskip(module)
