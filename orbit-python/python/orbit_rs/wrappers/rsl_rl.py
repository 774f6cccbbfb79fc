"""orbit-rs envs as RSL-RL's ``VecEnv`` (rsl-rl-lib 3 or newer: observations as a TensorDict)."""

from __future__ import annotations

import numpy as np
import torch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from ..vector_env import OrbitVectorEnv


class RslRlVecEnvWrapper(VecEnv):
    """An :class:`~orbit_rs.OrbitVectorEnv` as RSL-RL's ``VecEnv``, as Isaac Lab's
    ``RslRlVecEnvWrapper`` wraps its envs.

    Observations are a TensorDict of the groups ``policy`` and ``critic`` (the task's privileged
    critic group, or ``policy`` again if it has none; the runner config's ``obs_groups`` maps
    them). ``step`` returns
    ``dones`` (terminated or timed out) and ``extras`` with ``time_outs`` (which RSL-RL
    bootstraps) and ``log``, the episode statistics of the envs that finished.
    ``episode_length_buf`` can be set, so ``learn(init_at_random_ep_len=True)`` works.
    """

    def __init__(self, env: OrbitVectorEnv, device: str | torch.device = "cpu"):
        self.env = env
        self.device = torch.device(device)
        self.num_envs = env.num_envs
        self.num_actions = env.single_action_space.shape[0]
        self.max_episode_length = env.max_episode_length
        self.cfg = {"task": env.task, "backend": env.backend, "num_envs": env.num_envs}
        self.env.reset()

    def _tensor(self, array: np.ndarray) -> torch.Tensor:
        # One copy at most: from_numpy shares the array's memory; .to copies only to a GPU.
        return torch.from_numpy(array).to(self.device)

    def _observations(self, policy: np.ndarray) -> TensorDict:
        groups = {
            "policy": self._tensor(policy),
            "critic": self._tensor(self.env.critic_observations()),
        }
        return TensorDict(groups, batch_size=[self.num_envs], device=self.device)

    def get_observations(self) -> TensorDict:
        """The current observations."""
        return self._observations(self.env.native.observations())

    @property
    def episode_length_buf(self) -> torch.Tensor:
        """Steps each env has taken in its episode."""
        return self._tensor(self.env.native.episode_lengths().astype(np.int64))

    @episode_length_buf.setter
    def episode_length_buf(self, lengths: torch.Tensor) -> None:
        values = lengths.detach().to("cpu", torch.int64).numpy().astype(np.uint32)
        self.env.native.set_episode_lengths(values)

    def step(self, actions: torch.Tensor) -> tuple[TensorDict, torch.Tensor, torch.Tensor, dict]:
        """Applies one action per env."""
        obs, rewards, terminated, truncated, infos = self.env.step(
            actions.detach().to("cpu", torch.float32).numpy()
        )
        dones = self._tensor((terminated | truncated).astype(np.int64))
        extras = {"time_outs": self._tensor(truncated), "log": infos.get("log", {})}
        return self._observations(obs), self._tensor(rewards), dones, extras

    def close(self) -> None:
        """Closes the envs."""
        self.env.close()
