"""Env-steps/s of a task stepped from Python against the same env stepped from Rust.

Both sides build the task with the same seed, backend and env count, reset it, and time
``--steps`` steps with zero actions; the Rust side is the ``zero_agent`` example (release
build), which times only its ``env.step`` calls. The Python side times three loops, each on
an env built afresh, so that every loop covers the same steps of the same episodes:

- ``native``: ``NativeEnv.step`` alone (the call into Rust and the new reward and flag
  arrays, no observations);
- ``native + obs``: the same plus ``NativeEnv.observations()``, the least a learner reads;
- ``gymnasium``: ``OrbitVectorEnv.step``, which also builds the infos (final observations
  of the finished envs, the episode log).

Runs alternate (Rust, then Python) ``--repeats`` times; the table gives the median of each.

```sh
cargo build --release --example zero_agent
pip install ./orbit-python
python orbit-python/benches/overhead.py --zero-agent target/release/examples/zero_agent \\
    --task Isaac-Cartpole-v0 --backend rapier --num-envs 4096 --steps 500
```
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import time

import numpy as np

import orbit_rs


def rust_steps_per_s(args: argparse.Namespace) -> float:
    """Runs the Rust agent script once and reads its env-steps/s."""
    cmd = [
        args.zero_agent,
        "--task",
        args.task,
        "--num-envs",
        str(args.num_envs),
        "--backend",
        args.backend,
        "--seed",
        str(args.seed),
        "--steps",
        str(args.steps),
    ]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    found = re.search(r"\(([0-9.]+) env-steps/s\)", out)
    if found is None:
        raise RuntimeError(f"no env-steps/s in the output of {' '.join(cmd)}:\n{out}")
    return float(found.group(1))


def timed(step, steps: int, num_envs: int) -> float:
    """Env-steps/s of ``steps`` calls of ``step``."""
    start = time.perf_counter()
    for _ in range(steps):
        step()
    return steps * num_envs / (time.perf_counter() - start)


def python_steps_per_s(args: argparse.Namespace, loop: str) -> float:
    """Builds the env from Python, as the Rust side does, and times one loop over the same
    steps of the episodes."""
    env = orbit_rs.make(
        args.task, num_envs=args.num_envs, backend=args.backend, seed=args.seed
    )
    env.reset()
    zeros = np.zeros((env.num_envs, env.native.num_actions), dtype=np.float32)
    native = env.native

    def native_and_obs() -> None:
        native.step(zeros)
        native.observations()

    step = {
        "native": lambda: native.step(zeros),
        "native + obs": native_and_obs,
        "gymnasium": lambda: env.step(zeros),
    }[loop]
    result = timed(step, args.steps, args.num_envs)
    env.close()
    return result


LOOPS = ("native", "native + obs", "gymnasium")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--zero-agent", required=True, help="the release zero_agent binary")
    parser.add_argument("--task", default="Isaac-Cartpole-v0")
    parser.add_argument("--backend", default="rapier")
    parser.add_argument("--num-envs", type=int, default=4096)
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    rust: list[float] = []
    python: dict[str, list[float]] = {}
    for _ in range(args.repeats):
        rust.append(rust_steps_per_s(args))
        for loop in LOOPS:
            python.setdefault(loop, []).append(python_steps_per_s(args, loop))

    reference = statistics.median(rust)
    print(
        f"{args.task}, {args.backend}, {args.num_envs} envs, {args.steps} steps with zero "
        f"actions, median of {args.repeats}"
    )
    print(f"{'loop':<14} {'env-steps/s':>12} {'overhead':>9}")
    print(f"{'rust':<14} {reference:>12.0f} {'':>9}")
    for name, values in python.items():
        median = statistics.median(values)
        overhead = 100.0 * (reference / median - 1.0)
        print(f"{name:<14} {median:>12.0f} {overhead:>8.1f}%")


if __name__ == "__main__":
    main()
