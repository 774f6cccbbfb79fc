"""Trains a registered orbit-rs task with Stable-Baselines3's PPO, then evaluates the
mean-action policy over one episode of 64 fresh envs.

    pip install "./orbit-python[sb3]"
    python orbit-python/examples/train_sb3.py --task Isaac-Cartpole-v0 --iterations 40

Written against stable-baselines3 2.9. One iteration is a rollout of 16 steps per env and 5
epochs of PPO updates over it in 4 mini-batches; the defaults are the ones orbit-python's
tests balance the cart-pole with (a return above 4.5 of its 5.0 ceiling). ``Sb3VecEnvWrapper``
gives PPO the finished episodes' last observations, from which it bootstraps time-outs.
"""

from __future__ import annotations

import argparse

from stable_baselines3 import PPO

import orbit_rs
from orbit_rs.wrappers.sb3 import Sb3VecEnvWrapper

EVAL_ENVS, EVAL_SEED = 64, 1234
STEPS_PER_ENV = 16


def evaluate(task: str, backend: str, model: PPO) -> float:
    """Mean return of the policy's mean actions over one whole episode of fresh envs."""
    env = orbit_rs.make(task, num_envs=EVAL_ENVS, backend=backend, seed=EVAL_SEED)
    obs, _ = env.reset()
    ret = 0.0
    for _ in range(env.max_episode_length):
        actions, _ = model.predict(obs, deterministic=True)
        obs, rewards, *_ = env.step(actions)
        ret += float(rewards.mean())
    env.close()
    return ret


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--task", default="Isaac-Cartpole-v0")
    parser.add_argument("--num-envs", type=int, default=256)
    parser.add_argument(
        "--iterations", type=int, default=40, help=f"PPO updates ({STEPS_PER_ENV} steps per env)"
    )
    parser.add_argument("--backend", default="rapier", help='"rapier", "wgpu" or "auto"')
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    envs = orbit_rs.make(args.task, num_envs=args.num_envs, backend=args.backend, seed=args.seed)
    env = Sb3VecEnvWrapper(envs)
    rollout = args.num_envs * STEPS_PER_ENV
    model = PPO(
        "MlpPolicy",
        env,
        n_steps=STEPS_PER_ENV,
        batch_size=max(rollout // 4, 2),  # 4 mini-batches per epoch
        n_epochs=5,
        learning_rate=1e-3,
        policy_kwargs={"net_arch": [32, 32]},
        seed=args.seed,
        device="cpu",
        verbose=1,
    )
    model.learn(total_timesteps=rollout * args.iterations)
    env.close()

    ret = evaluate(args.task, args.backend, model)
    print(f"final return: {ret:.4f}")


if __name__ == "__main__":
    main()
