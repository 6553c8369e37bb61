"""The ``nengo-dl`` simulation: the ``nengo`` backend's Nengo network run by NengoDL's Simulator.

The network is built by :func:`neurovpr.backends.nengo.build.build_network` exactly as
for the ``nengo`` backend (``nengo.LIF`` ensembles with the network's weights as
transforms, spike sources replayed by nodes into spike-gate neurons); NengoDL turns it
into a TensorFlow graph and runs it on the CPU, in float64 so that spike times agree
with Nengo's reference simulator (NengoDL's default float32 moves threshold crossings
by round-off). Everything else (sources, read-out, voltages, activity counts) is
:class:`~neurovpr.backends.nengo.simulation.NengoSimulation`'s.
"""

from __future__ import annotations

import sys
import warnings
from typing import Any

from neurovpr.backends.nengo.build import BuiltNetwork, SpikeGate
from neurovpr.backends.nengo.simulation import NengoSimulation
from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.network import Network

from .compat import import_nengo_dl

__all__ = ["NengoDLSimulation"]

nengo_dl = import_nengo_dl()
tf = sys.modules["tensorflow"]


class SpikeGateBuilder(nengo_dl.neuron_builders.TFNeuronBuilder):  # type: ignore[misc, name-defined]
    """NengoDL's TensorFlow step of :class:`~neurovpr.backends.nengo.build.SpikeGate` (a spike where ``J > 0.5``).

    Registered in ``SimNeuronsBuilder.TF_NEURON_IMPL``, NengoDL's table of neuron types
    with their own TensorFlow step; without it NengoDL calls the Python step through
    ``tf.numpy_function`` on every step.
    """

    spiking = True

    def step(self, J: Any, dt: Any) -> Any:
        """One step: ``1 / dt`` where the replayed spike is on, else 0."""
        return tf.cast(J > 0.5, J.dtype) * self.alpha

    def training_step(self, J: Any, dt: Any) -> Any:
        """Spike gates are never trained: the same step."""
        return self.step(J, dt)


nengo_dl.neuron_builders.SimNeuronsBuilder.TF_NEURON_IMPL.setdefault(SpikeGate, SpikeGateBuilder)


class _Simulator(nengo_dl.Simulator):  # type: ignore[misc, name-defined]
    """NengoDL's Simulator with the two calls :class:`NengoSimulation` makes of Nengo's."""

    def clear_probes(self) -> None:
        """Forget the recorded probe data (the simulation state is kept)."""
        for probe in self.model.probes:
            self.model.params[probe] = []

    def __del__(self) -> None:
        """Close a simulator dropped open (neurovpr's simulations are closed by their owner or by the collector)."""
        if getattr(self, "closed", True) is False:
            self.close()

    def run_steps(self, n_steps: int, **kwargs: Any) -> None:
        """NengoDL's ``run_steps`` (its first call builds the TensorFlow function, with the convolution notice silenced)."""
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*channels_last=False on the CPU.*")
            super().run_steps(n_steps, **kwargs)

    def reset_state(self) -> None:
        """Back to the initial state: time, voltages, synaptic filters, node replays (weights never change)."""
        self.reset(include_trainable=False, include_probes=True, include_processes=True)


class NengoDLSimulation(NengoSimulation):
    """A network on NengoDL's Simulator (TensorFlow, CPU, float64).

    Parameters
    ----------
    network, backend, dt, seed, hardware
        As for :class:`~neurovpr.runtime.simulation.Simulation`.
    """

    def __init__(self, network: Network, *, backend: str, dt: float, seed: int, hardware: HardwareTarget | None = None) -> None:
        super().__init__(network, backend=backend, dt=dt, seed=seed, loihi=False, hardware=hardware)

    def _new_simulator(self, built: BuiltNetwork) -> Any:
        with built.net:
            nengo_dl.configure_settings(dtype="float64", inference_only=True, stateful=True)
        with warnings.catch_warnings():
            # NengoDL transposes Nengo's channels-first convolutions for TensorFlow's CPU kernels
            warnings.filterwarnings("ignore", message=".*channels_last=False on the CPU.*")
            return _Simulator(built.net, dt=self._dt / 1000.0, seed=self._seed % 2**31, device="/cpu:0", progress_bar=False)

    def _reset_simulator(self, sim: Any) -> None:
        sim.reset_state()
