#!/usr/bin/env python3
"""Writes a MuJoCo rollout of the bundled Ant under open-loop joint torques, the reference that
`orbit_conformance::ant_tracks_mujoco_rollout` replays on each backend.

Usage (from the workspace root):

    python3 orbit-conformance/tools/mujoco_ant_rollout.py orbit-assets/assets/ant.xml \
        > orbit-conformance/data/mujoco_ant_rollout.json

Needs `pip install mujoco numpy`. The Ant starts 1 m up, tilted, moving and spinning, its hips
near 0 and its ankles at +-50 degrees (inside their ranges); each 2 ms step applies sinusoidal
torques of 4 N m to its eight joints (`qfrc_applied`, no actuators involved) with MuJoCo's
default settings (semi-implicit Euler with implicit joint damping, gravity 9.81 m/s^2). It
falls for about 0.3 s before a foot comes within the geoms' 1 cm contact margin, then lands.
The file holds the initial state (root velocities in world axes), the torques of every step,
and every fifth step's root position, orientation (x, y, z, w) and joint positions, with the
time of the first contact.
"""

import json
import math
import sys

import mujoco
import numpy as np

DT = 0.002
STEPS = 500
RECORD_EVERY = 5
AMPLITUDE = 4.0


def main():
    model = mujoco.MjModel.from_xml_path(sys.argv[1])
    model.opt.timestep = DT
    data = mujoco.MjData(model)
    joints = [model.joint(j).name for j in range(1, model.njnt)]
    joint_pos = [0.1, 0.87, -0.1, -0.87, 0.05, -0.87, -0.05, 0.87]
    axis = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    angle = 0.1
    quat_wxyz = np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis])
    lin_vel = np.array([0.3, -0.2, 0.5])
    ang_vel = np.array([0.4, -0.6, 1.0])
    data.qpos[:3] = [0.0, 0.0, 1.0]
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
        tau = [
            AMPLITUDE * math.sin(2.0 * math.pi * (1.0 + 0.25 * j) * t + 0.7 * j)
            for j in range(len(joints))
        ]
        efforts.append(tau)
        data.qfrc_applied[6:] = tau
        mujoco.mj_step(model, data)
        if first_contact is None and data.ncon > 0:
            first_contact = (k + 1) * DT
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
    json.dump(
        {
            "mujoco": mujoco.__version__,
            "dt": DT,
            "record_every": RECORD_EVERY,
            "joints": joints,
            "initial": {
                "root_pos": [0.0, 0.0, 1.0],
                "root_quat": [*quat_wxyz[1:].tolist(), float(quat_wxyz[0])],
                "lin_vel": lin_vel.tolist(),
                "ang_vel": ang_vel.tolist(),
                "joint_pos": joint_pos,
            },
            "first_contact": first_contact,
            "efforts": efforts,
            "records": records,
        },
        sys.stdout,
    )
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
