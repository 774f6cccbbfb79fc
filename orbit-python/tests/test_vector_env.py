"""orbit-rs envs against gymnasium's vector-env contract (gymnasium 1.x, same-step autoreset)."""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.passive_env_checker import (
    check_action_space,
    check_observation_space,
    data_shares_objects,
)
from gymnasium.vector import AutoresetMode

import orbit_rs
from conftest import CARTPOLE, actions_for, cartpole


def test_spaces_and_batches_follow_gymnasium(env):
    check_observation_space(env.single_observation_space)
    check_action_space(env.single_action_space)
    assert env.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    assert env.observation_space.shape == (16, 4) and env.action_space.shape == (16, 1)
    obs, info = env.reset()
    assert obs.dtype == np.float32 and obs.shape == (16, 4) and info == {}
    assert env.observation_space.contains(obs)
    env.action_space.seed(0)
    obs, rewards, terminated, truncated, _ = env.step(env.action_space.sample())
    assert env.observation_space.contains(obs)
    assert rewards.dtype == np.float32 and rewards.shape == (16,)
    assert terminated.dtype == np.bool_ and truncated.dtype == np.bool_
    assert terminated.shape == truncated.shape == (16,)


def test_returned_data_is_new_on_every_call(env):
    calls = [env.reset(seed=1)]
    for t in range(3):
        obs, _, _, _, info = env.step(actions_for(t, 16, 1))
        calls.append((obs, info))
    calls.append(env.reset())
    for i, (obs_i, info_i) in enumerate(calls):
        for obs_j, info_j in calls[i + 1 :]:
            assert not data_shares_objects(obs_i, obs_j)
            assert not data_shares_objects(info_i, info_j)


def test_step_seconds_counts_only_time_inside_the_steps(env):
    # The time inside the Rust steps grows with each step and never exceeds the wall time
    # around the calls (both clocks are monotonic; 1 ms allows for their different sources).
    env.reset()
    before = env.native.step_seconds
    start = time.perf_counter()
    for t in range(5):
        env.step(actions_for(t, 16, 1))
    wall = time.perf_counter() - start
    inside = env.native.step_seconds - before
    assert 0.0 < inside <= wall + 1e-3


def test_finished_envs_restart_in_the_same_step():
    # 0.5 s episodes at 120 Hz / 2: every env times out after 30 steps, unless it failed first.
    env = cartpole(overrides=["episode_length_s=0.5"])
    assert env.max_episode_length == 30
    env.reset()
    seen_truncation = False
    for t in range(60):
        obs, _, terminated, truncated, info = env.step(actions_for(t, 16, 1))
        done = terminated | truncated
        if not done.any():
            assert "final_obs" not in info
            continue
        assert np.array_equal(info["_final_obs"], done)
        for i in range(16):
            if done[i]:
                final = info["final_obs"][i]
                assert final.shape == (4,) and final.dtype == np.float32
                # A new episode starts from a reset pose, not from where the last one ended.
                assert not np.array_equal(final, obs[i])
            else:
                assert info["final_obs"][i] is None
        if (t + 1) % 30 == 0:
            assert truncated.all(), f"step {t + 1}: every running episode times out"
            seen_truncation = True
    assert seen_truncation


def test_final_obs_is_the_observation_the_episode_ended_in():
    # Twin batches with the same seed and actions; one has episodes half as long. When an env
    # of the short batch times out and its twin runs on, the twin's observation is what the
    # timed-out episode's last observation had to be, to the bit.
    short = cartpole(overrides=["episode_length_s=0.5"])
    long = cartpole(overrides=["episode_length_s=1.0"])
    short.reset()
    long.reset()
    compared = 0
    for t in range(30):
        a = actions_for(t, 16, 1)
        _, _, term_s, trunc_s, info_s = short.step(a)
        obs_l, _, term_l, trunc_l, _ = long.step(a)
        assert np.array_equal(term_s, term_l)
        for i in np.flatnonzero(trunc_s & ~term_s & ~(term_l | trunc_l)):
            assert np.array_equal(info_s["final_obs"][i], obs_l[i])
            compared += 1
    assert compared > 0, "no env timed out in the short batch while its twin ran on"


def test_seeded_resets_repeat_and_seeds_differ(env):
    def rollout(seed):
        obs, _ = env.reset(seed=seed)
        out = [obs]
        for t in range(10):
            out.append(env.step(actions_for(t, 16, 1))[0])
        return np.stack(out)

    first = rollout(5)
    assert np.array_equal(first, rollout(5))
    assert not np.array_equal(first, rollout(6))


def test_episode_statistics_wrapper_counts_finished_episodes():
    env = gym.wrappers.vector.RecordEpisodeStatistics(cartpole(overrides=["episode_length_s=0.5"]))
    env.reset()
    episodes = 0
    for t in range(30):
        _, _, terminated, truncated, info = env.step(actions_for(t, 16, 1))
        if "episode" in info:
            episodes += int(info["_episode"].sum())
            assert np.all(info["episode"]["l"][info["_episode"]] <= 30)
    assert episodes >= 16, "every env ends at least one episode in 30 steps"


def test_errors_arrive_with_orbit_rs_messages(env):
    with pytest.raises(orbit_rs.OrbitError, match="no task `No-Such-Task`"):
        orbit_rs.make("No-Such-Task")
    with pytest.raises(orbit_rs.OrbitError, match="num_envs"):
        orbit_rs.make(CARTPOLE, num_envs=0, backend="rapier")
    env.reset()
    with pytest.raises(ValueError, match=r"the env takes \(16, 1\)"):
        env.step(np.zeros((16, 2), np.float32))
    bad = np.zeros((16, 1), np.float32)
    bad[3, 0] = np.nan
    with pytest.raises(orbit_rs.OrbitError, match="not finite"):
        env.step(bad)
    # The env is still usable after a refused step.
    obs, *_ = env.step(np.zeros((16, 1), np.float32))
    assert np.isfinite(obs).all()


def test_a_black_box_step_is_one_movement_primitive():
    tasks = {t[0]: t for t in orbit_rs.tasks()}
    assert tasks["BoxPushing-ProDMP-Franka-v0"][3], "the ProDMP task is black-box"
    env = orbit_rs.make("BoxPushing-ProDMP-Franka-v0", num_envs=4, backend="rapier", seed=2)
    assert env.max_episode_length == 1
    obs, _ = env.reset()
    assert obs.shape == (4, env.single_observation_space.shape[0])
    params = np.zeros((4, env.single_action_space.shape[0]), np.float32)
    obs, rewards, terminated, truncated, info = env.step(params)
    assert terminated.all() and not truncated.any(), "the primitive runs the whole episode"
    assert all(f.shape == obs.shape[1:] for f in info["final_obs"])
    assert np.isfinite(rewards).all() and "log" in info


def test_a_closed_env_says_so():
    envs = cartpole(num_envs=2)
    envs.reset()
    envs.close()
    for call in (lambda: envs.step(np.zeros((2, 1), np.float32)), envs.reset):
        with pytest.raises(orbit_rs.OrbitError, match="Isaac-Cartpole-v0` was closed"):
            call()


def test_reset_mask_resets_the_masked_envs_alone(env):
    env.reset()
    for t in range(3):
        env.step(actions_for(t, 16, 1))
    before = env.native.observations()
    mask = np.zeros(16, bool)
    mask[[2, 5]] = True
    obs, info = env.reset(options={"reset_mask": mask})
    lengths = env.native.episode_lengths()
    assert info == {}
    assert (lengths[mask] == 0).all() and (lengths[~mask] == 3).all()
    np.testing.assert_array_equal(obs[~mask], before[~mask])
    assert not np.array_equal(obs[mask], before[mask])
    with pytest.raises(ValueError, match=r"\['seeds'\] are not understood"):
        env.reset(options={"seeds": 1})
    with pytest.raises(ValueError, match="boolean array of shape"):
        env.reset(options={"reset_mask": [1, 0]})


def test_without_final_obs_no_final_obs_keys():
    envs = cartpole(final_obs=False, overrides=["episode_length_s=0.1"])
    envs.reset()
    for t in range(20):
        _, _, terminated, truncated, info = envs.step(actions_for(t, 16, 1))
        if (terminated | truncated).any():
            break
    assert (terminated | truncated).any()
    assert "_final_obs" not in info and "final_obs" not in info
    np.testing.assert_array_equal(info["_final_info"], terminated | truncated)


def test_the_action_space_holds_the_saturation_bounds(env):
    # The cart's drive is damped, so 400 N of action need not saturate it: unbounded.
    assert not env.single_action_space.is_bounded("both")
    # Undamped, its effort of 100 N per unit saturates at the 400 N limit: beyond ±4 every
    # action acts as ±4 does.
    undamped = cartpole(
        overrides=[
            "scene.articulations.robot.actuators.cart_actuator=(joint_names_expr: "
            '["slider_to_cart"], stiffness: 0.0, damping: 0.0, effort_limit: Some(400.0))'
        ]
    )
    np.testing.assert_array_equal(undamped.single_action_space.low, [-4.0])
    np.testing.assert_array_equal(undamped.single_action_space.high, [4.0])
    observed = []
    for action in (4.0, 1e30, 3.5):
        undamped.reset(seed=7)
        observed.append(undamped.step(np.full((16, 1), action, np.float32))[0])
    np.testing.assert_array_equal(observed[0], observed[1])
    assert not np.array_equal(observed[0], observed[2])
    # A clip bounds the space where the term sets it.
    clipped = cartpole(overrides=["actions.joint_effort.params.clip=(-1.0, 1.0)"])
    np.testing.assert_array_equal(clipped.single_action_space.high, [1.0])


def test_version_and_backend_choice_go_to_their_places(capsys, caplog):
    assert orbit_rs.__version__.count(".") == 2
    with caplog.at_level("INFO", logger="orbit_rs"):
        envs = orbit_rs.make(CARTPOLE, num_envs=2, backend="auto", seed=1)
    assert capsys.readouterr().out == ""
    assert any("chose it" in r.getMessage() for r in caplog.records), caplog.records
    envs.close()
