"""The tour's Modular SNN part: the faithful model, trained on the embedded route, next to SAD.

The Modular SNN (defaults following the authors' code) trains through its plugin on the
summer traverse, with the reference backend in local worker processes, and is
evaluated on the late-autumn queries with and without sequence matching; SAD runs on
the same images. Its distance matrix and PR curve are the model's own plots.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

from neurovpr import models

__all__ = ["run_modular"]


def run_modular(
    data: Path, run: Path, out: Path, *, members: int, epochs: int, module_size: int, neurons: int, seq_len: int,
    seed: int, workers: int | None,
) -> dict[str, Any]:
    """Train and evaluate; rows of R@1 at L = 1 and L = ``seq_len`` (one module set, the ensemble, SAD) and plots."""
    model = models.get("modular")
    trained = model.train(
        data=data, out=run, seed=seed, progress=True,
        members=members, epochs=epochs, module_size=module_size, neurons=neurons, workers=workers,
    )  # fmt: skip
    results = {n: model.evaluate(run=run, seq_len=n, progress=False) for n in (1, seq_len)}
    rows: dict[str, dict[str, float]] = {"Modular SNN": {}, "SAD": {}}
    if members > 1:
        rows[f"Ensemble of {members}"] = {}
    for n, res in results.items():
        key = f"L={n}"
        rows["Modular SNN"][key] = res["modular_snn"]["R@1"]
        rows["SAD"][key] = res["baselines"]["SAD"]["R@1"]
        if members > 1:
            rows[f"Ensemble of {members}"][key] = res["metrics"]["R@1"]
    files = results[1]["files"]
    figures = {}
    for key in ("distance_matrix", "pr_curve"):
        if key in files and Path(files[key]).is_file():
            target = out / f"modular_{key}.png"
            shutil.copyfile(files[key], target)
            figures[key] = target.name
    return {
        "plan": trained.get("plan"),
        "members": members,
        "epochs": epochs,
        "module_size": module_size,
        "seq_lens": [1, seq_len],
        "R@1": rows,
        "train_seconds_per_module": trained.get("train_seconds_per_module"),
        "plots": figures,
    }
