"""orbit-rs from Python: its tasks as gymnasium vector envs, and adapters for RSL-RL,
Stable-Baselines3 and skrl.

>>> import orbit_rs
>>> env = orbit_rs.make("Isaac-Cartpole-v0", num_envs=64, backend="rapier", seed=1)
>>> obs, info = env.reset()
>>> obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
"""

from __future__ import annotations

import logging
import os
from typing import Sequence

from . import _native
from ._native import OrbitError, __version__
from .vector_env import OrbitVectorEnv

__all__ = ["OrbitError", "OrbitVectorEnv", "__version__", "make", "tasks"]

_logger = logging.getLogger(__name__)


def make(
    task: str | None = None,
    *,
    num_envs: int | None = None,
    backend: str | None = None,
    seed: int | None = None,
    overrides: Sequence[str] = (),
    config: str | os.PathLike | None = None,
    black_box_overrides: Sequence[str] = (),
    final_obs: bool = True,
) -> OrbitVectorEnv:
    """Builds the envs of a registered task (``tasks()`` lists them), as ``train`` does.

    Args:
        task: A registered task id, e.g. ``"Isaac-Ant-v0"``; ``None`` with ``config``.
        num_envs: Number of envs (default: the env config's).
        backend: Physics backend: ``"rapier"`` (CPU), ``"wgpu"`` (GPU through Vulkan, or
            Mesa's lavapipe on the CPU) or ``"auto"`` (default: the env config's).
        seed: Seed of the envs' random streams (default: the env config's).
        overrides: Env config overrides, ``"key.path=value"`` as on the command line.
        config: An env config file (RON) to use instead of the task's.
        black_box_overrides: Overrides of a black-box task's wrapper config.
        final_obs: Keep each finished episode's last observation for ``infos["final_obs"]``
            (costs an observation pass on the steps where episodes end).

    Raises:
        OrbitError: The config is invalid or the backend failed; the message says what to
            change.

    Which backend ``"auto"`` chose, and why, is logged at level INFO on the ``orbit_rs``
    logger.
    """
    native = _native.make(
        task,
        num_envs=num_envs,
        backend=backend,
        seed=seed,
        overrides=[str(o) for o in overrides],
        config=None if config is None else os.fspath(config),
        black_box_overrides=[str(o) for o in black_box_overrides],
    )
    if native.backend_choice:
        _logger.info(native.backend_choice)
    return OrbitVectorEnv(native, keep_final_obs=final_obs)


def tasks() -> list[tuple[str, str, bool, bool]]:
    """The registered tasks: ``(id, description, trainable, black_box)``, sorted by id."""
    return _native.tasks()
