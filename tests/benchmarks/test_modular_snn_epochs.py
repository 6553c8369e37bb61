"""The Nordland benchmark's choice among several epoch counts (``--epochs 20,30,60``).

Member matrices are saved as the benchmark saves them, with made-up calibration Recall@1;
the choice must be the count whose best calibration Recall@1 is highest (ties to fewer
epochs), and matrices saved before the calibration was stored must be refused rather than
guessed at. No training here: the training and the calibration itself are tested in
``tests/models``.
"""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def _benchmark():
    spec = importlib.util.spec_from_file_location("modular_snn_nordland", ROOT / "benchmarks" / "modular_snn_nordland.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _save(bench, folder: Path, member: int, key: str, sim: np.ndarray, calibration: dict[float, float]) -> None:
    info = dict.fromkeys(bench._TIMING_KEYS, 1.0)
    anatomy = {"assigned": np.ones(2), "kept": np.ones(2), "kept_activity": np.ones(2)}
    extra = {"places": np.arange(2), "queries": np.arange(2), "threshold": 20.0, "anatomy": anatomy, "calibration": calibration}
    bench._save_member(folder, member, sim, key, info, extra)


def test_each_member_takes_the_epochs_its_calibration_chooses(tmp_path: Path) -> None:
    bench = _benchmark()
    keys = {20: "k20", 30: "k30", 60: "k60"}
    recall = {  # member -> epochs -> calibration Recall@1 per threshold
        0: {20: {0.0: 0.19, 60.0: 0.40}, 30: {20.0: 0.48}, 60: {100.0: 0.32}},
        1: {20: {40.0: 0.50}, 30: {20.0: 0.50}, 60: {100.0: 0.20}},
    }
    for member, by_epochs in recall.items():
        for epochs, cal in by_epochs.items():
            sim = np.full((2, 2), float(epochs)) + member
            _save(bench, tmp_path / f"epochs{epochs}" / "similarity", member, keys[epochs], sim, cal)
    args = argparse.Namespace(epochs=[20, 30, 60], out=tmp_path)
    sim, meta = bench._choose_epochs(args, keys, 0)
    assert meta["epochs"] == 30 and np.all(sim == 30.0)
    assert meta["calibration_by_epochs"] == {str(e): c for e, c in recall[0].items()}
    sim, meta = bench._choose_epochs(args, keys, 1)
    assert meta["epochs"] == 20 and np.all(sim == 21.0)  # a tie goes to fewer epochs
    # one count: the single folder layout, the calibration reported under its count
    single = argparse.Namespace(epochs=[30], out=tmp_path / "epochs30")
    sim, meta = bench._choose_epochs(single, keys, 0)
    assert meta["epochs"] == 30 and meta["calibration_by_epochs"] == {"30": {20.0: 0.48}}


def test_matrices_without_their_calibration_are_refused(tmp_path: Path) -> None:
    bench = _benchmark()
    keys = {20: "k20", 30: "k30"}
    _save(bench, tmp_path / "epochs20" / "similarity", 0, "k20", np.zeros((2, 2)), {0.0: 0.3})
    folder = tmp_path / "epochs30" / "similarity"
    _save(bench, folder, 0, "k30", np.zeros((2, 2)), {0.0: 0.4})
    with np.load(folder / "m00.npz") as f:  # as saved before the calibration was stored
        old = {k: f[k] for k in f.files if not k.startswith("calibration_")}
    np.savez_compressed(folder / "m00.npz", **old)
    args = argparse.Namespace(epochs=[20, 30], out=tmp_path)
    with pytest.raises(SystemExit, match="at 30 epochs was saved without its calibration"):
        bench._choose_epochs(args, keys, 0)
    # a single count still reads it (the README's older runs)
    sim, meta = bench._choose_epochs(argparse.Namespace(epochs=[30], out=tmp_path / "epochs30"), keys, 0)
    assert meta["calibration_by_epochs"] == {} and sim.shape == (2, 2)
    with pytest.raises(SystemExit, match="other data, settings or seed"):
        bench._choose_epochs(args, {20: "k20", 30: "another"}, 0)


def test_epochs_option_reads_one_count_or_several() -> None:
    bench = _benchmark()
    assert bench._counts("30") == [30]
    assert bench._counts("60,20,30,20") == [20, 30, 60]
    for bad in ("0", "20,x", ""):
        with pytest.raises(argparse.ArgumentTypeError):
            bench._counts(bad)
