"""Training one module and recording its responses, on any backend that learns.

Presentation (Diehl & Cook 2015; QVPR/VPRSNN ``non_modular_snn/snn_model.py``): every
28x28 image becomes 784 Poisson rates ``pixel / 4`` Hz
(:class:`neurovpr.data.encoding.RateCoding`) shown for 350 ms. Before every training
image the input weights onto each excitatory neuron are scaled to sum to 78 (VPRSNN's
``normalize_weights``; clipped to ``w_max``, where the code leaves a weight above it
until that synapse's next update). A module trains on its own places for ``epochs``
passes in one random order drawn once and repeated every pass (VPRSNN presents
``training_data[j % num_training_imgs]``), and then, with learning off, is shown every
reference image once: those responses give the hyperactive-neuron counts.

Assignment responses (VPRSNN's ``resultPopVecs`` of the training run and
``get_new_assignments``): the spike counts of the last ``assignment_presentations``
training presentations (250 in the authors' Nordland commands, ``--update_interval``),
*while learning*, averaged per place; a neuron is assigned to the place it fired most
for there (:func:`.inference.assign_neurons`).

Several training traverses (the paper trains on two reference traverses, e.g. Nordland
spring and fall; VPRSNN's ``get_train_test_imagenames_path``). Extra reference traverses
hold the same places in the same order (image ``i`` of every traverse is place ``i``).
Every epoch shows the module's places in the drawn order on the first traverse, then in
the same order on the next (VPRSNN's ``segment_array``: ``T x P`` presentations for
``T`` traverses and ``P`` module places); the assignment averages a place over all its
presentations in the window; afterwards, with learning off, every image of every
traverse is shown once, traverse by traverse.

Reset instead of rest (the default, ``simulate_rest=False``). VPRSNN follows each image
with 150 ms without input. After 150 ms the conductances (tau 1 ms and 0.5 ms) are
gone, the STDP traces (20 ms, 40 ms) are below e^-3.75 = 2%, the inhibitory membrane
(10 ms) is at rest and the excitatory membrane (100 ms) has relaxed to within
e^-1.5 = 22% of its distance from rest; adaptive thresholds carry over. ``reset()``
between images gives exactly that state except for the last 22% of the excitatory
membrane's excursion (set to rest instead) and removes spikes still in flight on the
0-10 ms input delays, while keeping weights and thresholds, and costs no simulated
time. ``simulate_rest=True`` runs the published schedule instead: membranes start 40 mV
below rest, 500 ms of silence first, then 350 ms image + 150 ms silence per image,
spike counts taken as differences, never reset.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import neurovpr as nv
from neurovpr.data.encoding import RateCoding

from .network import EXC, INPUT, INPUT_PROJECTION, ModuleParameters, build_module

__all__ = [
    "TrainingSettings",
    "Presenter",
    "normalise_input_weights",
    "train_module",
    "record_responses",
    "derive_seed",
    "module_seeds",
    "presentation_order",
]

#: Published code: membranes start this far below rest when the rest is simulated.
_V_START_OFFSET = -40.0


@dataclass(frozen=True, slots=True, kw_only=True)
class TrainingSettings:
    """How modules are built, trained and shown images (defaults: the paper / VPRSNN)."""

    params: ModuleParameters = field(default_factory=ModuleParameters)
    coding: RateCoding = field(default_factory=RateCoding)
    epochs: int = 30
    module_size: int = 25
    dt: float = 0.1
    weight_sum: float = 78.0
    simulate_rest: bool = False
    backend: str = "reference"
    assignment_presentations: int = 250

    def __post_init__(self) -> None:
        if isinstance(self.epochs, bool) or not isinstance(self.epochs, int) or not 1 <= self.epochs <= 1000:
            raise nv.ValidationError(f"epochs is {self.epochs!r}, expected an integer in 1..1000.")
        if isinstance(self.module_size, bool) or not isinstance(self.module_size, int) or not 1 <= self.module_size <= 10_000:
            raise nv.ValidationError(f"module size is {self.module_size!r} places, expected an integer in 1..10000.")
        window = self.assignment_presentations
        if isinstance(window, bool) or not isinstance(window, int) or not 1 <= window <= 1_000_000:
            raise nv.ValidationError(f"assignment presentations is {window!r}, expected an integer in 1..1000000.")
        if not (isinstance(self.dt, (int, float)) and 0 < self.dt <= 10):
            raise nv.ValidationError(f"dt is {self.dt!r} ms, expected a number in (0, 10].")
        if self.params.delay_max > 0 and self.params.delay_min < self.dt * (1 - 1e-9):
            raise nv.ValidationError(
                f"input delay minimum {self.params.delay_min} ms is shorter than the time step dt={self.dt} ms."
            )
        if self.params.integration == "euler":
            taus = {name: getattr(self.params, name) for name in ("tau_e", "tau_i", "tau_ge", "tau_gi", "tau_theta")}
            name = min(taus, key=lambda k: taus[k])
            if taus[name] <= self.dt:
                raise nv.ValidationError(
                    f"ModuleParameters.integration='euler' needs dt below every time constant of the cells, "
                    f"got dt = {self.dt} ms with {name} = {taus[name]} ms."
                )
        if not (isinstance(self.weight_sum, (int, float)) and 0 < self.weight_sum < self.params.n_input * self.params.w_max):
            raise nv.ValidationError(
                f"weight_sum is {self.weight_sum!r}, expected a number in (0, n_input * w_max = "
                f"{self.params.n_input * self.params.w_max:g})."
            )
        for name in ("presentation_ms", "rest_ms", "initial_rest_ms"):
            value = getattr(self.coding, name)
            if value and abs(round(value / self.dt) * self.dt - value) > 1e-9 * max(1.0, value):
                raise nv.ValidationError(f"{name} = {value} ms is not a whole number of dt = {self.dt} ms steps.")
        if self.coding.max_rate_hz * self.dt / 1000.0 > 1.0:
            raise nv.ValidationError(
                f"a 255 pixel's rate {self.coding.max_rate_hz:g} Hz exceeds one spike per dt = {self.dt} ms step."
            )

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form (read back with :meth:`from_dict`)."""
        return {
            "params": self.params.as_dict(),
            "coding": dataclasses.asdict(self.coding),
            "epochs": self.epochs,
            "module_size": self.module_size,
            "dt": self.dt,
            "weight_sum": self.weight_sum,
            "simulate_rest": self.simulate_rest,
            "backend": self.backend,
            "assignment_presentations": self.assignment_presentations,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrainingSettings:
        """Settings from :meth:`as_dict` output."""
        if not isinstance(data, dict):
            raise nv.ValidationError(f"training settings must be a JSON object, got {type(data).__name__}.")
        try:
            return cls(
                params=ModuleParameters.from_dict(data["params"]),
                coding=RateCoding(**data["coding"]),
                epochs=int(data["epochs"]),
                module_size=int(data["module_size"]),
                dt=float(data["dt"]),
                weight_sum=float(data["weight_sum"]),
                simulate_rest=bool(data["simulate_rest"]),
                backend=str(data["backend"]),
                assignment_presentations=int(data["assignment_presentations"]),
            )
        except (KeyError, TypeError) as exc:
            raise nv.ValidationError(f"training settings are incomplete or malformed ({exc}).") from None

    def network(self, name: str, seed: int | None = None, delay_seed: int | None = None) -> nv.Network:
        """A fresh (untrained) module graph with these settings (initial weights and delays from ``seed``;
        the delays from ``delay_seed`` when given, see :func:`.network.build_module`)."""
        p = self.params
        if self.simulate_rest:
            v_e, v_i = p.v_rest_e + _V_START_OFFSET, p.v_rest_i + _V_START_OFFSET
            return build_module(p, seed=seed, delay_seed=delay_seed, name=name, v_init_e=v_e, v_init_i=v_i)
        return build_module(p, seed=seed, delay_seed=delay_seed, name=name)


def derive_seed(seed: int, *keys: int) -> int:
    """A 31-bit seed derived from ``seed`` and integer ``keys`` (``numpy.random.SeedSequence``)."""
    return int(np.random.SeedSequence([int(seed), *map(int, keys)]).generate_state(1, dtype=np.uint32)[0] >> 1)


def module_seeds(seed: int, network_seed: int | None = None, stream_seed: int | None = None) -> tuple[int, int]:
    """``(network_seed, stream_seed)`` of a module: each given one, else the module's own ``seed``.

    The one rule for which seed draws a module's initial weights and which its input delays and
    Poisson spikes (see :func:`train_module`; :mod:`.plan` says when they are given apart).
    """
    return int(seed if network_seed is None else network_seed), int(seed if stream_seed is None else stream_seed)


def presentation_order(seed: int, n_places: int) -> np.ndarray:
    """The order a module seeded with ``seed`` shows its ``n_places`` places in every epoch.

    Indices into the module's places (as :func:`train_module` receives them); drawn once
    from ``numpy.random.default_rng([seed, 1])``. The assignment breaks ties by it
    (:func:`.inference.assign_neurons`), so it is derived here, in one place, from the seed
    every module record keeps.
    """
    if n_places < 1:
        raise nv.ValidationError(f"a module needs at least one place to order, got {n_places}.")
    return np.random.default_rng([int(seed), 1]).permutation(int(n_places))


class Presenter:
    """Shows images to a compiled module and returns the excitatory spike counts per image."""

    def __init__(self, sim: nv.Simulation, settings: TrainingSettings) -> None:
        self._sim = sim
        self._s = settings
        self._started = False

    @property
    def settings(self) -> TrainingSettings:
        """How images are shown."""
        return self._s

    @property
    def at_start(self) -> bool:
        """Whether the simulation is at time 0 (nothing shown since the last reset)."""
        return self._sim.time == 0

    def present_batch(self, images: np.ndarray, *, tick: Callable[[], None] | None = None) -> np.ndarray:
        """Spike counts ``(n_images, n_neurons)`` of independent presentations from the reset state (``Simulation.run_batch``)."""
        coding = self._s.coding
        items = [{INPUT: coding.rates(image)} for image in images]
        return self._sim.run_batch(coding.presentation_ms, items, populations=[EXC], tick=tick).counts[EXC]

    def present(self, image: np.ndarray) -> np.ndarray:
        """Present one preprocessed 0..255 image; spike counts of the excitatory neurons."""
        coding, sim = self._s.coding, self._sim
        rates = coding.rates(image)
        if not self._s.simulate_rest:
            sim.run(coding.presentation_ms, inputs={INPUT: rates})
            counts = sim.spike_counts(EXC)
            sim.reset()
            return counts
        if not self._started:
            self._started = True
            if coding.initial_rest_ms > 0:
                sim.run(coding.initial_rest_ms, inputs={INPUT: 0.0})
        before = sim.spike_counts(EXC)
        sim.run(coding.presentation_ms, inputs={INPUT: rates})
        counts = sim.spike_counts(EXC) - before
        if coding.rest_ms > 0:
            sim.run(coding.rest_ms, inputs={INPUT: 0.0})
        return counts


def normalise_input_weights(sim: nv.Simulation, target_sum: float, w_max: float) -> None:
    """Scale each excitatory neuron's input weights to sum to ``target_sum`` (clipped to ``w_max``).

    :meth:`Simulation.normalise_weights` (the sums in connection order, as ``np.bincount``
    adds them).
    """
    sim.normalise_weights(INPUT_PROJECTION, target_sum, w_max=w_max)


def record_responses(presenter: Presenter, images: np.ndarray, *, tick: Callable[[], None] | None = None) -> np.ndarray:
    """Spike counts ``(n_images, n_neurons)`` (int32) of every image, in order.

    With reset instead of rest the images are independent items from the reset state, so
    they go through one ``Simulation.run_batch`` (which a batching backend, ``torch``, runs
    at once; on the others it is the loop of :meth:`Presenter.present`, with the same
    result); with simulated rest they are shown one after another.
    """
    if not presenter.settings.simulate_rest and len(images) and presenter.at_start:
        return presenter.present_batch(images, tick=tick).astype(np.int32)
    rows = []
    for image in images:
        rows.append(presenter.present(image))
        if tick is not None:
            tick()
    return np.asarray(rows, dtype=np.int32)


def train_module(
    reference: np.ndarray,
    places: np.ndarray,
    settings: TrainingSettings,
    seed: int,
    *,
    name: str = "module",
    tick: Callable[[], None] | None = None,
    extra_references: Sequence[np.ndarray] = (),
    network_seed: int | None = None,
    stream_seed: int | None = None,
) -> tuple[nv.Network, np.ndarray, np.ndarray, dict[str, float]]:
    """Train one module on ``reference[places]`` and record its responses to all of ``reference``.

    Parameters
    ----------
    reference
        Every preprocessed reference image, ``(N, 28, 28)`` or ``(N, 784)``, 0..255.
    places
        Indices (into ``reference``) of this module's places.
    settings
        Graph, coding and training settings.
    seed
        Seed of the presentation order and, unless given apart, of everything else
        random in this module: initial weights, delays and Poisson spikes.
    name
        Name of the learned network.
    tick
        Called once per presented image (progress reporting).
    extra_references
        Further training traverses of the same ``N`` places, each shaped like
        ``reference`` (see the module docstring); empty: train on ``reference`` alone.
    network_seed, stream_seed
        Given apart (see :mod:`.plan`, ``seeding``): the seed of the initial weights, and
        the seed of the input delays and Poisson spikes (through ``nv.compile``), as the
        authors' code draws its weights with NumPy and its delays and Poisson spikes with
        Brian2's generator. ``None`` (both): everything from ``seed``.

    Returns
    -------
    network, assignment, responses, timing
        The learned network (weights and thresholds); the ``(len(places), n_neurons)``
        mean spike counts per place over the last ``assignment_presentations`` training
        presentations (see the module docstring; rows in the order of ``places``); the
        ``(T * N, n_neurons)`` spike counts with learning off to every image of the
        ``T = 1 + len(extra_references)`` training traverses (traverse-major: rows
        ``t * N .. t * N + N - 1`` are traverse ``t``, ``reference`` first); and the
        wall-clock and CPU seconds of training and recording (``train_seconds``,
        ``train_cpu_seconds``, ``record_seconds``, ``record_cpu_seconds``).
    """
    images = np.asarray(reference)
    images = images.reshape(images.shape[0], -1)
    traverses = [images]
    for k, extra in enumerate(extra_references, start=1):
        extra = np.asarray(extra)
        extra = extra.reshape(extra.shape[0], -1) if extra.ndim >= 1 else extra
        if extra.shape != images.shape:
            raise nv.ValidationError(
                f"module {name!r}: training traverse {k} has images of shape {extra.shape}, expected {images.shape} "
                "(the same places as the reference, in the same order)."
            )
        traverses.append(extra)
    places = np.asarray(places, dtype=np.int64)
    if places.size == 0 or places.min() < 0 or places.max() >= images.shape[0]:
        raise nv.ValidationError(f"module {name!r}: place indices must lie in 0..{images.shape[0] - 1}.")
    if images.shape[1] != settings.params.n_input:
        raise nv.ValidationError(
            f"module {name!r}: images have {images.shape[1]} pixels but the module has {settings.params.n_input} inputs."
        )
    start, cpu_start = time.perf_counter(), time.process_time()
    apart = network_seed is not None or stream_seed is not None
    weights, stream = module_seeds(seed, network_seed, stream_seed)
    graph = settings.network(name, weights, stream if apart else None)
    sim = nv.compile(graph, backend=settings.backend, dt=settings.dt, seed=stream)
    presenter = Presenter(sim, settings)
    order = presentation_order(seed, places.size)  # one order, every epoch
    epoch = [(t, k) for t in range(len(traverses)) for k in order]
    first_counted = settings.epochs * len(epoch) - settings.assignment_presentations
    summed = np.zeros((places.size, settings.params.n_neurons))
    shown = np.zeros(places.size)
    for e in range(settings.epochs):
        for j, (t, k) in enumerate(epoch):
            normalise_input_weights(sim, settings.weight_sum, settings.params.w_max)
            counts = presenter.present(traverses[t][places[k]])
            if e * len(epoch) + j >= first_counted:
                summed[k] += counts
                shown[k] += 1
            if tick is not None:
                tick()
    assignment = summed / np.maximum(shown, 1)[:, None]
    trained, cpu_trained = time.perf_counter(), time.process_time()
    sim.plasticity(False)
    responses = np.concatenate([record_responses(presenter, t, tick=tick) for t in traverses], axis=0)
    timing = {
        "train_seconds": trained - start,
        "train_cpu_seconds": cpu_trained - cpu_start,
        "record_seconds": time.perf_counter() - trained,
        "record_cpu_seconds": time.process_time() - cpu_trained,
    }
    return sim.to_network(name), assignment, responses, timing
