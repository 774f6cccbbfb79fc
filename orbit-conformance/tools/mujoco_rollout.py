#!/usr/bin/env python3
"""Writes a MuJoCo rollout of a bundled floating-base robot under open-loop joint torques, the
reference that `orbit_conformance::{ant,humanoid}_tracks_mujoco_rollout` replay on each backend.

Usage (from the workspace root):

    python3 orbit-conformance/tools/mujoco_rollout.py ant orbit-assets/assets/ant.xml \
        > orbit-conformance/data/mujoco_ant_rollout.json
    python3 orbit-conformance/tools/mujoco_rollout.py humanoid \
        orbit-assets/assets/isaac_humanoid.xml > orbit-conformance/data/mujoco_humanoid_rollout.json
    python3 orbit-conformance/tools/mujoco_rollout.py ant_standing orbit-assets/assets/ant.xml \
        > orbit-conformance/data/mujoco_ant_standing_rollout.json

Needs `pip install mujoco numpy`. Each 2 ms step applies the torques to the joints
(`qfrc_applied`, no actuators involved) with MuJoCo's default settings (semi-implicit Euler
with implicit joint damping, gravity 9.81 m/s^2). The robot starts high, tilted, moving and
spinning, falls until a geom first touches another (the ground or, for the Humanoid, one of
its own), then lands. The file holds the initial state (root velocities in world axes), the
torques of every step, every fifth step's root position, orientation (x, y, z, w) and joint
positions, and the time of the first contact.

- `ant`: the Ant starts 1 m up, hips near 0 and ankles at +-50 degrees; sinusoidal torques of
  4 N m on its eight joints.
- `ant_standing`: the Ant (joint armature 1, large against its legs' inertias) standing on
  the ground from Gymnasium's start (torso 0.55 m up, level and at rest, hips at 0, ankles at
  +-1 rad) under sinusoidal torques of 2 N m, in contact from the first step; the geoms'
  `margin` is set to 0 (the engines compared with it do not simulate margins), so MuJoCo's
  contacts act at touch as theirs do.
- `humanoid`: the Humanoid of the `humanoid` asset config, whose drives towards 0 are joint
  springs and dampers here (`GAINS`, written to the file so that the replay checks they are
  the asset's), starts 2 m up with every joint 0.25 rad or more inside its range; each joint's
  torque holds it at its start against its spring and swings it by about 0.1 rad. No joint
  reaches a limit before the first contact (checked).
"""

import json
import math
import sys

import mujoco
import numpy as np

DT = 0.002
STEPS = 500
RECORD_EVERY = 5

# The `humanoid` asset config's drive gains by joint-name prefix (stiffness N m/rad, damping
# N m s/rad): Isaac Lab's HUMANOID_CFG.
GAINS = [
    ("abdomen_z", 20.0, 5.0),
    ("abdomen_y", 20.0, 5.0),
    ("abdomen_x", 10.0, 5.0),
    ("shoulder", 10.0, 5.0),
    ("elbow", 2.0, 1.0),
    ("hip_x", 10.0, 5.0),
    ("hip_z", 10.0, 5.0),
    ("hip_y", 20.0, 5.0),
    ("knee", 5.0, 0.1),
    ("ankle", 2.0, 1.0),
]


def gains(name):
    for key, k, d in GAINS:
        if key in name:
            return k, d
    raise KeyError(name)


def ant_start(model, joints):
    joint_pos = [0.1, 0.87, -0.1, -0.87, 0.05, -0.87, -0.05, 0.87]

    def torque(j, t):
        return 4.0 * math.sin(2.0 * math.pi * (1.0 + 0.25 * j) * t + 0.7 * j)

    return 1.0, joint_pos, torque, None


def ant_standing_start(model, joints):
    model.geom_margin[:] = 0.0
    joint_pos = [0.0, 1.0, 0.0, -1.0, 0.0, -1.0, 0.0, 1.0]

    def torque(j, t):
        return 2.0 * math.sin(2.0 * math.pi * (1.0 + 0.25 * j) * t + 0.7 * j)

    return 0.55, joint_pos, torque, None


def humanoid_start(model, joints):
    stiffness, damping = zip(*(gains(n) for n in joints))
    for j, name in enumerate(joints):
        model.jnt_stiffness[j + 1] = stiffness[j]
        model.dof_damping[model.jnt_dofadr[j + 1]] = damping[j]
    # Start inside each range: the middle, pulled 0.4 of the way towards 0.
    ranges = model.jnt_range[1:]
    joint_pos = [0.6 * 0.5 * (lo + hi) for lo, hi in ranges]
    for q, (lo, hi) in zip(joint_pos, ranges):
        assert lo + 0.25 <= q <= hi - 0.25, (q, lo, hi)
    model.qpos_spring[7:] = 0.0

    def torque(j, t):
        hold = stiffness[j] * joint_pos[j]
        swing = 0.1 * stiffness[j] * math.sin(2.0 * math.pi * (1.0 + 0.25 * j) * t + 0.7 * j)
        return hold + swing

    return 2.0, joint_pos, torque, {"stiffness": list(stiffness), "damping": list(damping)}


def main():
    kind, path = sys.argv[1], sys.argv[2]
    model = mujoco.MjModel.from_xml_path(path)
    model.opt.timestep = DT
    joints = [model.joint(j).name for j in range(1, model.njnt)]
    starts = {"ant": ant_start, "ant_standing": ant_standing_start, "humanoid": humanoid_start}
    height, joint_pos, torque, joint_gains = starts[kind](model, joints)
    data = mujoco.MjData(model)
    axis = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    angle = 0.1
    quat_wxyz = np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis])
    lin_vel = np.array([0.3, -0.2, 0.5])
    ang_vel = np.array([0.4, -0.6, 1.0])
    if kind == "ant_standing":
        quat_wxyz = np.array([1.0, 0.0, 0.0, 0.0])
        lin_vel, ang_vel = np.zeros(3), np.zeros(3)
    data.qpos[:3] = [0.0, 0.0, height]
    data.qpos[3:7] = quat_wxyz
    data.qpos[7:] = joint_pos
    # A free joint's angular velocity is in the body frame.
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, quat_wxyz)
    data.qvel[:3] = lin_vel
    data.qvel[3:6] = rot.reshape(3, 3).T @ ang_vel
    mujoco.mj_forward(model, data)

    efforts = []
    records = []
    first_contact = None
    for k in range(STEPS):
        t = k * DT
        tau = [torque(j, t) for j in range(len(joints))]
        efforts.append(tau)
        data.qfrc_applied[6:] = tau
        mujoco.mj_step(model, data)
        if first_contact is None and data.ncon > 0:
            first_contact = (k + 1) * DT
        if first_contact is None and data.nl > 0:
            sys.exit(f"a joint limit is reached at {(k + 1) * DT} s, before the first contact")
        if (k + 1) % RECORD_EVERY == 0:
            w, x, y, z = data.qpos[3:7]
            records.append(
                {
                    "t": (k + 1) * DT,
                    "root_pos": data.qpos[:3].tolist(),
                    "root_quat": [x, y, z, w],
                    "joint_pos": data.qpos[7:].tolist(),
                }
            )
    out = {
        "mujoco": mujoco.__version__,
        "dt": DT,
        "record_every": RECORD_EVERY,
        "joints": joints,
        "initial": {
            "root_pos": [0.0, 0.0, height],
            "root_quat": [*quat_wxyz[1:].tolist(), float(quat_wxyz[0])],
            "lin_vel": lin_vel.tolist(),
            "ang_vel": ang_vel.tolist(),
            "joint_pos": joint_pos,
        },
        "first_contact": first_contact,
        "efforts": efforts,
        "records": records,
    }
    if joint_gains is not None:
        out["gains"] = joint_gains
    json.dump(out, sys.stdout)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
