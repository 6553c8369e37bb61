"""The tour's fit checks: what fits which chip, and for what does not, why and what would make it fit.

Every verdict comes from :func:`neurovpr.hardware.check_network`, the partition
``neurovpr check`` reports; :func:`remedy` turns each broken limit into the change that
would remove it (more chips, fewer neurons per core for the offending population, a
neuron model the chip hosts), computed from the violation's own numbers.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import neurovpr as nv
from neurovpr.hardware import check_network
from neurovpr.hardware.check import CheckReport
from neurovpr.hardware.plots import plot_utilisation

__all__ = ["remedy", "fit_check"]

#: Per-core resources: a core holding fewer neurons of the population uses less of them.
_PER_CORE = {
    "output axons per core": "output axons",
    "input axons per core": "input axons",
    "synapse memory bits per core": "synapse memory",
    "neurons per core": "neurons",
}


def _population(where: str) -> str:
    return where.split("[", 1)[0]


def remedy(violation: dict[str, Any], report: CheckReport) -> str:
    """One sentence: what would remove this broken limit (from the violation's value and maximum)."""
    limit, where = violation["limit"], violation["where"]
    value, maximum = float(violation["value"]), float(violation["maximum"])
    population = _population(where)
    if limit in _PER_CORE:
        share = max(2, math.ceil(value / maximum)) if maximum > 0 else 2
        return (
            f"split {population!r} over about {share} times as many cores (each core holding 1/{share} of the "
            f"neurons of block {where}), or lower its fan-out, so its {_PER_CORE[limit]} stay within {maximum:g} per core"
        )
    if limit == "neuron model":
        hosted = ", ".join(report.spec.features.neuron_models)
        return f"declare {population!r} with a neuron model the chip hosts ({hosted}), or run it on the host"
    if limit == "plasticity rule":
        return f"train {where!r} off-chip and deploy its learned weights as static synapses"
    if limit in ("chips", "cores"):
        return f"a board with at least {value:g} {limit} (this one has {maximum:g}), or split the network over boards"
    return f"bring {where} from {value:g} down to {maximum:g}"


def fit_check(network: nv.Network, hardware: str, out: Path, *, dt: float, label: str) -> dict[str, Any]:
    """Check ``network`` on ``hardware`` at step ``dt``; the verdict, the broken limits with remedies, and a PNG.

    The utilisation plot (one bar per core and resource) is written to
    ``out/utilisation_<label>.png``.
    """
    report = check_network(network, hardware, dt=dt)
    d = report.as_dict()
    png = plot_utilisation(report, out / f"utilisation_{label}.png")
    violations = [dict(v, remedy=remedy(v, report)) for v in d["violations"]]
    return {
        "label": label,
        "network": d["network"],
        "hardware": d["hardware"],
        "title": report.spec.title,
        "dt_ms": dt,
        "fits": d["fits"],
        "chips": d["chips"],
        "max_chips": d["max_chips"],
        "cores": d["cores"],
        "max_cores": d["max_cores"],
        "populations": [{"name": p["name"], "neurons": p["neurons"], "cores": p["cores"]} for p in d["populations"]],
        "violations": violations,
        "plot": png.name,
    }
