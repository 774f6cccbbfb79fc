"""Trains a registered orbit-rs task with RSL-RL's PPO (``OnPolicyRunner``), then evaluates the
mean-action policy over one episode of 64 fresh envs.

    pip install "./orbit-python[rsl-rl]"
    python orbit-python/examples/train_rsl_rl.py --task Isaac-Cartpole-v0 --iterations 150

The train config is in the layout of rsl-rl-lib 5 (written against 5.5): ``actor`` and ``critic``
models by ``class_name``, ``obs_groups`` mapping the env's observation groups (``policy`` and
``critic``, see ``RslRlVecEnvWrapper``) to the models, and the PPO settings under ``algorithm``.
Logs (TensorBoard) and checkpoints go to ``--log-dir``.
"""

from __future__ import annotations

import argparse

import torch
from rsl_rl.runners import OnPolicyRunner

import orbit_rs
from orbit_rs.wrappers.rsl_rl import RslRlVecEnvWrapper

EVAL_ENVS, EVAL_SEED = 64, 1234


def train_config() -> dict:
    """RSL-RL's runner config, with Isaac Lab's Cart-pole PPO settings."""
    model = {"class_name": "MLPModel", "hidden_dims": [32, 32], "activation": "elu"}
    return {
        "num_steps_per_env": 16,
        "save_interval": 50,
        "obs_groups": {"actor": ["policy"], "critic": ["critic"]},
        "actor": {**model, "distribution_cfg": {"class_name": "GaussianDistribution"}},
        "critic": model,
        "algorithm": {
            "class_name": "PPO",
            "num_learning_epochs": 5,
            "num_mini_batches": 4,
            "learning_rate": 1e-3,
            "schedule": "adaptive",
            "desired_kl": 0.01,
            "gamma": 0.99,
            "lam": 0.95,
            "clip_param": 0.2,
            "entropy_coef": 0.005,
            "value_loss_coef": 1.0,
            "use_clipped_value_loss": True,
            "max_grad_norm": 1.0,
        },
    }


def evaluate(task: str, backend: str, policy) -> float:
    """Mean return of the policy's mean actions over one whole episode of fresh envs."""
    envs = orbit_rs.make(task, num_envs=EVAL_ENVS, backend=backend, seed=EVAL_SEED)
    env = RslRlVecEnvWrapper(envs)
    obs = env.get_observations()
    ret = 0.0
    with torch.inference_mode():
        for _ in range(int(env.max_episode_length)):
            obs, rewards, _, _ = env.step(policy(obs))  # MLPModel's forward: the mean action
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
        "--iterations", type=int, default=150, help="PPO updates (16 steps per env each)"
    )
    parser.add_argument("--backend", default="rapier", help='"rapier", "wgpu" or "auto"')
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--log-dir", default="logs/rsl_rl", help="TensorBoard logs and checkpoints")
    args = parser.parse_args()

    torch.manual_seed(args.seed)
    envs = orbit_rs.make(args.task, num_envs=args.num_envs, backend=args.backend, seed=args.seed)
    env = RslRlVecEnvWrapper(envs)
    runner = OnPolicyRunner(env, train_config(), log_dir=args.log_dir, device="cpu")
    runner.learn(args.iterations, init_at_random_ep_len=True)
    env.close()

    ret = evaluate(args.task, args.backend, runner.get_inference_policy())
    print(f"final return: {ret:.4f}")


if __name__ == "__main__":
    main()
