"""Shared helpers of the Python tests: where the repository is, and how
to run its Rust programs (the checksum example, the `crumble` command)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
# checksum_scenes.py sits beside the tests.
sys.path.insert(0, str(Path(__file__).resolve().parent))


def cargo(*args: str) -> str:
    """Runs `cargo ARGS` in the repository and returns its standard output;
    fails the test with cargo's standard error when it fails."""
    exe = shutil.which("cargo")
    if exe is None:
        pytest.fail("cargo is not on the PATH: the tests compare with the Rust programs of the repository")
    run = subprocess.run([exe, *args], cwd=REPO, capture_output=True, text=True)
    if run.returncode != 0:
        pytest.fail(f"cargo {' '.join(args)} failed:\n{run.stderr}")
    return run.stdout


@pytest.fixture(scope="session")
def crumble_cli() -> Path:
    """The `crumble` command built in the test profile (optimised; `cargo
    test --workspace` builds it). Missing, the tests that use it skip,
    except when CI is set: then it is built here, so that a green CI run
    means that every test ran."""
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    exe = target / "debug" / "crumble"
    if not exe.exists():
        if not os.environ.get("CI"):
            pytest.skip(f"{exe} is not built (cargo build --profile test -p crumble-cli; CI builds it)")
        cargo("build", "-q", "--profile", "test", "-p", "crumble-cli")
    return exe
