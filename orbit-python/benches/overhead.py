"""Env-steps/s of a task stepped from Python against the same env stepped from Rust.

Python builds the task with the given seed, backend and env count, resets it, and times
``--steps`` steps with zero actions in one of three loops:

- ``native``: ``NativeEnv.step`` alone (the call into Rust and the new reward and flag
  arrays, no observations);
- ``native + obs``: the same plus ``NativeEnv.observations()``, the least a learner reads;
- ``gymnasium``: ``OrbitVectorEnv.step``, which also builds the infos (final observations
  of the finished envs, the episode log).

Each loop runs on an env built afresh, so that all cover the same steps of the same
episodes. Its overhead is its wall time over the time the same steps spent inside the Rust
env (``NativeEnv.step_seconds``), minus one: Python's share, measured in one process on
the same steps. For reference, the ``zero_agent`` example (a release build) steps the same
task in a Rust program; its rate varies from process to process by more than Python's
share, so it is shown, not subtracted. Runs alternate (Rust, then the three Python loops)
``--repeats`` times; the table gives medians.

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

LOOPS = ("native", "native + obs", "gymnasium")


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


def python_loop(args: argparse.Namespace, loop: str) -> tuple[float, float]:
    """Builds the env from Python and times one loop: its env-steps/s and Python's share
    (wall time over the time inside the Rust env, minus one)."""
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
    inside = native.step_seconds
    start = time.perf_counter()
    for _ in range(args.steps):
        step()
    wall = time.perf_counter() - start
    inside = native.step_seconds - inside
    env.close()
    return args.steps * args.num_envs / wall, wall / inside - 1.0


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
    rates: dict[str, list[float]] = {loop: [] for loop in LOOPS}
    shares: dict[str, list[float]] = {loop: [] for loop in LOOPS}
    for _ in range(args.repeats):
        rust.append(rust_steps_per_s(args))
        for loop in LOOPS:
            rate, share = python_loop(args, loop)
            rates[loop].append(rate)
            shares[loop].append(share)

    print(
        f"{args.task}, {args.backend}, {args.num_envs} envs, {args.steps} steps with zero "
        f"actions, median of {args.repeats}"
    )
    print(f"{'loop':<14} {'env-steps/s':>12} {'Python share':>13}")
    print(f"{'zero_agent':<14} {statistics.median(rust):>12.0f}")
    for loop in LOOPS:
        rate = statistics.median(rates[loop])
        share = 100.0 * statistics.median(shares[loop])
        print(f"{loop:<14} {rate:>12.0f} {share:>12.2f}%")


if __name__ == "__main__":
    main()
