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


def test_quick_comparison_runs_every_peer_on_the_same_work(tmp_path: Path) -> None:
    out = tmp_path / "peers.json"
    png = tmp_path / "peers.png"
    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "reference_vs_peers.py"), "--quick", "--json", str(out), "--png", str(png)],
        capture_output=True, text=True, timeout=1800, cwd=ROOT,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    results = json.loads(out.read_text())["networks"]
    assert png.stat().st_size > 0
    ran = {name: {(r["simulator"], r["threads"]) for r in res["runs"]} for name, res in results.items()}
    assert ran["dc"] == {("reference", 1), ("brian2-cpp", 1), ("brian2-cpp", 2)}
    assert ran["stdp"] == {("reference", 1), ("nest", 1), ("nest", 2), ("brian2-cpp", 1), ("brian2-cpp", 2)}
    assert ran["locsnet"] == {("reference", 1), ("nest", 1), ("nest", 2), ("torch-rate", 1), ("torch-rate", 2)}
    assert "nest" in results["dc"]["not_run"]
    for name, res in results.items():
        ref = res["runs"][0]
        assert ref["simulator"] == "reference" and sum(ref["spikes_of"].values()) > 0, name
        assert res["same_work"]["ok"], (name, res["same_work"])
        for r in res["runs"]:
            assert r["run_seconds"] > 0
            if r["simulator"] != "torch-rate":
                assert r["synaptic_events"] > 0, (name, r)
    # Brian2's standalone device runs the reference's arithmetic: the same spikes, to the spike
    for r in results["dc"]["runs"] + results["stdp"]["runs"]:
        if r["simulator"] == "brian2-cpp":
            assert r["spikes_of"] == results["dc" if r in results["dc"]["runs"] else "stdp"]["runs"][0]["spikes_of"]
