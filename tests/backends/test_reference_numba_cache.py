"""numba's cache of the reference kernels works across processes: a second process compiles nothing.

``benchmarks/numba_cold_start.py --child`` compiles and runs a small network on the reference
backend in a fresh process and prints numba's cache hits and misses of every kernel it
called. Run twice with one ``NUMBA_CACHE_DIR``, the second process must load every kernel
from the cache the first one wrote (hits, no misses) and give the same spikes.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("numba")

ROOT = Path(__file__).resolve().parents[2]


def _child(cache: Path | None) -> dict:
    """One fresh process; ``cache=None``: numba's default location (next to the kernels' source)."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "numba_cold_start.py"), "--child"],
        env=env, capture_output=True, text=True, check=True, timeout=900,
    )  # fmt: skip
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_second_process_loads_every_kernel_from_a_fresh_cache(tmp_path: Path) -> None:
    cold = _child(tmp_path)
    assert sum(cold["cache_misses"].values()) > 0  # an empty cache: compiled
    assert any(p.suffix == ".nbc" for p in tmp_path.rglob("*")) and any(p.suffix == ".nbi" for p in tmp_path.rglob("*"))
    warm = _child(tmp_path)
    assert "run_steps" in warm["cache_hits"]
    assert sum(warm["cache_misses"].values()) == 0, warm["cache_misses"]
    assert all(n > 0 for n in warm["cache_hits"].values()), warm["cache_hits"]
    assert warm["spikes"] == cold["spikes"] > 0


def test_second_process_compiles_nothing() -> None:
    """Where users and the CLI run it: numba's default cache location, or the caller's NUMBA_CACHE_DIR."""
    cache = Path(os.environ["NUMBA_CACHE_DIR"]) if os.environ.get("NUMBA_CACHE_DIR") else None
    first = _child(cache)
    second = _child(cache)
    assert sum(second["cache_misses"].values()) == 0, second["cache_misses"]
    assert second["cache_hits"].get("run_steps", 0) > 0
    assert second["spikes"] == first["spikes"] > 0
