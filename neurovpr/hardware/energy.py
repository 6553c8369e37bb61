"""Energy per inference on a hardware target, from the activity counted in a run.

Activity file (``RUN_DIR/activity.json``)
-----------------------------------------
One JSON object, written by :func:`write_activity`. Counts are **per inference** (the
totals of ``Simulation.statistics()`` divided by ``inferences``) and may be fractional:

``version`` (int, 1)
    Format version.
``inferences`` (int > 0)
    How many inferences (queries, images, recordings) the totals were divided by.
``dt_ms`` (number or null)
    Simulation time step of the run; lets the estimator convert to the hardware step.
``steps``, ``neuron_updates``, ``spikes``, ``synaptic_events`` (numbers >= 0, required)
    Time steps, neuron state updates, spikes emitted, synaptic events delivered.
``plastic_updates`` (number >= 0, optional)
    Synaptic weight updates by plasticity rules.
``spikes_between_chips`` (number >= 0, optional)
    Spikes that cross a chip boundary, when the run counted them.
``population_spikes`` (object, optional)
    Spikes per population name; used to estimate chip crossings from the partition.
``cpu_seconds``, ``cpu_joules`` (numbers >= 0, optional)
    Measured CPU time and CPU energy of the run per inference (see :class:`CpuEnergyMeter`).

The estimate uses only numbers from the hwspec's ``[energy]`` table: synaptic events x
energy per synaptic op, plastic updates x energy per synaptic update, neuron updates at the
hardware step x energy per (inactive or spiking) neuron update, spikes x energy per spike
within or between chips, and static power x chips x wall time at the hardware step.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from neurovpr.errors import ValidationError
from neurovpr.fileio import atomic_write_text
from neurovpr.ir.network import Network

from .check import check_network
from .hwspec import HwSpec, load_hwspec
from .partition import Partition

__all__ = [
    "ACTIVITY_FILE",
    "REQUIRED_COUNTS",
    "write_activity",
    "read_activity",
    "EnergyReport",
    "estimate_energy",
    "CpuEnergyMeter",
    "rapl_status",
]

ACTIVITY_FILE = "activity.json"
ACTIVITY_VERSION = 1
#: Counts every activity file must carry.
REQUIRED_COUNTS = ("steps", "neuron_updates", "spikes", "synaptic_events")
_OPTIONAL_COUNTS = ("plastic_updates", "spikes_between_chips", "cpu_seconds", "cpu_joules")
_POWERCAP = Path("/sys/class/powercap")


def _number(where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
        raise ValidationError(f"{where} must be a finite number >= 0, got {value!r}.")
    return float(value)


def write_activity(
    run_dir: str | os.PathLike,
    stats: Mapping[str, Any],
    inferences: int,
    *,
    dt_ms: float | None = None,
    population_spikes: Mapping[str, Any] | None = None,
    cpu_seconds: float | None = None,
    cpu_joules: float | None = None,
) -> Path:
    """Write ``RUN_DIR/activity.json`` from a run's totals (atomically).

    Parameters
    ----------
    run_dir
        The run directory (created if missing).
    stats
        Totals over the whole run, as returned by ``Simulation.statistics()``; must hold
        ``steps``, ``neuron_updates``, ``spikes`` and ``synaptic_events`` and may hold
        ``plastic_updates`` and ``spikes_between_chips``. Other keys are ignored.
    inferences
        Number of inferences the totals cover; every count is divided by it.
    dt_ms
        The run's time step in ms.
    population_spikes
        Total spikes per population (divided by ``inferences`` too).
    cpu_seconds, cpu_joules
        Total CPU time and CPU energy measured over the run (divided by ``inferences``).

    Returns
    -------
    pathlib.Path
        The file written.
    """
    if isinstance(inferences, bool) or not isinstance(inferences, int) or inferences < 1:
        raise ValidationError(f"write_activity: inferences must be an integer >= 1, got {inferences!r}.")
    data: dict[str, Any] = {"version": ACTIVITY_VERSION, "inferences": inferences, "dt_ms": None}
    if dt_ms is not None:
        data["dt_ms"] = _number("write_activity: dt_ms", dt_ms)
    for key in REQUIRED_COUNTS:
        if key not in stats:
            raise ValidationError(f"write_activity: statistics lack the count {key!r} (have {sorted(stats)}).")
        data[key] = _number(f"write_activity: statistics[{key!r}]", stats[key]) / inferences
    for key in ("plastic_updates", "spikes_between_chips"):
        if key in stats:
            data[key] = _number(f"write_activity: statistics[{key!r}]", stats[key]) / inferences
    for key, value in (("cpu_seconds", cpu_seconds), ("cpu_joules", cpu_joules)):
        if value is not None:
            data[key] = _number(f"write_activity: {key}", value) / inferences
    if population_spikes is not None:
        data["population_spikes"] = {
            str(k): _number(f"write_activity: population_spikes[{k!r}]", v) / inferences
            for k, v in population_spikes.items()
        }
    path = Path(run_dir)
    path.mkdir(parents=True, exist_ok=True)
    target = path / ACTIVITY_FILE
    atomic_write_text(target, json.dumps(data, indent=2) + "\n")
    return target


def read_activity(path: str | os.PathLike) -> dict[str, Any]:
    """Read and validate an activity file (or ``RUN_DIR/activity.json`` given the directory)."""
    p = Path(path)
    if p.is_dir():
        p = p / ACTIVITY_FILE
    if not p.is_file():
        raise ValidationError(f"Activity file {str(p)!r} does not exist.")
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValidationError(f"Activity file {str(p)!r} is not valid JSON: {exc}.") from None
    if not isinstance(data, dict):
        raise ValidationError(f"Activity file {str(p)!r} must hold one JSON object.")
    if data.get("version") != ACTIVITY_VERSION:
        raise ValidationError(f"Activity file {str(p)!r} has version {data.get('version')!r}, expected 1.")
    inf = data.get("inferences")
    if isinstance(inf, bool) or not isinstance(inf, int) or inf < 1:
        raise ValidationError(f"Activity file {str(p)!r}: inferences must be an integer >= 1, got {inf!r}.")
    out: dict[str, Any] = {"inferences": inf, "dt_ms": None}
    if data.get("dt_ms") is not None:
        out["dt_ms"] = _number(f"Activity file {str(p)!r}: dt_ms", data["dt_ms"])
    for key in REQUIRED_COUNTS:
        if key not in data:
            raise ValidationError(f"Activity file {str(p)!r} lacks the count {key!r}.")
        out[key] = _number(f"Activity file {str(p)!r}: {key}", data[key])
    for key in _OPTIONAL_COUNTS:
        if data.get(key) is not None:
            out[key] = _number(f"Activity file {str(p)!r}: {key}", data[key])
    if data.get("population_spikes") is not None:
        pops = data["population_spikes"]
        if not isinstance(pops, dict):
            raise ValidationError(f"Activity file {str(p)!r}: population_spikes must be an object.")
        out["population_spikes"] = {str(k): _number(f"population_spikes[{k!r}]", v) for k, v in pops.items()}
    return out


@dataclass(frozen=True, slots=True, kw_only=True)
class EnergyReport:
    """Estimated energy per inference on one target, with its breakdown (joules)."""

    hardware: str
    joules_per_inference: float | None
    breakdown: dict[str, float]
    seconds_per_inference: float
    chips: int
    cores: int | None
    basis: str
    not_estimated: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    activity: dict[str, Any] = field(default_factory=dict)
    cpu: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """The JSON object ``neurovpr energy --json`` prints."""
        return {
            "hardware": self.hardware,
            "joules_per_inference": self.joules_per_inference,
            "breakdown": dict(self.breakdown),
            "seconds_per_inference": self.seconds_per_inference,
            "chips": self.chips,
            "cores": self.cores,
            "basis": self.basis,
            "not_estimated": list(self.not_estimated),
            "notes": list(self.notes),
            "activity": dict(self.activity),
            "cpu": dict(self.cpu),
        }

    def table(self) -> str:
        """A human-readable breakdown."""
        if self.joules_per_inference is None:
            total = "energy not estimated (no term has a published figure)"
        elif self.not_estimated:
            total = f"at least {self.joules_per_inference:.6g} J per inference (terms below not estimated)"
        else:
            total = f"{self.joules_per_inference:.6g} J per inference"
        lines = [f"{self.hardware}: {total} ({self.seconds_per_inference:.6g} s on chip, {self.chips} chip(s))"]
        for key, joules in self.breakdown.items():
            share = 100 * joules / self.joules_per_inference if self.joules_per_inference else 0.0
            lines.append(f"  {key:<22} {joules:.6g} J  ({share:.1f}%)")
        lines += [f"  not estimated: {item}" for item in self.not_estimated]
        lines += [f"  note: {item}" for item in self.notes]
        if self.cpu.get("joules_per_inference") is not None:
            lines.append(f"  measured CPU: {self.cpu['joules_per_inference']:.6g} J per inference")
        else:
            lines.append(f"  measured CPU energy: unavailable ({self.cpu.get('reason', 'not measured')})")
        lines.append(f"  basis: {self.basis}")
        return "\n".join(lines)


def _between_chips(activity: Mapping[str, Any], network: Network | None, part: Partition | None) -> float | None:
    """Spikes crossing chips: counted by the run, or estimated from per-population spikes."""
    if "spikes_between_chips" in activity:
        return float(activity["spikes_between_chips"])
    if part is None or network is None:
        return None
    if len({c.chip for c in part.cores}) <= 1:
        return 0.0
    pops = activity.get("population_spikes")
    if pops is None:
        return None
    chips_of: dict[str, set[int]] = {}
    for c in part.cores:
        chips_of.setdefault(c.population, set()).add(c.chip)
    total = 0.0
    for name, spikes in pops.items():
        cores = part.cores_of(name)
        targets = set().union(*(chips_of.get(p.post, set()) for p in network.projections.values() if p.pre == name))
        if not cores or not targets:
            continue
        per_core = [len(targets - {c.chip}) * c.neurons for c in cores]
        total += spikes * sum(per_core) / sum(c.neurons for c in cores)
    return total


def estimate_energy(
    activity: Mapping[str, Any],
    hardware: str | HwSpec,
    *,
    network: Network | None = None,
    partition: Partition | None = None,
    seed: int = 0,
    dt: float | None = None,
) -> EnergyReport:
    """Joules per inference on ``hardware`` for the per-inference ``activity``.

    Parameters
    ----------
    activity
        Per-inference counts as returned by :func:`read_activity`.
    hardware
        A hwspec name, path or loaded spec.
    network
        The network that produced the activity; with it the estimate uses the chips and
        cores it occupies (otherwise all chips of the target) and estimates chip crossings.
    partition
        A partition already computed for ``network`` on ``hardware`` (else computed here).
    seed, dt
        Seed of random connectors and time step (ms; default the hwspec's) when the
        partition is computed here: the partition :func:`~neurovpr.hardware.check.check_network`
        makes for the fit verdict with the same ``dt`` and ``seed``.
    """
    spec = hardware if isinstance(hardware, HwSpec) else load_hwspec(hardware)
    energy = spec.energy
    if network is not None and partition is None:
        partition = check_network(network, spec, seed=seed, dt=dt).partition
    steps = float(activity["steps"])
    dt = activity.get("dt_ms")
    hw_steps = steps * dt / spec.timing.time_step_ms if dt is not None else steps
    scale = hw_steps / steps if steps > 0 else 0.0
    neuron_updates = float(activity["neuron_updates"]) * scale
    spikes = float(activity["spikes"])
    active = min(spikes, neuron_updates)
    not_estimated: list[str] = []
    between = _between_chips(activity, network, partition)
    chips = spec.chip.n_chips if partition is None else max(partition.chips, 1)
    cores = None if partition is None else len(partition.cores)
    notes: list[str] = []
    if partition is None:
        notes.append(f"network unknown: static power counted for all {chips} chip(s) of {spec.name}")
    elif not partition.fits:
        notes.append(f"the network does not fit {spec.name}; the estimate assumes the {chips} chip(s) it would need")
    if between is None:
        between = 0.0
        if chips > 1:
            not_estimated.append("spikes between chips (no per-population spike counts in the activity)")
    seconds = hw_steps * energy.wall_time_per_step_s
    # Each term needs its published figure; one left out of the hwspec (unpublished) is reported as not estimated.
    terms = {
        "synaptic_ops": (float(activity["synaptic_events"]), energy.synaptic_op_pJ),
        "synaptic_updates": (float(activity.get("plastic_updates", 0.0)), energy.synaptic_update_pJ),
        "inactive_neuron_updates": (neuron_updates - active, energy.neuron_update_pJ),
        "active_neuron_updates": (active, energy.neuron_active_update_pJ),
        "spikes_within_chip": (max(spikes - between, 0.0), energy.spike_within_chip_pJ),
    }
    breakdown: dict[str, float] = {}
    for name, (count, pj) in terms.items():
        if pj is not None:
            key = "neuron_updates" if name.endswith("neuron_updates") else name
            breakdown[key] = breakdown.get(key, 0.0) + count * pj * 1e-12
        elif count > 0:
            not_estimated.append(f"{count:g} {name.replace('_', ' ')} ({spec.name} publishes no energy for them)")
    if energy.spike_between_chips_pJ is not None:
        breakdown["spikes_between_chips"] = between * energy.spike_between_chips_pJ * 1e-12
    elif between > 0:
        not_estimated.append(f"{between:g} spikes between chips ({spec.name} publishes no energy per chip crossing)")
    if energy.board_static_power_W is not None:
        breakdown["static"] = energy.board_static_power_W * seconds
    elif energy.static_power_per_chip_W is not None:
        breakdown["static"] = energy.static_power_per_chip_W * chips * seconds
    else:
        not_estimated.append(f"static power ({spec.name} publishes none)")
    if energy.active_core_power_W is not None:
        if cores is None:
            not_estimated.append("active-core power (cores unknown without the network)")
        else:
            breakdown["active_cores"] = energy.active_core_power_W * cores * seconds
    cpu: dict[str, Any] = {}
    if activity.get("cpu_joules") is not None:
        cpu = {"joules_per_inference": float(activity["cpu_joules"]), "seconds_per_inference": activity.get("cpu_seconds")}
    else:
        ok, reason = rapl_status()
        cpu = {"joules_per_inference": None, "seconds_per_inference": activity.get("cpu_seconds"),
               "reason": "the run did not record CPU energy" if ok else reason}
    return EnergyReport(
        hardware=spec.name,
        # Nothing with a published figure: no total rather than a misleading 0 J.
        joules_per_inference=float(sum(breakdown.values())) if breakdown else None,
        breakdown=breakdown,
        seconds_per_inference=seconds,
        chips=chips,
        cores=cores,
        basis=energy.basis,
        not_estimated=tuple(not_estimated),
        notes=tuple(notes),
        activity={k: v for k, v in activity.items() if k != "population_spikes"},
        cpu=cpu,
    )


def _rapl_domains(root: Path) -> list[Path]:
    """Top-level RAPL package domains (``intel-rapl:N``) that expose ``energy_uj``."""
    if not root.is_dir():
        return []
    return sorted(p for p in root.glob("intel-rapl:*") if p.name.count(":") == 1 and (p / "energy_uj").is_file())


def rapl_status(root: str | os.PathLike | None = None) -> tuple[bool, str]:
    """Whether this machine exposes readable RAPL energy counters, and why not if it does not."""
    base = _POWERCAP if root is None else Path(root)
    domains = _rapl_domains(base)
    if not domains:
        return False, f"no RAPL energy counters under {base} (not an Intel/AMD host, or not exposed here)"
    try:
        (domains[0] / "energy_uj").read_text()
    except OSError as exc:
        return False, f"RAPL counters under {base} are not readable ({exc.strerror or exc})"
    return True, "available"


class CpuEnergyMeter:
    """Measure CPU package energy (RAPL, ``/sys/class/powercap``) and time over a block.

    Use as a context manager; afterwards ``joules`` is the energy of all packages (or
    ``None`` with ``reason`` set when RAPL is unavailable) and ``seconds`` the wall time.
    Counter wrap-around is handled with each domain's ``max_energy_range_uj``.
    """

    def __init__(self, root: str | os.PathLike | None = None) -> None:
        self._root = _POWERCAP if root is None else Path(root)
        self.joules: float | None = None
        self.seconds: float = 0.0
        ok, self.reason = rapl_status(self._root)
        self._domains = _rapl_domains(self._root) if ok else []
        self._start: list[int] = []
        self._t0 = 0.0

    @property
    def available(self) -> bool:
        """True when RAPL counters can be read."""
        return bool(self._domains)

    def _read(self) -> list[int]:
        return [int((d / "energy_uj").read_text().strip()) for d in self._domains]

    def __enter__(self) -> CpuEnergyMeter:
        self._start = self._read() if self._domains else []
        self._t0 = time.perf_counter()
        return self

    def __exit__(self, *exc: object) -> None:
        self.seconds = time.perf_counter() - self._t0
        if not self._domains:
            return
        total = 0
        for d, start, end in zip(self._domains, self._start, self._read(), strict=True):
            delta = end - start
            if delta < 0:
                delta += int((d / "max_energy_range_uj").read_text().strip())
            total += delta
        self.joules = total * 1e-6
