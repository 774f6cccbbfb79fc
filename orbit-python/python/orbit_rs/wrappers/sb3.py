"""orbit-rs envs as a Stable-Baselines3 ``VecEnv``."""

from __future__ import annotations

from typing import Any, Sequence

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

from ..vector_env import OrbitVectorEnv


class Sb3VecEnvWrapper(VecEnv):
    """An :class:`~orbit_rs.OrbitVectorEnv` as a Stable-Baselines3 ``VecEnv``, as Isaac Lab's
    ``Sb3VecEnvWrapper`` wraps its envs.

    Finished envs are reset in the step that ends them, as SB3 expects: their info holds the
    observation the episode ended in (``terminal_observation``) and whether a time-out ended
    it (``TimeLimit.truncated``), which SB3's PPO bootstraps. The envs are seeded when built
    (``orbit_rs.make(seed=…)``); ``seed()`` builds them again from a new seed at the next
    reset. SB3 takes only bounded action spaces: the env's bounds (where its action terms
    saturate) are kept, and each unbounded value gets ``[-100, 100]``, as Isaac Lab's adapter
    makes an unbounded space.
    """

    def __init__(self, env: OrbitVectorEnv):
        self.env = env
        action_space = env.single_action_space
        if not action_space.is_bounded("both"):
            # SB3 takes only bounded boxes (its PPO clips actions to them); as Isaac Lab's
            # adapter does, an unbounded value gets [-100, 100].
            low = np.where(np.isfinite(action_space.low), action_space.low, -100.0)
            high = np.where(np.isfinite(action_space.high), action_space.high, 100.0)
            action_space = gym.spaces.Box(
                low.astype(np.float32), high.astype(np.float32), action_space.shape, np.float32
            )
        super().__init__(env.num_envs, env.single_observation_space, action_space)
        self._actions: np.ndarray | None = None

    def reset(self) -> np.ndarray:
        """Resets every env; returns the observations."""
        seed = self._seeds[0] if self._seeds and self._seeds[0] is not None else None
        obs, _ = self.env.reset(seed=seed)
        self._reset_seeds()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Stores the actions of the next ``step_wait``."""
        self._actions = actions

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        """Steps the envs with the stored actions."""
        obs, rewards, terminated, truncated, infos = self.env.step(self._actions)
        dones = terminated | truncated
        # SB3 takes a dict per env: the finished envs' hold their episodes' last observation.
        env_infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        final = infos.get("final_obs")
        for i in np.flatnonzero(dones):
            env_infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            if final is not None:
                env_infos[i]["terminal_observation"] = final[i]
        return obs, rewards, dones, env_infos

    def close(self) -> None:
        """Closes the envs."""
        self.env.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        """The env's attribute, once per selected env (all envs share one object)."""
        return [getattr(self.env, attr_name)] * len(self._get_indices(indices))

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        """Sets the attribute of the batched env (one object for all envs)."""
        setattr(self.env, attr_name, value)

    def env_method(self, method_name: str, *args: Any, indices: Any = None, **kwargs: Any) -> list[Any]:
        """Calls a method of the batched env once, for every selected env."""
        result = getattr(self.env, method_name)(*args, **kwargs)
        return [result] * len(self._get_indices(indices))

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        """No env is wrapped by a gymnasium wrapper."""
        return [False] * len(self._get_indices(indices))

    def _get_indices(self, indices: Any) -> Sequence[int]:
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, int):
            return [indices]
        return indices
