"""Shared paths: the repository, FL_THERMAL and the CLI binary to compare with."""

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

# CI sees the real run at ../shared/data/fl_thermal/run.csv from the repository root.
FL_THERMAL = Path(
    os.environ.get("THERMCOMP_FL_THERMAL", ROOT / ".." / "shared" / "data" / "fl_thermal" / "run.csv")
).resolve()

# The release CLI of this tree (cargo build --release -p host-tools): the
# figures are compared with what it prints.
CLI = Path(os.environ.get("THERMCOMP_BIN", ROOT / "target" / "release" / "thermcomp"))


@pytest.fixture(scope="session")
def fl_thermal() -> Path:
    assert FL_THERMAL.exists(), f"{FL_THERMAL}: the FL_THERMAL run is missing (set THERMCOMP_FL_THERMAL)"
    return FL_THERMAL


@pytest.fixture(scope="session")
def cli():
    """Runs the CLI; returns (exit status, stdout, stderr)."""
    assert CLI.exists(), f"{CLI}: build it first (cargo build --release -p host-tools) or set THERMCOMP_BIN"

    def run(*args: str, cwd=ROOT):
        p = subprocess.run([str(CLI), *args], capture_output=True, text=True, cwd=cwd)
        return p.returncode, p.stdout, p.stderr

    return run
