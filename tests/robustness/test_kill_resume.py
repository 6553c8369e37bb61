"""Training killed (SIGKILL) at random points, then resumed, equals the uninterrupted run bit for bit; no temporary file stays."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from neurovpr.fileio import is_temp_name

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "models"))
from modular_tiny import synthetic_dataset

_OPTIONS = ["--model", "modular", "--neurons", "10", "--epochs", "1", "--module-size", "2", "--places", "6",
            "--workers", "1", "--seed", "3", "--no-progress"]  # fmt: skip


def _train(data: Path, out: Path, *extra: str) -> subprocess.Popen[bytes]:
    cmd = [sys.executable, "-m", "neurovpr.cli.main", "train", "--data", str(data), "--out", str(out), *_OPTIONS, *extra]
    return subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)


def _networks(run: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((run / "modules").glob("*.h5"))}


@pytest.mark.slow
def test_killed_training_resumes_to_the_same_result(tmp_path: Path) -> None:
    data = synthetic_dataset(tmp_path, 6)
    full = _train(data, tmp_path / "full")
    assert full.wait(timeout=600) == 0, full.stderr.read().decode() if full.stderr else ""
    expected = _networks(tmp_path / "full")
    assert len(expected) == 3
    for seed in range(3):
        out = tmp_path / f"killed{seed}"
        delay = float(np.random.default_rng(seed).uniform(3.0, 20.0))
        proc = _train(data, out)
        time.sleep(delay)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=60)
        resumed = _train(data, out, "--resume") if out.exists() else _train(data, out)
        assert resumed.wait(timeout=600) == 0, resumed.stderr.read().decode() if resumed.stderr else ""
        assert _networks(out) == expected, f"seed {seed} (killed after {delay:.1f} s)"
        assert not [p for p in out.rglob("*") if is_temp_name(p.name) or p.suffix == ".tmp"], f"seed {seed}"
