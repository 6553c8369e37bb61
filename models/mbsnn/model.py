"""Running the mushroom body: learning a route segment, responding to a recording, familiarity.

The learning phase presents one traversal (or a segment of it) with plasticity on; the
test phase presents another recording with plasticity off, once through the naive
network (all KC->KC weights at their initial 0) and once through the trained one. The
MBON's firing rate in equal windows of the test recording gives, per window,

    familiarity = (rate before learning - rate after learning) / rate before learning,

1 when learning silenced the MBON, 0 when it did not change it, negative when the MBON
fires more than before (and 0 where the naive MBON was silent, as nothing could be
reduced). Windows are equal fractions of the
recording, which aligns two recordings of the same route by normalised time.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from tqdm.auto import tqdm

import neurovpr as nv
from neurovpr.data.events import PNSpikes
from neurovpr.errors import ValidationError
from neurovpr.resources import check_run
from neurovpr.runtime.simulation import Simulation

from .network import KC_KC, MBSNNParameters

__all__ = [
    "MBONResponse",
    "check_recording",
    "compile_mbsnn",
    "present",
    "naive_weights",
    "window_rates",
    "familiarity",
    "segment_labels",
]


@dataclass(frozen=True, slots=True)
class MBONResponse:
    """What one presentation of a recording produced.

    Attributes
    ----------
    spike_times
        MBON spike times (ms from the start of the recording).
    duration_ms
        Length of the presented recording.
    v_times, v
        The MBON membrane potential (mV) at the end of every step.
    counts
        Spikes of each population (``{"pn": ..., "kc1": ..., "kc2": ..., "mbon": ...}``).
    """

    spike_times: np.ndarray
    duration_ms: float
    v_times: np.ndarray
    v: np.ndarray
    counts: dict[str, int]

    @property
    def rate_hz(self) -> float:
        """Mean MBON rate over the whole recording."""
        return float(self.spike_times.size / self.duration_ms * 1000.0)

    def rates(self, n_windows: int) -> np.ndarray:
        """MBON rate (Hz) in ``n_windows`` equal windows of the recording."""
        return window_rates(self.spike_times, self.duration_ms, n_windows)


def check_recording(spikes: PNSpikes, what: str, n_pn: int | None = None) -> None:
    """Refuse an empty recording, or one with another number of PNs than the network."""
    if not isinstance(spikes, PNSpikes):
        raise ValidationError(f"{what} must be PNSpikes, got {type(spikes).__name__}.")
    if len(spikes) == 0:
        raise ValidationError(
            f"{what} holds no projection-neuron spikes in its {spikes.duration_ms:g} ms; "
            "an empty stream cannot drive the mushroom body."
        )
    if n_pn is not None and spikes.n_pn != n_pn:
        raise ValidationError(f"{what} has {spikes.n_pn} projection neurons but the network has {n_pn}.")


def compile_mbsnn(
    network: nv.Network,
    *,
    dt: float = MBSNNParameters().dt,
    backend: str = "reference",
    seed: int = 0,
    **options: Any,
) -> Simulation:
    """Compile a mushroom-body network (:func:`~neurovpr.models.mbsnn.network.build_network`) on ``backend``.

    On the reference backend only the MBON's spike trains are kept (counts are kept
    for every population), which keeps long recordings small in memory.
    """
    if backend == "reference":
        options.setdefault("record_spikes", ("mbon",))
    return nv.compile(network, backend=backend, dt=dt, seed=seed, **options)


def naive_weights(sim: Simulation) -> np.ndarray:
    """The KC->KC weights before learning: the synapse's initial weight (0) for every connection."""
    n = sim.connections(KC_KC)[0].size
    initial = sim.network.projections[KC_KC].synapse.weight
    return np.full(n, float(initial)) if isinstance(initial, float) else np.zeros(n)


def present(
    sim: Simulation,
    spikes: PNSpikes,
    *,
    learn: bool,
    chunk_ms: float = 500.0,
    progress: str | None = None,
) -> MBONResponse:
    """Reset ``sim`` and play ``spikes`` through it, learning or not.

    Parameters
    ----------
    sim
        A compiled mushroom body (:func:`compile_mbsnn`).
    spikes
        The recording (times from 0).
    learn
        Plasticity on (learning phase) or off (test phase).
    chunk_ms
        The run advances in pieces of this length, for the progress bar.
    progress
        Label of a tqdm progress bar; ``None`` shows none.
    """
    n_pn = sim.network.populations["input"].size
    check_recording(spikes, "the recording", n_pn)
    total_steps = max(round(spikes.duration_ms / sim.dt), 1)
    check_run(sim.network, dt=sim.dt, steps=total_steps, what=f"mbsnn: {spikes.duration_ms:g} ms of PN spikes")
    sim.reset()
    sim.plasticity(bool(learn))
    sim.record("mbon", "v")
    total, steps = spikes.duration_ms, total_steps
    chunk = max(round(chunk_ms / sim.dt), 1)
    inputs: dict[str, Any] | None = {"input": spikes.to_source()}
    with tqdm(total=round(total / 1000.0, 3), unit="s", desc=progress, disable=progress is None, leave=False) as bar:
        done = 0
        while done < steps:
            n = min(chunk, steps - done)
            sim.run(n * sim.dt, inputs=inputs)
            inputs = None
            done += n
            bar.update(round(n * sim.dt / 1000.0, 3))
    times, _ = sim.spike_trains("mbon")
    v_times, v = sim.trace("mbon", "v")
    counts = {name: int(sim.spike_counts(name).sum()) for name in ("pn", "kc1", "kc2", "mbon")}
    return MBONResponse(
        spike_times=times, duration_ms=float(steps * sim.dt), v_times=v_times, v=v[:, 0].copy(), counts=counts
    )


def window_rates(spike_times: np.ndarray, duration_ms: float, n_windows: int) -> np.ndarray:
    """Spike rate (Hz) in ``n_windows`` equal windows of ``[0, duration_ms)``."""
    if isinstance(n_windows, bool) or int(n_windows) != n_windows or n_windows < 1:
        raise ValidationError(f"window_rates: n_windows must be a positive integer, got {n_windows!r}.")
    if not duration_ms > 0:
        raise ValidationError(f"window_rates: duration_ms must be > 0, got {duration_ms!r}.")
    n = int(n_windows)
    width = duration_ms / n
    which = np.clip(np.floor(np.asarray(spike_times, dtype=np.float64) / width).astype(np.int64), 0, n - 1)
    return np.bincount(which, minlength=n).astype(np.float64) / (width / 1000.0)


def familiarity(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """``(before - after) / before`` per window; 0 where the naive MBON did not fire."""
    b = np.asarray(before, dtype=np.float64)
    a = np.asarray(after, dtype=np.float64)
    if b.shape != a.shape:
        raise ValidationError(f"familiarity: rates before {b.shape} and after {a.shape} differ in shape.")
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(b > 0, (b - a) / np.where(b > 0, b, 1.0), 0.0)


def segment_labels(n_windows: int, start: float, end: float) -> np.ndarray:
    """Windows whose centre lies in the learned segment ``[start, end)`` (fractions of the recording)."""
    if not 0.0 <= start < end <= 1.0:
        raise ValidationError(f"segment_labels: need 0 <= start < end <= 1, got {start}:{end}.")
    centres = (np.arange(int(n_windows)) + 0.5) / int(n_windows)
    return (centres >= start) & (centres < end)
