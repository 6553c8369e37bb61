"""The result of ``neurovpr compare``: one row per backend, the comparison, its table and JSON.

:func:`neurovpr.apps.compare.compare_model` builds these; this module holds what they
contain and how they are shown (``compare --json`` and the text table).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["BackendComparison", "Comparison", "PRIMARY_METRICS"]

#: Metrics shown in the table and the plot when the model reports them, in this order.
PRIMARY_METRICS = ("R@1", "P@100R", "AUC_PR", "AUC_ROC")


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class BackendComparison:
    """The result of one backend: a row of the comparison.

    Exactly one of ``refused`` (the sentence why it did not run) or the measured fields
    (``metrics``, ``seconds_per_query``, ...) is set. ``predictions`` and
    ``output_counts`` are kept for the caller but not written to JSON.
    """

    backend: str
    refused: str | None = None
    metrics: dict[str, float | None] = field(default_factory=dict)
    agreement: float | None = None
    spike_count_correlation: float | None = None
    seconds_per_query: float | None = None
    energy: dict[str, Any] | None = None
    neurobench: dict[str, Any] | None = None
    deployed_from: str | None = None
    notes: tuple[str, ...] = ()
    predictions: np.ndarray | None = None
    output_counts: np.ndarray | None = None

    @property
    def ran(self) -> bool:
        """True when the backend ran the model."""
        return self.refused is None

    def as_dict(self) -> dict[str, Any]:
        """The JSON object of this backend in ``compare --json``."""
        if not self.ran:
            return {"refused": self.refused}
        out: dict[str, Any] = {
            "metrics": dict(self.metrics),
            "agreement": self.agreement,
            "spike_count_correlation": self.spike_count_correlation,
            "seconds_per_query": self.seconds_per_query,
        }
        if self.energy is not None:
            out["energy"] = dict(self.energy)
        if self.neurobench is not None:
            out["neurobench"] = dict(self.neurobench)
        if self.deployed_from is not None:
            out["deployed_from"] = self.deployed_from
        if self.notes:
            out["notes"] = list(self.notes)
        return out


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Comparison:
    """A model compared across backends (see the module docstring)."""

    model: str
    run: str
    data: str | None
    trained_on: str | None
    hardware: str | None
    rows: tuple[BackendComparison, ...]
    #: The fit of the run's network on ``hardware`` (``fits``, ``dt_ms``, ``chips``, ``cores``, ``violations``):
    #: the one partition every row's energy estimate uses; ``None`` without a hwspec or a network file.
    hardware_fit: dict[str, Any] | None = None

    @property
    def reference_backend(self) -> str | None:
        """The first backend that ran: what agreement and correlation are measured against."""
        return next((r.backend for r in self.rows if r.ran), None)

    @property
    def any_ran(self) -> bool:
        """True when at least one backend ran the model."""
        return any(r.ran for r in self.rows)

    def notes(self) -> list[str]:
        """Sentences on deployment and on the reference of comparison."""
        out = []
        deployed: dict[str, list[str]] = {}
        for row in self.rows:
            if row.ran and row.deployed_from is not None:
                deployed.setdefault(row.deployed_from, []).append(row.backend)
        for source, targets in deployed.items():
            out.append(f"trained on {source}, deployed to {', '.join(targets)} (the run's learned weights, plasticity off)")
        for row in self.rows:
            for note in row.notes if row.ran else ():
                line = f"{row.backend}: {note}"
                if line not in out:
                    out.append(line)
        ref = self.reference_backend
        if ref is not None:
            out.append(f"agreement and spike-count correlation are measured against {ref}")
        fit = self.hardware_fit
        if fit is not None:
            verdict = "fits" if fit["fits"] else f"does NOT fit ({fit['violations']} limits broken)"
            out.append(
                f"the network {verdict} {self.hardware} at dt {fit['dt_ms']:g} ms: {fit['chips']} chip(s), {fit['cores']} "
                "cores, the partition of every energy figure but those a row's note names"
            )
        return out

    def shown_metrics(self) -> list[str]:
        """The metric names the table and plot show."""
        names = {k for r in self.rows for k in r.metrics}
        shown = [m for m in PRIMARY_METRICS if m in names]
        if shown:
            return shown
        first = next((r.metrics for r in self.rows if r.metrics), {})
        return list(first)[:3]

    def as_dict(self) -> dict[str, Any]:
        """The JSON object ``neurovpr compare --json`` prints."""
        return {
            "model": self.model,
            "run": self.run,
            "data": self.data,
            "trained_on": self.trained_on,
            "hardware": self.hardware,
            "hardware_fit": None if self.hardware_fit is None else dict(self.hardware_fit),
            "reference_backend": self.reference_backend,
            "backends": {r.backend: r.as_dict() for r in self.rows},
            "notes": self.notes(),
        }

    def table(self) -> str:
        """A fixed-width table, one line per backend, then refusals and notes."""
        metrics = self.shown_metrics()
        head = ["backend", *metrics, "agreement", "r(counts)", "s/query"]
        if self.hardware is not None:
            head.append(f"J/inf {self.hardware}")
        lines = []
        for row in self.rows:
            if not row.ran:
                lines.append([row.backend, *(["refused"] + [""] * (len(head) - 2))])
                continue
            cells = [row.backend, *(_fmt(row.metrics.get(m)) for m in metrics)]
            cells += [_fmt(row.agreement), _fmt(row.spike_count_correlation), _fmt(row.seconds_per_query, ".4g")]
            if self.hardware is not None:
                joules = (row.energy or {}).get("joules_per_inference")
                cells.append(_fmt(joules, ".4g"))
            lines.append(cells)
        widths = [max(len(str(c[i])) for c in [head, *lines]) for i in range(len(head))]
        text = ["  ".join(str(c).ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in [head, *lines]]
        text.insert(1, "  ".join("-" * w for w in widths))
        for row in self.rows:
            if not row.ran:
                text.append(f"{row.backend}: refused: {row.refused}")
            elif row.energy is not None and row.energy.get("joules_per_inference") is None:
                text.append(f"{row.backend}: energy not estimated: {row.energy.get('reason')}")
        text += [f"note: {n}" for n in self.notes()]
        return "\n".join(text)


def _fmt(value: float | None, spec: str = ".3f") -> str:
    return "-" if value is None else format(value, spec)
