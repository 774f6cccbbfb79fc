#!/usr/bin/env python3
"""Writes MuJoCo's view of an MJCF model as JSON, the reference the MJCF importer is tested
against (`orbit-assets/tests/mjcf_import.rs`).

Usage (from the workspace root):

    python3 orbit-assets/tools/mjcf_reference.py orbit-assets/assets/ant.xml \
        > orbit-assets/tests/data/ant_mujoco_reference.json
    python3 orbit-assets/tools/mjcf_reference.py orbit-assets/tests/data/multi_joint.xml \
        > orbit-assets/tests/data/multi_joint_mujoco_reference.json

Needs `pip install mujoco numpy`. For every body but the world: its mass, its inertia tensor
about its centre of mass in the body frame (MuJoCo's principal moments rotated by `body_iquat`),
its centre of mass in the body frame, and its world position, orientation (wxyz) and centre of
mass at the
model's reference configuration and at one configuration drawn with a fixed seed (the free
joint moved and turned, every hinge or slide within its range).
"""

import json
import sys

import mujoco
import numpy as np


def quat_to_matrix(q):
    m = np.zeros(9)
    mujoco.mju_quat2Mat(m, np.asarray(q, dtype=float))
    return m.reshape(3, 3)


def poses(model, data):
    mujoco.mj_kinematics(model, data)
    return {
        model.body(b).name: {
            "pos": data.xpos[b].tolist(),
            "quat": data.xquat[b].tolist(),
            "com": data.xipos[b].tolist(),
        }
        for b in range(1, model.nbody)
    }


def main():
    path = sys.argv[1]
    model = mujoco.MjModel.from_xml_path(path)
    data = mujoco.MjData(model)
    bodies = {}
    for b in range(1, model.nbody):
        rot = quat_to_matrix(model.body_iquat[b])
        inertia = rot @ np.diag(model.body_inertia[b]) @ rot.T
        bodies[model.body(b).name] = {
            "mass": float(model.body_mass[b]),
            "com": model.body_ipos[b].tolist(),
            "inertia": inertia.tolist(),
        }
    reference = poses(model, data)
    rng = np.random.default_rng(7)
    qpos = model.qpos0.copy()
    for j in range(model.njnt):
        adr = model.jnt_qposadr[j]
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            qpos[adr : adr + 3] += [0.3, -0.2, 0.1]
            quat = rng.normal(size=4)
            qpos[adr + 3 : adr + 7] = quat / np.linalg.norm(quat)
        else:
            lo, hi = model.jnt_range[j] if model.jnt_limited[j] else (-1.0, 1.0)
            qpos[adr] = rng.uniform(lo, hi)
    data.qpos[:] = qpos
    moved = poses(model, data)
    joints = {
        model.joint(j).name: float(qpos[model.jnt_qposadr[j]])
        for j in range(model.njnt)
        if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE
    }
    free = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
    root = None
    if free:
        adr = model.jnt_qposadr[free[0]]
        root = {"pos": qpos[adr : adr + 3].tolist(), "quat": qpos[adr + 3 : adr + 7].tolist()}
    json.dump(
        {
            "about": f"MuJoCo {mujoco.__version__} on {path} (orbit-assets/tools/mjcf_reference.py)",
            "bodies": bodies,
            "reference_poses": reference,
            "moved": {"root": root, "joints": joints, "poses": moved},
        },
        sys.stdout,
        indent=1,
    )
    print()


if __name__ == "__main__":
    main()
