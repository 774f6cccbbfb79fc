"""The learning libraries' adapters: RSL-RL's own runner learns the reach task and
Stable-Baselines3's PPO balances the cart-pole through them; skrl's wrapper contract holds."""

from __future__ import annotations

import numpy as np
import pytest

import orbit_rs
from conftest import actions_for, cartpole, need

torch = need("torch")

# The reach task with a fixed target, position reward only and 2 s episodes, as the Rust
# learning test trains it: within a CI budget, unlike the full task (about 10^7 transitions).
REACH = "Reach-Franka-v0"
REACH_FIXED = [
    "episode_length_s=2.0",
    "rewards.end_effector_orientation_tracking.weight=0.0",
    "commands.ee_pose.params.ranges.pos_x=(0.5, 0.5)",
    "commands.ee_pose.params.ranges.pos_y=(0.1, 0.1)",
    "commands.ee_pose.params.ranges.pos_z=(0.3, 0.3)",
]


def reach(num_envs: int, seed: int) -> orbit_rs.OrbitVectorEnv:
    return orbit_rs.make(REACH, num_envs=num_envs, backend="rapier", seed=seed, overrides=REACH_FIXED)


def evaluate_reach(act) -> tuple[float, float]:
    """Final tcp-target distance (m) and mean return of `act`'s actions over one episode of
    64 fresh envs."""
    env = reach(64, 1234)
    obs, _ = env.reset()
    ret = 0.0
    while True:
        obs, rewards, terminated, truncated, info = env.step(act(obs))
        ret += float(rewards.mean())
        if (terminated | truncated).all():
            return info["log"]["Metrics/ee_pose/position_error"], ret


def test_rsl_rl_runner_learns_to_reach(tmp_path):
    need("rsl_rl")
    from rsl_rl.runners import OnPolicyRunner

    from orbit_rs.wrappers.rsl_rl import RslRlVecEnvWrapper

    torch.manual_seed(0)
    env = RslRlVecEnvWrapper(reach(64, 0))
    model = {
        "class_name": "MLPModel",
        "hidden_dims": [64, 64],
        "activation": "elu",
        "obs_normalization": True,
    }
    cfg = {
        "num_steps_per_env": 24,
        "save_interval": 1000,
        "obs_groups": {"actor": ["policy"], "critic": ["critic"]},
        "actor": {**model, "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 0.5}},
        "critic": model,
        "algorithm": {
            "class_name": "PPO",
            "num_learning_epochs": 5,
            "num_mini_batches": 4,
            "learning_rate": 5e-4,
            "schedule": "fixed",
            "entropy_coef": 0.001,
            "gamma": 0.99,
            "lam": 0.95,
            "desired_kl": 0.01,
            "max_grad_norm": 1.0,
        },
    }
    runner = OnPolicyRunner(env, cfg, log_dir=str(tmp_path), device="cpu")

    def act(obs):
        policy = runner.get_inference_policy()
        with torch.inference_mode():
            groups = env._observations(obs)
            return policy(groups).numpy()

    d0, r0 = evaluate_reach(act)
    runner.learn(80)
    d1, r1 = evaluate_reach(act)
    print(f"RSL-RL on orbit-rs reach: final distance {d0:.4f} -> {d1:.4f} m, return {r0:.3f} -> {r1:.3f}")
    assert d1 < 0.7 * d0, f"final distance: untrained {d0} m, trained {d1} m"
    assert r1 > r0 + 0.05, f"return: untrained {r0}, trained {r1}"


def cartpole_return(act) -> float:
    """Mean return of `act`'s actions over one whole episode (5 s) of 64 fresh cart-poles."""
    env = cartpole(num_envs=64, seed=1234)
    obs, _ = env.reset()
    ret = 0.0
    for _ in range(env.max_episode_length):
        obs, rewards, *_ = env.step(act(obs))
        ret += float(rewards.mean())
    return ret


def test_sb3_ppo_balances_the_pole():
    need("stable_baselines3")
    from stable_baselines3 import PPO

    from orbit_rs.wrappers.sb3 import Sb3VecEnvWrapper

    env = Sb3VecEnvWrapper(cartpole(num_envs=256, seed=0))
    model = PPO(
        "MlpPolicy",
        env,
        n_steps=16,
        batch_size=1024,
        n_epochs=5,
        learning_rate=1e-3,
        policy_kwargs={"net_arch": [32, 32]},
        seed=0,
        device="cpu",
    )

    def act(obs):
        return model.predict(obs, deterministic=True)[0]

    r0 = cartpole_return(act)
    model.learn(total_timesteps=256 * 16 * 40)
    r1 = cartpole_return(act)
    print(f"SB3 PPO on orbit-rs Cart-pole: return {r0:.3f} -> {r1:.3f} (ceiling 5.0)")
    # The untrained policy lets the pole fall; a balanced pole earns nearly 1 per second.
    assert r0 < 0.0 and r1 > 4.5, f"return: untrained {r0}, trained {r1}"


def test_sb3_infos_carry_terminal_observations():
    need("stable_baselines3")
    from orbit_rs.wrappers.sb3 import Sb3VecEnvWrapper

    env = Sb3VecEnvWrapper(cartpole(overrides=["episode_length_s=0.5"]))
    env.reset()
    for t in range(30):
        env.step_async(actions_for(t, 16, 1))
        obs, rewards, dones, infos = env.step_wait()
        assert len(infos) == 16 and rewards.shape == dones.shape == (16,)
        for i in range(16):
            assert ("terminal_observation" in infos[i]) == dones[i]
    assert all(info["TimeLimit.truncated"] for info in infos if "terminal_observation" in info)


def test_sb3_time_outs_are_marked_without_final_observations():
    need("stable_baselines3")
    from orbit_rs.wrappers.sb3 import Sb3VecEnvWrapper

    env = Sb3VecEnvWrapper(cartpole(final_obs=False, overrides=["episode_length_s=0.1"]))
    env.reset()
    timed_out = 0
    for t in range(20):
        env.step_async(np.zeros((16, 1), np.float32))
        _, _, dones, infos = env.step_wait()
        timed_out += sum(info.get("TimeLimit.truncated", False) for info in infos)
        assert all("terminal_observation" not in info for info in infos)
    assert timed_out >= 16, "every held pole times out after 0.1 s"
    # Unbounded values get SB3's [-100, 100].
    np.testing.assert_array_equal(env.action_space.high, [100.0])


def test_skrl_wrapper_gives_column_tensors():
    need("skrl")
    from orbit_rs.wrappers.skrl import SkrlVecEnvWrapper

    env = SkrlVecEnvWrapper(cartpole())
    assert env.num_envs == 16 and env.observation_space.shape == (4,)
    assert env.action_space.shape == (1,) and env.state_space.shape == (4,)
    obs, _ = env.reset()
    assert obs.shape == (16, 4) and obs.dtype == torch.float32
    obs, rewards, terminated, truncated, _ = env.step(torch.zeros(16, 1))
    assert rewards.shape == terminated.shape == truncated.shape == (16, 1)
    assert torch.equal(env.state(), obs), "cart-pole's critic sees the policy's observations"
    again, _ = env.reset()
    assert torch.equal(again, obs), "the envs reset themselves: reset() after the first is a no-op"


def test_observations_reach_torch_without_a_copy(env):
    obs, _ = env.reset()
    tensor = torch.from_dlpack(obs)
    assert tensor.dtype == torch.float32 and tuple(tensor.shape) == obs.shape
    obs[0, 0] = 123.0
    assert tensor[0, 0].item() == 123.0, "the tensor shares the array's memory"
