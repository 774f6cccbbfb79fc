"""Env-steps/s of MuJoCo on Fancy Gym's box-pushing model, per CPU core.

The same load as `cargo run --release --example benchmark` puts on orbit-rs's backends: one env
step is 10 substeps of 2 ms; the arm runs Fancy Gym's torque law, tau = clip(10 a + bias,
+-tau_max), with the bias force (MuJoCo's qfrc_bias) taken once per env step as Fancy Gym does
and the normalised action a_j = 0.3 sin(pi t + j); the box starts on the table as in
`orbit-conformance/data/mujoco_box_pushing_rollouts.json`. Each process steps its own envs
(MjData) one after another on one thread, so `--processes N` runs N cores side by side.

    python3 mujoco_box_pushing_speed.py FANCY_GYM_DIR [--envs 16] [--steps 200] [--processes 1]

FANCY_GYM_DIR is a checkout of github.com/ALRhub/fancy_gym (the model is
fancy_gym/envs/mujoco/box_pushing/assets/box_pushing.xml). Needs `pip install mujoco numpy`.
"""

import argparse
import json
import multiprocessing
import os
import pathlib
import tempfile
import time

import mujoco
import numpy as np

ROLLOUTS = pathlib.Path(__file__).parent.parent / "data" / "mujoco_box_pushing_rollouts.json"
SUBSTEPS = 10
WARMUP = 20


def load_model(fancy_gym: pathlib.Path) -> mujoco.MjModel:
    """Fancy Gym's model; `collision="all"`, which MuJoCo 3.x no longer takes, is dropped."""
    assets = fancy_gym / "fancy_gym" / "envs" / "mujoco" / "box_pushing" / "assets"
    text = (assets / "box_pushing.xml").read_text().replace(' collision="all"', "")
    # Written beside the original so that its includes and meshes resolve.
    with tempfile.NamedTemporaryFile("w", suffix=".xml", dir=assets, delete=False) as f:
        f.write(text)
    try:
        return mujoco.MjModel.from_xml_path(f.name)
    finally:
        os.unlink(f.name)


def run(args) -> float:
    """Env-steps/s of `args.envs` envs stepped `args.steps` times on this process's core."""
    model = load_model(pathlib.Path(args.fancy_gym))
    reference = json.loads(ROLLOUTS.read_text())
    tau_max = np.array(reference["torque_max"])
    envs = []
    for _ in range(args.envs):
        data = mujoco.MjData(model)
        data.qpos[:7] = reference["initial_arm_q"]
        box = reference["initial_box_pose"]  # x, y, z, then the quaternion xyzw
        adr = model.jnt_qposadr[model.joint("box_joint").id]
        data.qpos[adr : adr + 3] = box[:3]
        data.qpos[adr + 3 : adr + 7] = [box[6], box[3], box[4], box[5]]
        mujoco.mj_forward(model, data)
        envs.append(data)
    joints = np.arange(7)

    def step(k: int) -> None:
        action = 0.3 * np.sin(np.pi * k * 0.02 + joints)
        for data in envs:
            data.ctrl[:7] = np.clip(10.0 * action + data.qfrc_bias[:7], -tau_max, tau_max)
            mujoco.mj_step(model, data, nstep=SUBSTEPS)

    for k in range(WARMUP):
        step(k)
    start = time.perf_counter()
    for k in range(WARMUP, WARMUP + args.steps):
        step(k)
    elapsed = time.perf_counter() - start
    if not all(np.isfinite(d.qpos).all() for d in envs):
        raise RuntimeError("the simulation diverged")
    return args.envs * args.steps / elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("fancy_gym", help="a checkout of github.com/ALRhub/fancy_gym")
    parser.add_argument("--envs", type=int, default=16, help="envs per process")
    parser.add_argument("--steps", type=int, default=200, help="measured env steps")
    parser.add_argument("--processes", type=int, default=1, help="processes side by side")
    args = parser.parse_args()
    with multiprocessing.Pool(args.processes) as pool:
        rates = pool.map(run, [args] * args.processes)
    total = sum(rates)
    print(
        f"MuJoCo {mujoco.__version__}: {args.processes} process(es) x {args.envs} envs, "
        f"{args.steps} env steps of {SUBSTEPS} substeps: {total:.0f} env-steps/s, "
        f"{total / args.processes:.0f} per process"
    )


if __name__ == "__main__":
    main()
