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

    The action space is bounded where an action acts the same beyond a bound in every state (an
    action term's clip, or an effort limit over the action's scale where nothing else adds to
    that effort). It is unbounded elsewhere. ``reset(options={"reset_mask": mask})`` resets the masked envs alone.

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
        low, high = native.action_bounds()
        self.single_action_space = gym.spaces.Box(low, high, (native.num_actions,), np.float32)
        self.observation_space = gym.vector.utils.batch_space(
            self.single_observation_space, self.num_envs
        )
        self.action_space = gym.vector.utils.batch_space(
            self.single_action_space, self.num_envs
        )
        self.max_episode_length = native.max_episode_length
        self._name = native.name
        self.keep_final_obs = keep_final_obs
        native.keep_final_observations(keep_final_obs)
        # Built envs start reset: the first reset() takes them as they are.
        self._fresh = True
        self.spec = None
        self.render_mode = None
        self.closed = False

    def _open(self) -> _native.NativeEnv:
        if self.native is None:
            raise _native.OrbitError(
                f"the env of `{self._name}` was closed: make a new one with orbit_rs.make()"
            )
        return self.native

    @property
    def task(self) -> str:
        """The task id (or the env file's name)."""
        return self._name

    @property
    def backend(self) -> str:
        """The physics backend the envs run on."""
        return self._open().backend

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Resets every env. With ``seed``, the envs are built again from that seed, as
        orbit-rs (like Isaac Lab) seeds its random streams when it builds the envs. Built
        envs start reset, so a first ``reset()`` after ``make`` gives the same episodes as
        the Rust env of the same seed. ``options={"reset_mask": mask}`` (a boolean array,
        one per env) resets the masked envs alone; other options are errors."""
        native = self._open()
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        if options:
            raise ValueError(
                f"reset() options {sorted(options)} are not understood; the one option is "
                "`reset_mask`, a boolean array with one value per env"
            )
        if mask is not None:
            if seed is not None:
                raise ValueError("reset() takes `seed` or a `reset_mask`, not both")
            mask = np.asarray(mask)
            if mask.dtype != np.bool_ or mask.shape != (self.num_envs,):
                raise ValueError(
                    f"reset_mask must be a boolean array of shape ({self.num_envs},), got "
                    f"{mask.dtype} {mask.shape}"
                )
            native.reset_envs([int(i) for i in np.flatnonzero(mask)])
            self._fresh = False
            return native.observations(), {}
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
        self._open()
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
            infos["_final_info"] = done.copy()
            infos["final_info"] = {}
            if self.keep_final_obs:
                infos["_final_obs"] = done
                rows = list(self.native.final_observations(done))
                final = np.empty(self.num_envs, dtype=object)
                # One row view per finished env, placed without a Python loop.
                final[done] = np.fromiter(rows, dtype=object, count=len(rows))
                infos["final_obs"] = final
        return obs, rewards, terminated, truncated, infos

    def critic_observations(self) -> np.ndarray:
        """The critic's observations (group ``critic``, else ``policy``) of the current step."""
        return self._open().critic_observations()

    def close_extras(self, **kwargs: Any) -> None:
        """Drops the native envs."""
        self.native = None
