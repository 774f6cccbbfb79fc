"""orbit-rs envs as an skrl env wrapper (PyTorch)."""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
import torch
from skrl.envs.wrappers.torch.base import Wrapper

from ..vector_env import OrbitVectorEnv


class SkrlVecEnvWrapper(Wrapper):
    """An :class:`~orbit_rs.OrbitVectorEnv` as an skrl env, as skrl's Isaac Lab wrapper
    treats Isaac Lab's envs: the envs reset themselves, so ``reset()`` resets them only on its
    first call; ``state()`` is the critic's observation (the task's ``critic`` group, or its
    ``policy`` group); rewards, terminations and time-outs come as ``[num_envs, 1]`` tensors.
    """

    def __init__(self, env: OrbitVectorEnv, device: str | torch.device = "cpu"):
        super().__init__(env)
        self._device = torch.device(device)
        self._reset_once = True
        self._observations: torch.Tensor | None = None
        self._states: torch.Tensor | None = None
        self._info: dict[str, Any] = {}

    @property
    def observation_space(self) -> gymnasium.Space:
        """One env's observation space."""
        return self._env.single_observation_space

    @property
    def action_space(self) -> gymnasium.Space:
        """One env's action space."""
        return self._env.single_action_space

    @property
    def state_space(self) -> gymnasium.Space:
        """One env's critic observation space."""
        width = self._env.native.num_critic_obs
        return gymnasium.spaces.Box(-np.inf, np.inf, (width,), np.float32)

    def _tensor(self, array: np.ndarray) -> torch.Tensor:
        return torch.from_numpy(array).to(self._device)

    def _observe(self, obs: np.ndarray) -> None:
        self._observations = self._tensor(obs)
        self._states = self._tensor(self._env.critic_observations())

    def step(
        self, actions: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, Any]:
        """Applies one action per env."""
        obs, rewards, terminated, truncated, self._info = self._env.step(
            actions.detach().to("cpu", torch.float32).numpy()
        )
        self._observe(obs)
        column = lambda a: self._tensor(a).view(-1, 1)  # noqa: E731
        return self._observations, column(rewards), column(terminated), column(truncated), self._info

    def state(self) -> torch.Tensor | None:
        """The critic's observations."""
        return self._states

    def reset(self) -> tuple[torch.Tensor, dict[str, Any]]:
        """Resets the envs on the first call; later calls return the current observations."""
        if self._reset_once:
            obs, self._info = self._env.reset()
            self._observe(obs)
            self._reset_once = False
        return self._observations, self._info

    def render(self, *args: Any, **kwargs: Any) -> None:
        """orbit-rs renders videos with ``train --video``, not through the env."""
        return None

    def close(self) -> None:
        """Closes the envs."""
        self._env.close()
