"""The tour's off-chip vs on-chip part: a small trained LoCS-Net on the embedded route.

LoCS-Net is trained (torch, through its plugin) on the summer traverse of the
synthetic route, then its spiking network runs the late-autumn queries with
:func:`neurovpr.apps.compare.compare_model` on the reference backend (off-chip) and on
NengoLoihi's Loihi emulator and Lava's fixed-point models (on-chip); each row gets its
accuracy, the drop against the reference and its energy per inference on Kapoho Bay.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import numpy as np

from neurovpr import models
from neurovpr.apps.compare import compare_model
from neurovpr.apps.compare_plots import plot_comparison

__all__ = ["ONCHIP_BACKENDS", "query_subset", "train_locsnet", "run_onchip"]

#: Off-chip first (the reference of comparison), then the two emulated chips.
ONCHIP_BACKENDS = ("reference", "nengo-loihi", "lava-fixed")
_ON_CHIP = {"nengo-loihi": "Loihi 1 (NengoLoihi emulator)", "lava-fixed": "Loihi 2 (Lava fixed point)"}


def train_locsnet(data: Path, run: Path, *, epochs: int, seed: int) -> dict[str, Any]:
    """Train LoCS-Net (the paper's layer sizes, regular-rate input coding) on ``data`` into ``run``."""
    model = models.get("locsnet")
    return model.train(data=data, out=run, seed=seed, progress=False, epochs=epochs, input_coding="regular")


def _dynamic(energy: dict[str, Any] | None) -> float | None:
    """The activity-driven share of an energy estimate: every term of its breakdown but static power."""
    if not energy or energy.get("joules_per_inference") is None:
        return None
    return float(sum(v for k, v in energy.get("breakdown", {}).items() if "static" not in k))


def query_subset(data: Path, out: Path, queries: int) -> Path:
    """A copy of the generic-layout route ``data`` with ``queries`` evenly spaced queries (all references kept).

    The emulated chips cost seconds per query here, so the on-chip part runs a subset;
    ``ground_truth.csv`` keeps each kept query matched to its own place.
    """
    refs = sorted(p for p in (data / "reference").iterdir() if not p.name.startswith("."))
    qrys = sorted(p for p in (data / "query").iterdir() if not p.name.startswith("."))
    keep = np.unique(np.linspace(0, len(qrys) - 1, min(queries, len(qrys))).round().astype(int))
    (out / "reference").mkdir(parents=True)
    (out / "query").mkdir()
    for path in refs:
        shutil.copyfile(path, out / "reference" / path.name)
    for path in (qrys[i] for i in keep):
        shutil.copyfile(path, out / "query" / path.name)
    lines = ["query_index,reference_index", *(f"{q},{r}" for q, r in enumerate(keep))]
    (out / "ground_truth.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return out


def run_onchip(
    run: Path, data: Path, out: Path, *, hardware: str = "kapoho-bay", backends: tuple[str, ...] = ONCHIP_BACKENDS
) -> dict[str, Any]:
    """Compare the trained run off- and on-chip; rows with R@1, its drop, agreement and joules per inference."""
    comparison = compare_model(run, data, backends, hardware=hardware, progress=False)
    plot = plot_comparison(comparison, out / "onchip_comparison.png")
    rows, refused = [], {}
    reference_r1: float | None = None
    for row in comparison.rows:
        if not row.ran:
            refused[row.backend] = row.refused
            continue
        r1 = row.metrics.get("R@1")
        if reference_r1 is None:
            reference_r1 = r1
        rows.append(
            {
                "backend": row.backend,
                "where": _ON_CHIP.get(row.backend, "off-chip (CPU)"),
                "R@1": r1,
                "R@1_drop": None if r1 is None or reference_r1 is None else round(reference_r1 - r1, 6),
                "agreement": row.agreement,
                "seconds_per_query": row.seconds_per_query,
                "joules_per_inference": (row.energy or {}).get("joules_per_inference"),
                "dynamic_joules_per_inference": _dynamic(row.energy),
            }
        )
    return {"hardware": hardware, "rows": rows, "refused": refused, "notes": comparison.notes(), "plot": plot.name}
