"""The peer benchmark runs every simulator at a tiny size and the runs do the same work.

``benchmarks/reference_vs_peers.py --quick`` runs the reference backend, NEST (through the
``pynn`` backend, 1 and 2 threads), Brian2's C++ standalone device (1 thread and 2 OpenMP
threads, compiled without optimisation) and the torch rate model on the three networks,
and exits 1 when the spike counts of a peer differ from the reference's by more than the
stated tolerance. Timings are not asserted (speed is a ratio in the benchmark, not a test).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("brian2")
pytest.importorskip("nest")
pytest.importorskip("torch")

ROOT = Path(__file__).resolve().parents[2]


def _quick(tmp_path: Path, *args: str) -> dict:
    out = tmp_path / "peers.json"
    png = tmp_path / "peers.png"
    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "reference_vs_peers.py"), "--quick",
         "--json", str(out), "--png", str(png), *args],
        capture_output=True, text=True, timeout=3600, cwd=ROOT,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert png.stat().st_size > 0
    results = json.loads(out.read_text())["networks"]
    for name, res in results.items():
        ref = res["runs"][0]
        assert ref["simulator"] == "reference" and sum(ref["spikes_of"].values()) > 0, name
        assert res["same_work"]["ok"], (name, res["same_work"])
        for r in res["runs"]:
            assert r["run_seconds"] > 0
            if r["simulator"] != "torch-rate":
                assert r["synaptic_events"] > 0, (name, r)
            if r["simulator"] == "brian2-cpp":  # Brian2 standalone runs the reference's arithmetic: the same spikes
                assert r["spikes_of"] == ref["spikes_of"], (name, r["threads"])
    return results


def test_quick_comparison_on_one_thread(tmp_path: Path) -> None:
    """Every kind of peer (NEST, Brian2 cpp_standalone, the torch rate model) at a tiny size, one thread."""
    results = _quick(tmp_path, "--networks", "stdp,locsnet", "--threads", "1")
    ran = {name: {(r["simulator"], r["threads"]) for r in res["runs"]} for name, res in results.items()}
    assert ran == {
        "stdp": {("reference", 1), ("nest", 1), ("brian2-cpp", 1)},
        "locsnet": {("reference", 1), ("nest", 1), ("torch-rate", 1)},
    }


@pytest.mark.slow
def test_quick_comparison_runs_every_peer_on_the_same_work(tmp_path: Path) -> None:
    """All three networks, peers on 1 and 2 threads (four Brian2 compilations)."""
    results = _quick(tmp_path)
    ran = {name: {(r["simulator"], r["threads"]) for r in res["runs"]} for name, res in results.items()}
    assert ran["dc"] == {("reference", 1), ("brian2-cpp", 1), ("brian2-cpp", 2)}
    assert ran["stdp"] == {("reference", 1), ("nest", 1), ("nest", 2), ("brian2-cpp", 1), ("brian2-cpp", 2)}
    assert ran["locsnet"] == {("reference", 1), ("nest", 1), ("nest", 2), ("torch-rate", 1), ("torch-rate", 2)}
    assert "nest" in results["dc"]["not_run"]
