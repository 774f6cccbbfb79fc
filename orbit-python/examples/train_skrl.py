"""Trains a registered orbit-rs task with skrl's PPO (PyTorch), then evaluates the mean-action
policy over one episode of 64 fresh envs.

    pip install "./orbit-python[skrl]"
    python orbit-python/examples/train_skrl.py --task Isaac-Cartpole-v0 --iterations 100

Written against skrl 2.1, whose API differs from skrl 1's: keyword-only constructors, the
``PPO_CFG`` dataclass, models that read ``inputs["observations"]`` and ``inputs["states"]``.
The policy sees the env's ``policy`` observations, the value model its ``states`` (the task's
critic observations, ``SkrlVecEnvWrapper.state()``). The settings are Isaac Lab's skrl PPO
config for Cart-pole. Logs (TensorBoard) and checkpoints go to ``--log-dir``.
"""

from __future__ import annotations

import argparse

import torch
from skrl.agents.torch import ExperimentCfg
from skrl.agents.torch.ppo import PPO, PPO_CFG
from skrl.memories.torch import RandomMemory
from skrl.models.torch import DeterministicMixin, GaussianMixin, Model
from skrl.resources.preprocessors.torch import RunningStandardScaler
from skrl.resources.schedulers.torch import KLAdaptiveLR
from skrl.trainers.torch import SequentialTrainer, SequentialTrainerCfg
from skrl.utils import set_seed
from torch import nn

import orbit_rs
from orbit_rs.wrappers.skrl import SkrlVecEnvWrapper

EVAL_ENVS, EVAL_SEED = 64, 1234
ROLLOUTS = 32  # steps per env between PPO updates: one iteration


def mlp(inputs: int, outputs: int) -> nn.Sequential:
    """Two hidden layers of 32 units with ELUs, as Isaac Lab's Cart-pole agents have."""
    hidden = [nn.Linear(inputs, 32), nn.ELU(), nn.Linear(32, 32), nn.ELU()]
    return nn.Sequential(*hidden, nn.Linear(32, outputs))


class Policy(GaussianMixin, Model):
    """Gaussian policy: an MLP of the observations gives the mean; the log std is a parameter."""

    def __init__(self, **spaces):  # observation_space, state_space, action_space, device
        Model.__init__(self, **spaces)
        GaussianMixin.__init__(self, clip_actions=False, clip_log_std=True, min_log_std=-20.0)
        self.net = mlp(self.num_observations, self.num_actions)
        self.log_std = nn.Parameter(torch.zeros(self.num_actions))

    def compute(self, inputs, role=""):
        return self.net(inputs["observations"]), {"log_std": self.log_std}


class Value(DeterministicMixin, Model):
    """Deterministic value model of the critic's observations (the env's states)."""

    def __init__(self, **spaces):
        Model.__init__(self, **spaces)
        DeterministicMixin.__init__(self, clip_actions=False)
        self.net = mlp(self.num_states, 1)

    def compute(self, inputs, role=""):
        return self.net(inputs["states"]), {}


def evaluate(task: str, backend: str, agent: PPO) -> float:
    """Mean return of the policy's mean actions over one whole episode of fresh envs."""
    envs = orbit_rs.make(task, num_envs=EVAL_ENVS, backend=backend, seed=EVAL_SEED)
    env = SkrlVecEnvWrapper(envs)
    obs, _ = env.reset()
    agent.enable_training_mode(False)
    ret = 0.0
    with torch.no_grad():
        for _ in range(env.max_episode_length):
            _, outputs = agent.act(obs, env.state(), timestep=0, timesteps=0)
            obs, rewards, *_ = env.step(outputs["mean_actions"])
            ret += rewards.mean().item()
    env.close()
    return ret


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--task", default="Isaac-Cartpole-v0")
    parser.add_argument("--num-envs", type=int, default=256)
    parser.add_argument(
        "--iterations", type=int, default=100, help=f"PPO updates ({ROLLOUTS} steps per env each)"
    )
    parser.add_argument("--backend", default="rapier", help='"rapier", "wgpu" or "auto"')
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--log-dir", default="logs/skrl", help="TensorBoard logs and checkpoints")
    args = parser.parse_args()

    set_seed(args.seed)
    device = "cpu"
    envs = orbit_rs.make(args.task, num_envs=args.num_envs, backend=args.backend, seed=args.seed)
    env = SkrlVecEnvWrapper(envs, device=device)
    spaces = {
        "observation_space": env.observation_space,
        "state_space": env.state_space,
        "action_space": env.action_space,
        "device": device,
    }
    models = {"policy": Policy(**spaces), "value": Value(**spaces)}
    cfg = PPO_CFG(  # and its defaults: discount 0.99, GAE lambda 0.95, ratio and value clips 0.2
        rollouts=ROLLOUTS,
        learning_epochs=8,
        mini_batches=8,
        learning_rate=5e-4,
        learning_rate_scheduler=KLAdaptiveLR,
        learning_rate_scheduler_kwargs={"kl_threshold": 0.008},
        observation_preprocessor=RunningStandardScaler,
        observation_preprocessor_kwargs={"size": env.observation_space, "device": device},
        state_preprocessor=RunningStandardScaler,
        state_preprocessor_kwargs={"size": env.state_space, "device": device},
        value_preprocessor=RunningStandardScaler,
        value_preprocessor_kwargs={"size": 1, "device": device},
        grad_norm_clip=1.0,
        value_loss_scale=2.0,
        rewards_shaper=lambda rewards, timestep, timesteps: rewards * 0.1,
        experiment=ExperimentCfg(directory=args.log_dir),
    )
    memory = RandomMemory(memory_size=ROLLOUTS, num_envs=env.num_envs, device=device)
    agent = PPO(models=models, memory=memory, cfg=cfg, **spaces)
    trainer_cfg = SequentialTrainerCfg(
        timesteps=ROLLOUTS * args.iterations, headless=True, close_environment_at_exit=False
    )
    SequentialTrainer(env=env, agents=agent, cfg=trainer_cfg).train()
    env.close()

    ret = evaluate(args.task, args.backend, agent)
    print(f"final return: {ret:.4f}")


if __name__ == "__main__":
    main()
