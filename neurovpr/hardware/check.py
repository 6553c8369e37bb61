"""Does a network fit a hardware target? The report behind ``neurovpr check``, and the one route to hardware.

``nv.compile(..., hardware=NAME)`` calls :func:`hardware_target`: the network is partitioned
once, with the compile's time step and seed, and that one partition gives the verdict
(:class:`CheckReport`), the core blocks the emulated arithmetic quantises per core, and the
chips and cores the energy estimate counts (:class:`HardwareTarget`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from neurovpr.errors import ValidationError
from neurovpr.ir.network import Network
from neurovpr.resources import require_nodes

from .hwspec import HwSpec, load_hwspec
from .partition import Partition, partition

__all__ = ["CheckReport", "HardwareTarget", "check_network", "hardware_target"]

#: Column titles of the per-population table, by resource.
_RESOURCES = {
    "neurons": "neurons/core",
    "input_axons": "in-axons",
    "output_axons": "out-axons",
    "synapse_bits": "synapse mem",
    "synaptic_matrix_bytes": "matrix bytes",
}


@dataclass(frozen=True, slots=True, kw_only=True)
class CheckReport:
    """The fit of one network on one hardware target.

    Attributes
    ----------
    network : str
        The network's name.
    spec : HwSpec
        The target; its ``[timing].time_step_ms`` is the step checked (``dt_ms``).
    partition : Partition
        Per-core slices, chips and violations.
    sizes : dict
        Population name -> number of neurons.
    """

    network: str
    spec: HwSpec
    partition: Partition
    sizes: dict[str, int]

    @property
    def fits(self) -> bool:
        """True when no limit is broken."""
        return self.partition.fits

    def populations(self) -> list[dict[str, Any]]:
        """One entry per population that occupies cores or is served by the host."""
        order: dict[str, list] = {}
        for core in self.partition.cores:
            order.setdefault(core.population, []).append(core)
        out = []
        for name, cores in order.items():
            usage_max: dict[str, int] = {}
            util_max: dict[str, float] = {}
            for c in cores:
                for k, v in c.usage.items():
                    usage_max[k] = max(usage_max.get(k, 0), v)
                for k, v in c.utilisation().items():
                    util_max[k] = max(util_max.get(k, 0.0), v)
            out.append(
                {
                    "name": name,
                    "neurons": sum(c.neurons for c in cores) if cores[0].kind not in ("delays", "synapses") else 0,
                    "cores": len(cores),
                    "kind": cores[0].kind,
                    "max_usage": usage_max,
                    "max_utilisation": {k: round(v, 6) for k, v in util_max.items()},
                    "slices": [c.as_dict() for c in cores],
                }
            )
        for name in self.partition.host:
            out.append({"name": name, "neurons": self.sizes.get(name), "cores": 0, "kind": "host", "max_usage": {},
                        "max_utilisation": {}, "slices": []})
        return out

    def as_dict(self) -> dict[str, Any]:
        """The JSON object ``neurovpr check --json`` prints."""
        return {
            "hardware": self.spec.name,
            "network": self.network,
            "fits": self.fits,
            "chips": self.partition.chips,
            "max_chips": self.spec.chip.n_chips,
            "cores": len(self.partition.cores),
            "max_cores": self.spec.total_cores,
            "dt_ms": self.spec.timing.time_step_ms,
            "populations": self.populations(),
            "violations": [v.as_dict() for v in self.partition.violations],
            "notes": list(self.partition.notes),
        }

    def table(self) -> str:
        """A human-readable table: per population cores and peak utilisation, then violations."""
        pops = self.populations()
        used = [k for k in _RESOURCES if any(k in p["max_utilisation"] or k in p["max_usage"] for p in pops)]
        header = ["population", "kind", "neurons", "cores"] + [_RESOURCES[k] for k in used]
        rows = [header]
        for p in pops:
            cells = [p["name"], p["kind"], "-" if p["neurons"] is None else str(p["neurons"]), str(p["cores"])]
            for k in used:
                if k in p["max_utilisation"]:
                    cells.append(f"{100 * p['max_utilisation'][k]:.1f}%")
                elif k in p["max_usage"]:
                    cells.append(str(p["max_usage"][k]))
                else:
                    cells.append("-")
            rows.append(cells)
        widths = [max(len(r[i]) for r in rows) for i in range(len(header))]
        step = self.spec.timing.time_step_ms
        lines = [f"{self.spec.title} ({self.spec.name}), network {self.network!r}, time step {step:g} ms"]
        lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in rows]
        verdict = "fits" if self.fits else f"does NOT fit ({len(self.partition.violations)} limits broken)"
        lines.append(
            f"chips {self.partition.chips}/{self.spec.chip.n_chips}, cores {len(self.partition.cores)}"
            f"/{self.spec.total_cores}: {verdict}"
        )
        lines += [f"  - {v.limit}: {v.message}" for v in self.partition.violations]
        return "\n".join(lines)


def check_network(network: Network, hardware: str | HwSpec, *, seed: int = 0, dt: float | None = None) -> CheckReport:
    """Partition ``network`` onto ``hardware`` (a hwspec name, path or object) and report the fit.

    Parameters
    ----------
    network
        The network to check.
    hardware
        ``"spinn5"``, ``"kapoho-bay"``, ``"loihi2"``, a ``.toml`` path, or a loaded spec.
    seed
        Seed of random connectors that have none of their own.
    dt
        Time step (ms) the network runs at on the chip; default the hwspec's
        ``[timing].time_step_ms``. Delays are counted in these steps, and sPyNNaker
        splits neuron and synapse cores below 1 ms; on SpiNNaker the step is the one
        sPyNNaker runs, ``dt`` rounded up to whole microseconds
        (:func:`neurovpr.hardware.spinnaker.spynnaker_step_us`).

    Returns
    -------
    CheckReport
        The report; ``report.fits`` says whether every limit holds.
    """
    if not isinstance(network, Network):
        raise ValidationError(f"check: expected a neurovpr Network, got {type(network).__name__}.")
    require_nodes(len(network.populations), len(network.projections), f"check: network {network.name!r}")
    spec = hardware if isinstance(hardware, HwSpec) else load_hwspec(hardware)
    if dt is not None:
        if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not math.isfinite(dt) or dt <= 0:
            raise ValidationError(f"check: time step dt must be a positive number of ms, got {dt!r}.")
        spec = dataclasses.replace(spec, timing=dataclasses.replace(spec.timing, time_step_ms=float(dt)))
    return CheckReport(network=network.name, spec=spec, partition=partition(network, spec, seed=seed),
                       sizes={name: pop.size for name, pop in network.populations.items()})


@dataclass(frozen=True, slots=True, kw_only=True)
class HardwareTarget:
    """A network placed on a hardware target, as ``nv.compile(..., hardware=...)`` made it.

    Attributes
    ----------
    spec : HwSpec
        The hwspec as loaded (its own ``[timing].time_step_ms``).
    report : CheckReport
        The fit of the network, partitioned at ``dt`` with ``seed``.
    dt : float
        The compile's time step (ms).
    seed : int
        The compile's seed (random connectors without their own seed).
    """

    spec: HwSpec
    report: CheckReport
    dt: float
    seed: int

    @property
    def name(self) -> str:
        """The hwspec's name."""
        return self.spec.name

    @property
    def partition(self) -> Partition:
        """The one partition: the verdict's, the emulation's and the energy estimate's."""
        return self.report.partition


def hardware_target(network: Network, hardware: str | HwSpec, *, dt: float, seed: int) -> HardwareTarget:
    """Partition ``network`` once onto ``hardware`` at time step ``dt`` with ``seed``; it must fit.

    Raises
    ------
    ValidationError
        If the hwspec is unknown or malformed, or the network does not fit (one sentence
        with the number of broken limits and the first of them).
    """
    spec = load_hwspec(hardware)
    report = check_network(network, spec, seed=seed, dt=dt)
    if not report.fits:
        broken = report.partition.violations
        first = broken[0].message.rstrip(".")
        raise ValidationError(
            f"Network {network.name!r} does not fit {spec.name} at dt={dt:g} ms ({len(broken)} limit(s) broken; "
            f"first: {first}; see `neurovpr check`)."
        )
    return HardwareTarget(spec=spec, report=report, dt=float(dt), seed=int(seed))
