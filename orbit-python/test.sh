#!/usr/bin/env bash
# Builds the Python package into a virtual environment and runs its tests (pytest). With
# ORBIT_REQUIRE_CLIENTS=1 (as CI runs) it also installs the learning libraries the adapter
# tests train with (RSL-RL, Stable-Baselines3, skrl, PyTorch) and a missing one fails them.
# The venv lives in the cargo target directory, so the Rust build cache and it go together.
set -euo pipefail
cd "$(dirname "$0")"
target="${CARGO_TARGET_DIR:-../target}"
venv="$target/python-venv"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
py="$venv/bin/python"
packages=(maturin "gymnasium>=1.0" "numpy>=1.24" pytest)
if [ "${ORBIT_REQUIRE_CLIENTS:-0}" = 1 ]; then
    packages+=("torch>=2.6" "rsl-rl-lib>=5" "tensordict>=0.7" "stable-baselines3>=2.4" "skrl>=2")
fi
"$py" -m pip install --quiet --disable-pip-version-check "${packages[@]}"
# Debug profile, as `cargo test` builds: the workspace's own build cache serves both.
VIRTUAL_ENV="$venv" "$venv/bin/maturin" develop --quiet --locked
"$py" -m pytest -q tests "$@"
