"""Running LoCS-Net: the rate model in numpy and the spiking network on any backend.

The spiking network is compiled once; every query resets it (time, membranes,
currents; weights are kept), sets the input spikes of the image and runs one
presentation window. The recognised place is the place neuron with the most spikes
in that window; the spike counts of all place neurons are the query's similarities.

The rate model (:func:`rate_forward`) computes the trained network's activations with
the SoftLIF nonlinearity (or the exact LIF rate) in numpy, so a run can be checked
without torch.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import neurovpr as nv
from neurovpr.errors import ValidationError
from neurovpr.ir.cells import SoftLIF

from .architecture import LAYER_NAMES, Architecture
from .conversion import INPUT, SpikingParameters, layer_populations

__all__ = [
    "lif_rate",
    "softlif_rate",
    "rate_forward",
    "regular_spike_trains",
    "check_images",
    "SpikingClassifier",
    "QueryResult",
]

_GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0


# -- rates ------------------------------------------------------------------------------
def lif_rate(j: np.ndarray, neuron: SoftLIF) -> np.ndarray:
    """The LIF steady firing rate (spikes/ms) for normalised input ``j`` (threshold 1), times ``amplitude``.

    ``r = 1 / (tau_ref + tau_rc log(1 + 1 / (j - 1)))`` above threshold, 0 below.
    """
    j = np.asarray(j, dtype=np.float64)
    out = np.zeros_like(j)
    above = j > 1.0
    out[above] = 1.0 / (neuron.tau_ref + neuron.tau_rc * np.log1p(1.0 / (j[above] - 1.0)))
    return neuron.amplitude * out


def softlif_rate(j: np.ndarray, neuron: SoftLIF) -> np.ndarray:
    """The smoothed LIF rate of Hunsberger & Eliasmith (2015), times ``amplitude``.

    ``p = sigma log(1 + exp((j - 1) / sigma))``, ``r = 1 / (tau_ref + tau_rc log(1 + 1 / p))``,
    computed through ``log p`` so that it stays finite far below threshold.
    """
    x = (np.asarray(j, dtype=np.float64) - 1.0) / float(neuron.sigma)
    low = x < -30.0
    with np.errstate(divide="ignore"):
        log_sp = np.where(low, x, np.log(np.logaddexp(0.0, np.where(low, 0.0, x))))
    log_p = np.log(float(neuron.sigma)) + log_sp
    log_inv = np.logaddexp(0.0, log_p) - log_p
    return neuron.amplitude / (neuron.tau_ref + neuron.tau_rc * log_inv)


def _conv2d(x: np.ndarray, kernel: np.ndarray, stride: int, padding: int) -> np.ndarray:
    """Cross-correlation of ``x`` (N, C, H, W) with ``kernel`` (O, C, k, k), as torch's ``conv2d``."""
    if padding:
        x = np.pad(x, ((0, 0), (0, 0), (padding, padding), (padding, padding)))
    k = kernel.shape[-1]
    windows = np.lib.stride_tricks.sliding_window_view(x, (k, k), axis=(2, 3))[:, :, ::stride, ::stride]
    return np.einsum("nchwyx,ocyx->nohw", windows, kernel, optimize=True)


def rate_forward(
    arch: Architecture, params: dict[str, np.ndarray], images: np.ndarray, *, exact_lif: bool = False
) -> dict[str, np.ndarray]:
    """Activations of every layer for ``images`` (N, H, W) in [0, 1].

    ``exact_lif=True`` uses the LIF rate instead of SoftLIF (what a spiking network
    approaches when its rates are steady).
    """
    x = check_images(arch, images)[:, None].astype(np.float64)
    rate = lif_rate if exact_lif else softlif_rate
    out: dict[str, np.ndarray] = {}
    for layer, conv in zip(LAYER_NAMES[:3], arch.convs, strict=True):
        j = _conv2d(x, np.asarray(params[f"{layer}.weight"], dtype=np.float64), conv.stride, conv.padding)
        if f"{layer}.bias" in params:
            j = j + np.asarray(params[f"{layer}.bias"])[None, :, None, None]
        x = rate(j, arch.neuron)
        out[layer] = x
    j = x.reshape(x.shape[0], -1) @ np.asarray(params["places.weight"], dtype=np.float64).T
    if "places.bias" in params:
        j = j + np.asarray(params["places.bias"])[None, :]
    out["places"] = rate(j, arch.neuron)
    return out


# -- input ------------------------------------------------------------------------------
def check_images(arch: Architecture, images: Any, *, what: str = "images") -> np.ndarray:
    """``images`` as a float (N, H, W) array in [0, 1] of the architecture's input size, or a clear error."""
    arr = np.asarray(images)
    if arr.ndim == 2:
        arr = arr[None]
    h, w = arch.input_size
    if arr.ndim != 3 or arr.shape[1:] != (h, w):
        raise ValidationError(
            f"{what}: shape {tuple(np.shape(images))}, but the network takes {h}x{w} grayscale images "
            f"((N, {h}, {w}) or ({h}, {w}))."
        )
    if arr.shape[0] == 0:
        raise ValidationError(f"{what}: none given, expected at least one image.")
    if not np.issubdtype(arr.dtype, np.number):
        raise ValidationError(f"{what}: dtype {arr.dtype}, expected numbers in [0, 1].")
    arr = arr.astype(np.float64)
    if not np.all(np.isfinite(arr)):
        raise ValidationError(f"{what}: NaN or infinite pixel values.")
    if arr.min() < 0.0 or arr.max() > 1.0:
        raise ValidationError(f"{what}: pixel values in [{arr.min():g}, {arr.max():g}], expected [0, 1].")
    return arr


def regular_spike_trains(values: np.ndarray, rate_hz: float, duration: float, dt: float) -> nv.SpikeSourceArray:
    """Evenly spaced spikes: pixel ``i`` of value ``x`` fires every ``1 / (x rate)`` from phase ``frac(i g)``.

    ``g`` is the golden ratio's fractional part, so pixels of equal value do not fire
    in lockstep. Times are on the ``dt`` grid and inside ``[0, duration)``.
    """
    x = np.asarray(values, dtype=np.float64).ravel()
    rho = x * rate_hz / 1000.0  # spikes per ms
    phase = np.mod(np.arange(x.size) * _GOLDEN, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        counts = np.where(rho > 0, np.ceil(duration * rho - phase), 0).astype(np.int64)
    counts = np.maximum(counts, 0)
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    owner = np.repeat(np.arange(x.size), counts)
    k = np.arange(offsets[-1]) - offsets[owner]
    times = np.floor((phase[owner] + k) / rho[owner] / dt + 1e-9) * dt
    return nv.SpikeSourceArray(times=np.minimum(times, duration - dt), offsets=offsets)


# -- spiking ------------------------------------------------------------------------------
@dataclass
class QueryResult:
    """Spike counts of the place layer for a batch of queries, with timing and activity.

    Attributes
    ----------
    counts
        ``(n_places, n_queries)`` spike counts: the similarity matrix ``[place, query]``.
    seconds
        Wall-clock seconds per query: the whole batch of queries (inputs, run, read-out) divided by their number.
    activity
        Per-inference means: steps, neuron updates, spikes, synaptic events (when the
        backend counts them).
    layer_spikes
        Mean spikes per query of every layer.
    totals
        The backend's activity totals over the whole batch (``Simulation.statistics()``
        differences), or ``None``.
    cpu_seconds
        CPU time of the whole batch (this process).
    """

    counts: np.ndarray
    seconds: np.ndarray
    activity: dict[str, float] | None = None
    layer_spikes: dict[str, float] = field(default_factory=dict)
    totals: dict[str, int] | None = None
    cpu_seconds: float = 0.0


def presentation_inputs(spiking: SpikingParameters, image: np.ndarray) -> dict[str, Any]:
    """Run inputs showing one image (H, W) in [0, 1]: Poisson rates or regular spike trains, as ``spiking`` codes them."""
    if spiking.input_coding == "poisson":
        return {INPUT: image.ravel() * spiking.input_rate}
    return {INPUT: regular_spike_trains(image, spiking.input_rate, spiking.presentation, spiking.dt)}


class SpikingClassifier:
    """A compiled spiking LoCS-Net that answers queries one by one.

    Parameters
    ----------
    network
        The spiking network (:func:`~.conversion.to_spiking_network` or ``nv.load``).
    arch
        Its architecture (checked against the network's sizes).
    spiking
        Time step, presentation window and input coding.
    backend
        Any backend that runs ``IF_curr_exp`` with convolutions.
    seed
        Seed of the Poisson input.
    hardware
        A hwspec name for backends that emulate a chip.
    options
        Backend options passed to :func:`neurovpr.compile`.
    """

    def __init__(
        self,
        network: nv.Network,
        arch: Architecture,
        spiking: SpikingParameters,
        *,
        backend: str = "reference",
        seed: int = 0,
        hardware: str | None = None,
        **options: Any,
    ) -> None:
        sizes = arch.layer_sizes()
        self.populations = layer_populations(arch, spiking)
        expected = {INPUT: sizes["input"]}
        for layer, names in self.populations.items():
            expected.update({name: sizes[layer] // len(names) for name in names})
        for name, size in expected.items():
            pop = network.populations.get(name)
            if pop is None or pop.size != size:
                raise ValidationError(
                    f"network {network.name!r} does not match the architecture: population {name!r} "
                    f"{'is missing' if pop is None else f'has {pop.size} neurons, expected {size}'}."
                )
        coding = "poisson" if isinstance(network.populations[INPUT].cell_type, nv.SpikeSourcePoisson) else "regular"
        if coding != spiking.input_coding:
            raise ValidationError(
                f"network {network.name!r} has a {coding} input population but the spiking parameters ask for "
                f"{spiking.input_coding!r} coding."
            )
        self.arch, self.spiking, self.backend = arch, spiking, backend
        if backend == "reference":
            options.setdefault("record_spikes", ())
        t0 = time.perf_counter()
        self.sim = nv.compile(network, backend=backend, dt=spiking.dt, seed=seed, hardware=hardware, **options)
        self.compile_seconds = time.perf_counter() - t0

    def layer_counts(self, layer: str) -> np.ndarray:
        """Spike counts of a layer since the last reset (groups of ``conv3`` concatenated in channel order)."""
        return np.concatenate([self.sim.spike_counts(p) for p in self.populations[layer]])

    def _inputs(self, image: np.ndarray) -> dict[str, Any]:
        return presentation_inputs(self.spiking, image)

    def query(self, image: np.ndarray) -> np.ndarray:
        """Spike counts of the place neurons for one image (H, W) in [0, 1]."""
        img = check_images(self.arch, image, what="query image")[0]
        self.sim.reset()
        self.sim.run(self.spiking.presentation, inputs=self._inputs(img))
        return self.sim.spike_counts("places")

    def run(self, images: np.ndarray | Iterable[np.ndarray], *, progress: bool = False, desc: str = "queries") -> QueryResult:
        """Answer every query; see :class:`QueryResult`."""
        imgs = check_images(self.arch, images if isinstance(images, np.ndarray) else np.stack(list(images)))
        n = imgs.shape[0]
        counts = np.zeros((self.arch.n_places, n), dtype=np.int64)
        seconds = np.zeros(n)
        layer_spikes = dict.fromkeys(LAYER_NAMES, 0.0)
        before = self._statistics()
        cpu0 = time.process_time()
        # every query is an independent item from the reset state: one batch (run at once by a batching backend)
        layers = {layer: self.populations[layer] for layer in LAYER_NAMES[:3]}
        names = ["places", *(p for pops in layers.values() for p in pops)]
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=n, desc=f"{desc} ({self.backend})", unit="query", leave=False)
        t0 = time.perf_counter()
        try:
            self.sim.reset()
            result = self.sim.run_batch(
                self.spiking.presentation,
                [self._inputs(imgs[q]) for q in range(n)],
                populations=names,
                tick=None if bar is None else bar.update,
            )
        finally:
            if bar is not None:
                bar.close()
        seconds[:] = (time.perf_counter() - t0) / n
        counts[:] = result.counts["places"].T
        for layer, pops in layers.items():
            layer_spikes[layer] = float(sum(result.counts[p].sum() for p in pops))
        layer_spikes["places"] = float(counts.sum())
        cpu = time.process_time() - cpu0
        after = self._statistics()
        activity = totals = None
        if before is not None and after is not None:
            totals = {key: after[key] - before[key] for key in after}
            activity = {key: value / n for key, value in totals.items()}
        return QueryResult(counts=counts, seconds=seconds, activity=activity,
                           layer_spikes={k: v / n for k, v in layer_spikes.items()}, totals=totals, cpu_seconds=cpu)

    def _statistics(self) -> dict[str, int] | None:
        try:
            return self.sim.statistics()
        except nv.SimulationError:
            return None
