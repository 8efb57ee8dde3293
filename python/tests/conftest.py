"""Shared fixtures: the repository, the `mtwin` binary to compare with."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
MACHINES = REPO / "examples" / "machines"


def _binary() -> str:
    b = os.environ.get("MTWIN_BIN")
    if b:
        return b
    for cand in (REPO / "target" / "debug" / "mtwin", REPO / "target" / "release" / "mtwin"):
        if cand.exists():
            return str(cand)
    found = shutil.which("mtwin")
    if found:
        return found
    raise RuntimeError("no mtwin binary: set MTWIN_BIN (cargo test does)")


class Cli:
    """Runs the `mtwin` binary of this build."""

    def __init__(self, binary: str) -> None:
        self.binary = binary

    def run(self, *args: str, cwd: Path) -> subprocess.CompletedProcess:
        p = subprocess.run(
            [self.binary, *args], cwd=cwd, capture_output=True, text=True
        )
        assert p.returncode == 0, f"mtwin {' '.join(args)}: {p.stderr}"
        return p

    def json(self, *args: str, cwd: Path) -> dict:
        return json.loads(self.run(*args, "--format", "json", cwd=cwd).stdout)


@pytest.fixture(scope="session")
def cli() -> Cli:
    return Cli(_binary())


def write_csv(path: Path, header, rows) -> None:
    """A CSV with shortest round-trip floats (Python's repr), read back exactly by mtwin."""
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        for r in rows:
            f.write(",".join(repr(float(v)) for v in r) + "\n")


def read_csv(path: Path):
    import numpy as np

    with open(path) as f:
        header = f.readline().strip().split(",")
        rows = [[float(v) for v in line.strip().split(",")] for line in f if line.strip()]
    return header, np.array(rows, dtype=np.float64)


# The Spark fleet tests need pyspark (and Java), which the `cargo test` harness does
# not install (a 300 MB download); they run wherever pyspark is installed (`cargo
# test` runs them in their own pytest process when target/py-venv has it), and
# `.ci/run` installs it and sets MTWIN_REQUIRE_SPARK=1, where a missing pyspark fails.
try:
    import pyspark  # noqa: F401
except ImportError:
    if os.environ.get("MTWIN_REQUIRE_SPARK") == "1":
        raise RuntimeError("MTWIN_REQUIRE_SPARK=1 but pyspark is not installed (pip install pyspark 'pandas<3')")
    collect_ignore = ["test_spark.py"]
