"""Cold and warm start of the reference backend: numba's compilation against its cache.

The reference backend's kernels are compiled by numba on their first call and cached
(``@njit(cache=True)``) next to their source, in ``backends/reference/__pycache__``
(numba falls back to a per-user cache folder when that folder is not writable, and
``NUMBA_CACHE_DIR`` overrides both). A second process loads the machine code from
the cache instead of compiling it again.

This script runs, in fresh processes, (1) the first simulation of a small network
(``--child``: compile and run it, then print numba's cache hits and misses of every
reference kernel) and (2) the demo tour at its tiny size (``neurovpr demo --size tiny``:
every backend, fit checks, LoCS-Net and Modular SNN training and evaluation), each twice
with ``NUMBA_CACHE_DIR`` pointing at one new empty folder: the first run is cold (every
kernel compiled and written to the cache), the second warm (every kernel read back). The
printed ratio is cold / warm wall time in the same run.

Usage (from the repository root)::

    python benchmarks/numba_cold_start.py [--demo-args "--size tiny --workers 1"] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

DEMO_ARGS = "--size tiny --workers 1"


def child() -> None:
    """Compile and run a small network on the reference backend; print timings and numba's cache statistics."""
    t0 = time.perf_counter()
    import numpy as np

    import neurovpr as nv
    from neurovpr.backends.reference import kernels

    t_import = time.perf_counter() - t0
    net = nv.Network("cold_start")
    net.add_population("src", 20, nv.SpikeSourcePoisson(rate=50.0))
    net.add_population("exc", 10, nv.IF_cond_exp())
    net.add_population("inh", 10, nv.IF_curr_exp())
    stdp = nv.STDPMechanism(weight=0.05, delay=1.0)
    net.connect("src", "exc", nv.AllToAllConnector(), stdp)
    net.connect("src", "inh", nv.AllToAllConnector(), nv.StaticSynapse(weight=np.full((20, 10), 2.0), delay=1.0))
    net.connect("inh", "exc", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.01), receptor_type="inhibitory")
    t1 = time.perf_counter()
    sim = nv.compile(net, backend="reference", dt=0.1, seed=1)
    sim.run(100.0)
    t_first = time.perf_counter() - t1
    hits, misses = {}, {}
    for module in [m for name, m in sys.modules.items() if name.startswith(kernels.__package__ + ".")]:
        for name, fn in vars(module).items():
            stats = getattr(fn, "stats", None)
            if stats is not None and getattr(fn, "signatures", None):  # a numba dispatcher this process called
                hits[name] = sum(stats.cache_hits.values())
                misses[name] = sum(stats.cache_misses.values())
    print(json.dumps({"import_seconds": t_import, "first_run_seconds": t_first, "cache_hits": hits,
                      "cache_misses": misses, "spikes": int(sim.spike_counts("exc").sum())}))  # fmt: skip


def _timed(cmd: list[str], env: dict[str, str]) -> tuple[float, str]:
    t0 = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    return time.perf_counter() - t0, done.stdout


def cache_files(folder: Path) -> int:
    """Number of numba cache files (index ``.nbi`` and data ``.nbc``) under ``folder``."""
    return sum(1 for p in folder.rglob("*") if p.suffix in (".nbi", ".nbc"))


def measure(demo_args: str) -> dict[str, Any]:
    """Cold then warm, for the first simulation and for a small demo, each in its own empty cache folder."""
    python = sys.executable
    cli = [python, "-m", "neurovpr.cli.main"]
    results: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="neurovpr-numba-") as tmp:
        for case, cmd in (
            ("first simulation", [python, __file__, "--child"]),
            ("neurovpr demo " + demo_args, [*cli, "demo", *shlex.split(demo_args), "--out", str(Path(tmp) / "demo")]),
        ):
            cache = Path(tmp) / f"cache-{len(results)}"
            cache.mkdir()
            env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
            cold, out_cold = _timed(cmd, env)
            files = cache_files(cache)
            warm, out_warm = _timed(cmd, env)
            row: dict[str, Any] = {"cold_seconds": cold, "warm_seconds": warm, "ratio": cold / warm, "cache_files": files}
            if case == "first simulation":
                row["cold"], row["warm"] = json.loads(out_cold), json.loads(out_warm)
            results[case] = row
            print(f"{case:60s} cold {cold:7.2f} s  warm {warm:7.2f} s  cold/warm {cold / warm:5.1f}  ({files} cache files)",
                  flush=True)  # fmt: skip
    return results


def main(argv: list[str] | None = None) -> int:
    """Measure (or, with ``--child``, be the measured process)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--demo-args", default=DEMO_ARGS)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    if args.child:
        child()
        return 0
    results = measure(args.demo_args)
    if args.json:
        tmp = args.json.with_suffix(".tmp")
        tmp.write_text(json.dumps(results, indent=2))
        tmp.replace(args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
