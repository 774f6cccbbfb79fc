"""orbit-rs envs as a gymnasium vector env (same-step autoreset)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv

from . import _native


class OrbitVectorEnv(VectorEnv):
    """A batch of orbit-rs envs of one task as a :class:`gymnasium.vector.VectorEnv`.

    Episodes reset in the step that ends them (``AutoresetMode.SAME_STEP``): the observation
    returned for a finished env is its new episode's first, and the observation the episode
    ended in is ``infos["final_obs"][i]`` (``infos["_final_obs"]`` marks the finished envs;
    ``infos["final_info"]`` is empty, as the envs keep no per-env info; ``infos["log"]``
    holds the mean episode statistics of the envs that finished, Isaac Lab's
    ``extras["log"]``). ``terminated`` comes
    from the task's termination terms, ``truncated`` from its time-out; both can be set.
    A black-box task's step is one movement primitive; its action is the primitive's
    parameters.

    Observations are the ``policy`` group; the ``critic`` group, if the task has one, is
    ``critic_observations()``. Arrays are ``float32`` numpy arrays, new on every call; pass
    them to torch with ``torch.from_numpy`` (or ``torch.from_dlpack``) without a copy.
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(self, native: _native.NativeEnv, keep_final_obs: bool = True):
        self.native = native
        self.num_envs = native.num_envs
        self.single_observation_space = gym.spaces.Box(
            -np.inf, np.inf, (native.num_obs,), np.float32
        )
        # Unbounded, as Isaac Lab's: the task's action terms scale and clip.
        self.single_action_space = gym.spaces.Box(
            -np.inf, np.inf, (native.num_actions,), np.float32
        )
        self.observation_space = gym.vector.utils.batch_space(
            self.single_observation_space, self.num_envs
        )
        self.action_space = gym.vector.utils.batch_space(
            self.single_action_space, self.num_envs
        )
        self.max_episode_length = native.max_episode_length
        self.keep_final_obs = keep_final_obs
        native.keep_final_observations(keep_final_obs)
        # Built envs start reset: the first reset() takes them as they are.
        self._fresh = True
        self.spec = None
        self.render_mode = None
        self.closed = False

    @property
    def task(self) -> str:
        """The task id (or the env file's name)."""
        return self.native.name

    @property
    def backend(self) -> str:
        """The physics backend the envs run on."""
        return self.native.backend

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Resets every env. With ``seed``, the envs are built again from that seed, as
        orbit-rs (like Isaac Lab) seeds its random streams when it builds the envs. Built
        envs start reset, so a first ``reset()`` after ``make`` gives the same episodes as
        the Rust env of the same seed."""
        if seed is not None:
            self.native = self.native.reseeded(int(seed))
            self.native.keep_final_observations(self.keep_final_obs)
        elif not self._fresh:
            self.native.reset()
        self._fresh = False
        return self.native.observations(), {}

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Applies one action per env; see the class docs for what comes back."""
        self._fresh = False
        actions = np.ascontiguousarray(actions, dtype=np.float32)
        if actions.ndim == 1 and self.native.num_actions == 1:
            actions = actions.reshape(-1, 1)
        rewards, terminated, truncated, log, _ = self.native.step(actions)
        obs = self.native.observations()
        infos: dict[str, Any] = {}
        done = terminated | truncated
        if log:
            infos["log"] = log
        if done.any():
            infos["_final_obs"] = done
            infos["_final_info"] = done.copy()
            infos["final_info"] = {}
            if self.keep_final_obs:
                rows = list(self.native.final_observations(done))
                final = np.empty(self.num_envs, dtype=object)
                # One row view per finished env, placed without a Python loop.
                final[done] = np.fromiter(rows, dtype=object, count=len(rows))
                infos["final_obs"] = final
        return obs, rewards, terminated, truncated, infos

    def critic_observations(self) -> np.ndarray:
        """The critic's observations (group ``critic``, else ``policy``) of the current step."""
        return self.native.critic_observations()

    def close_extras(self, **kwargs: Any) -> None:
        """Drops the native envs."""
        self.native = None
