#!/usr/bin/env python3
"""Physics steps/s of orbit-rs's GPU backend beside MuJoCo Warp's, model by model, in one run.

For every model and env count this runs `physics_speed` (orbit-rs, wgpu backend) and then
MuJoCo Warp's own benchmark (`python3 -m mujoco_warp.testspeed`, a CUDA graph of its steps) on
the same MJCF file, start and timestep, and prints one Markdown table: model, envs, orbit-rs
steps/s, the kernel's ms per step, MuJoCo Warp steps/s and the ratio. A step is one physics
step of all envs; neither side resets or reads state in between. orbit-rs's joints take
sinusoidal efforts of `--effort` N m; MuJoCo Warp's actuators take its default control noise.

Models (`--models` picks some by key):

- `ant`: `orbit-assets/assets/scenes/ant.ron` beside `orbit-conformance/tools/ant_standing.xml`
  (the same Ant with its start as a keyframe), 1/120 s steps.
- `humanoid`: `scenes/humanoid.ron` beside `tools/humanoid_standing.xml` (the drives towards 0
  as joint springs and dampers), 1/120 s steps.
- `mjw_humanoid`: MuJoCo Warp's test humanoid (`test_data/humanoid/humanoid.xml` of the
  installed package) at its own 5 ms step, both engines on one copy of the file whose contact
  settings are the ones both simulate: every geom's `condim` 3 (the file has 1 on the body's
  geoms) and no `margin` or `gap`, MuJoCo's default `solref`/`solimp` on geoms and joint
  limits (the file sets its own), the Euler integrator with its damping implicit (the file
  disables that). orbit-rs starts from the file's first
  keyframe, as `testspeed` does.
- `box_pushing`: `scenes/box_pushing.ron` at 2 ms steps; MuJoCo Warp is not run (Fancy Gym's
  model needs its meshes, which this repository does not carry).

`--mjcf FILE` (repeatable) adds a model of one's own, run like `mjw_humanoid`: a copy with the
contact settings both engines simulate, the file's timestep, the first keyframe as the start
(if it has none, MuJoCo's reference configuration with each joint moved into its range, added
to the copy as a keyframe), a floating base if its top-level body has a free joint.

Usage, from the workspace root, on a machine with an NVIDIA GPU, a Vulkan driver and
`pip install mujoco-warp`:

    cargo build --release --example physics_speed
    python3 tools/physics_table.py --envs 4096,65536 --steps 1000
"""

import argparse
import importlib.util
import json
import os
import pathlib
import re
import subprocess
import sys
import tempfile

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent


def mjw_file(relative):
    spec = importlib.util.find_spec("mujoco_warp")
    if spec is None:
        sys.exit("mujoco_warp is not installed: pip install mujoco-warp")
    return pathlib.Path(spec.submodule_search_locations[0]) / relative


def joint_ids(model):
    """The ids of `model`'s hinge and slide joints: those orbit-rs gives a dof each."""
    import mujoco

    moving = {int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)}
    return [j for j in range(model.njnt) if int(model.jnt_type[j]) in moving]


def same_contacts(source, target):
    """Writes `source` with the contact settings both engines simulate (module docstring)."""
    import mujoco

    spec = mujoco.MjSpec.from_file(str(source))
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    for geom in spec.geoms:
        geom.condim = 3
        geom.margin = 0.0
        geom.gap = 0.0
        geom.solref = [0.02, 1.0]
        geom.solimp = [0.9, 0.95, 0.001, 0.5, 2.0]
    for joint in spec.joints:
        joint.solref_limit = [0.02, 1.0]
        joint.solimp_limit = [0.9, 0.95, 0.001, 0.5, 2.0]
    spec.option.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_EULERDAMP)
    model = spec.compile()
    if model.nkey == 0:
        # Both engines start from the reference configuration, each joint moved into its range
        # (orbit-rs refuses a start outside the limits, MuJoCo would push it back in).
        qpos = model.qpos0.copy()
        for j in joint_ids(model):
            if model.jnt_limited[j]:
                lo, hi = model.jnt_range[j]
                a = model.jnt_qposadr[j]
                qpos[a] = min(max(qpos[a], lo), hi)
        key = spec.add_key()
        key.name = "start"
        key.qpos = qpos.tolist()
        spec.compile()
    target.write_text(spec.to_xml())


def keyframe_scene(mjcf, target):
    """An orbit-rs scene of `mjcf`'s robot on the ground plane, from the file's first keyframe
    (its reference configuration if it has none)."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(mjcf))
    qpos = model.key_qpos[0] if model.nkey > 0 else model.qpos0
    floating = model.njnt > 0 and int(model.jnt_type[0]) == int(mujoco.mjtJoint.mjJNT_FREE)
    joint_pos = ", ".join(
        f'"{model.joint(j).name}": {float(qpos[model.jnt_qposadr[j]])!r}' for j in joint_ids(model)
    )
    root = qpos[:7] if floating else np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    pos = ", ".join(repr(float(x)) for x in root[:3])
    rot = ", ".join(repr(float(x)) for x in root[3:7])
    target.write_text(
        f"""(
    env_spacing: 5.0,
    articulations: {{"robot": (
        spawn: Mjcf(path: "{mjcf}"),
        init_state: (pos: ({pos}), rot: ({rot}), joint_pos: {{{joint_pos}}}),
        fixed_base: {str(not floating).lower()},
        self_collisions: true,
    )}},
    static_objects: {{"ground": (asset: "ground_plane")}},
)
"""
    )


def orbit_rs(args, scene, dt, envs):
    """(steps/s, kernel ms per step) of `physics_speed`, or the error it printed."""
    cmd = [args.bin, "--scene", str(scene), "--backend", "wgpu", "--num-envs", str(envs),
           "--steps", str(args.steps), "--dt", repr(dt), "--effort", repr(args.effort)]
    run = subprocess.run(cmd, capture_output=True, text=True)
    print(" ".join(cmd), file=sys.stderr)
    print(run.stdout + run.stderr, file=sys.stderr)
    for line in run.stdout.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if cells and cells[0] == str(envs):
            return int(cells[1]), float(cells[2])
    return None, run.stderr.strip().splitlines()[-1:] or ["failed"]


def mujoco_warp(args, mjcf, dt, envs, njmax, overflow="error"):
    """MuJoCo Warp's steps/s and a note, or None and why there is none.

    A run stopped only because a world's line search used up its iterations (which drops no
    constraint) is run again past that, and the note says so; a run whose worlds overflowed
    their contact or constraint buffers has no figure."""
    cmd = [sys.executable, "-m", "mujoco_warp.testspeed", str(mjcf), "--nstep", str(args.steps),
           "--nworld", str(envs), "--format", "json", "--overflow_behavior", overflow]
    if dt is not None:
        cmd += ["-o", f"opt.timestep={dt!r}"]
    if njmax is not None:
        cmd += ["--njmax", str(njmax)]
    run = subprocess.run(cmd, capture_output=True, text=True)
    print(" ".join(cmd), file=sys.stderr)
    print(run.stdout[-2000:] + run.stderr[-2000:], file=sys.stderr)
    for line in run.stdout.splitlines():
        if line.startswith("{"):
            metrics = json.loads(line)
            if metrics["converged_worlds"] != envs:
                return None, f"{envs - metrics['converged_worlds']} worlds diverged"
            return metrics["steps_per_second"], None
    flags = re.findall(r"World \d+: (.*)", run.stdout)
    if flags and all(f.strip() == "LS_ITERATIONS" for f in flags) and overflow == "error":
        theirs, _ = mujoco_warp(args, mjcf, dt, envs, njmax, "continue")
        return theirs, f"line search capped in {len(flags)} world(s)"
    found = re.search(r"overflow detected in .*", run.stdout)
    return None, found.group(0) if found else f"exit {run.returncode}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bin", default=str(ROOT / "target/release/examples/physics_speed"))
    parser.add_argument("--envs", default="4096,65536")
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--effort", type=float, default=1.5)
    parser.add_argument("--models", default="ant,humanoid,mjw_humanoid,box_pushing")
    parser.add_argument("--mjcf", action="append", default=[],
                        help="an MJCF file of one's own to add (repeatable)")
    parser.add_argument("--out", help="also write the table to this file")
    args = parser.parse_args()
    work = pathlib.Path(tempfile.mkdtemp(prefix="physics_table_"))
    scenes = ROOT / "orbit-assets/assets/scenes"
    tools = ROOT / "orbit-conformance/tools"
    # key: (label, orbit-rs scene, MJCF for MuJoCo Warp, dt, njmax at each env count)
    models = {
        "ant": ("Ant", scenes / "ant.ron", tools / "ant_standing.xml", 1 / 120, None),
        "humanoid": ("Humanoid", scenes / "humanoid.ron", tools / "humanoid_standing.xml",
                     1 / 120, 128),
        "box_pushing": ("box pushing", scenes / "box_pushing.ron", None, 0.002, None),
    }
    if "mjw_humanoid" in args.models.split(","):
        mjcf = work / "humanoid.xml"
        same_contacts(mjw_file("test_data/humanoid/humanoid.xml"), mjcf)
        keyframe_scene(mjcf, work / "humanoid.ron")
        models["mjw_humanoid"] = ("MuJoCo Warp's test humanoid", work / "humanoid.ron", mjcf,
                                  0.005, 128)
    keys = [k for k in args.models.split(",") if k]
    for i, path in enumerate(args.mjcf):
        source = pathlib.Path(path).resolve()
        mjcf = work / f"model{i}.xml"
        same_contacts(source, mjcf)
        keyframe_scene(mjcf, work / f"model{i}.ron")
        import mujoco

        dt = float(mujoco.MjModel.from_xml_path(str(mjcf)).opt.timestep)
        models[source.name] = (source.name, work / f"model{i}.ron", mjcf, dt, 128)
        keys.append(source.name)
    rows = ["| model | envs | orbit-rs steps/s | kernel ms / step | MuJoCo Warp steps/s | ratio |",
            "|---|---:|---:|---:|---:|---:|"]
    for key in keys:
        label, scene, mjcf, dt, njmax = models[key]
        for envs in (int(e) for e in args.envs.split(",")):
            ours, kernel = orbit_rs(args, scene, dt, envs)
            theirs, why = (None, "not run") if mjcf is None else mujoco_warp(args, mjcf, dt, envs,
                                                                            njmax)
            ours_cell = f"{ours:,}" if ours else f"failed: {kernel}"
            kernel_cell = f"{kernel:.4f}" if ours else "–"
            theirs_cell = (f"{theirs:,.0f}" + (f" ({why})" if why else "")) if theirs else why
            ratio = f"{ours / theirs:.2f}" if ours and theirs else "–"
            rows.append(f"| {label} | {envs:,} | {ours_cell} | {kernel_cell} | {theirs_cell} | "
                        f"{ratio} |")
            print(rows[-1], file=sys.stderr, flush=True)
    table = "\n".join(rows)
    print(table)
    if args.out:
        pathlib.Path(args.out).write_text(table + "\n")


if __name__ == "__main__":
    main()
