#!/usr/bin/env bash
# Builds the Python package (crates/crumble-py, `crumble-physics`, imported
# as `crumble`) into a virtual environment and runs its tests
# (crates/crumble-py/tests, docs/python.md).
#
# Needs only Rust (cargo) and Python 3 (3.9 or later, with venv); pip
# fetches maturin, numpy, pytest and Dask (the sweep test runs a local cluster). The environment is
# $CARGO_TARGET_DIR/py-venv (default target/py-venv) and the extension is
# built by maturin in the release profile into $CARGO_TARGET_DIR, so that a
# second run, or a run after the workspace's own builds, recompiles little.
# The tests run the checksum example (`cargo run --profile test`) and,
# when it is built (`cargo test --workspace` builds it; with CI set they
# build it), the `crumble` command of the test profile: after CI's cargo
# steps, both are built already.
#
# PYTHON picks the interpreter (default python3).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$root/target}"
python="${PYTHON:-python3}"
venv="$CARGO_TARGET_DIR/py-venv"

echo "== Python package: virtual environment $venv"
[ -x "$venv/bin/python" ] || "$python" -m venv "$venv"
"$venv/bin/python" -m pip install -q --disable-pip-version-check maturin numpy pytest "dask[distributed]"
# maturin's build hook runs the `maturin` on the PATH.
export PATH="$venv/bin:$PATH"

echo "== Python package: pip install ./crates/crumble-py"
# Without build isolation the maturin just installed builds the wheel
# (isolation would fetch another copy every run).
"$venv/bin/python" -m pip install -q --disable-pip-version-check --no-build-isolation \
    --force-reinstall --no-deps ./crates/crumble-py

echo "== Python package: pytest"
# From the repository's root, so that `import crumble` finds the installed
# package, not crates/crumble-py/python/ (which lacks the native module).
"$venv/bin/python" -m pytest crates/crumble-py/tests -q
