"""The ``speck`` backend: SynSense Speck / DYNAP-CNN through Sinabs's chip-faithful simulation.

A network that fits the ``speck`` hwspec (checked first, with Sinabs's mapping rules:
:mod:`neurovpr.hardware.speck`) and whose neurons Speck can hold
(:func:`neurovpr.hardware.speck_values.speck_problems`: non-leaky ``IF_curr_exp`` layers,
one convolution or dense projection each, feeding forward) runs as Sinabs's discretised
``DynapcnnLayer`` objects (integer weights, thresholds and ``min_v_mem``; ``IAFSqueeze``
neurons that reset by subtraction), layer after layer as ``DynapcnnNetwork`` runs them
(:mod:`.simulation`). Inference only; Poisson and spike-array inputs are drawn on the host.
Sinabs's DYNAP-CNN package is imported without its samna-dependent ``__init__``
(:mod:`.compat`); what needs samna (the chip configuration, ``specksim``) is not run.
Importing this package does not import Sinabs.
"""

from __future__ import annotations

from typing import Any

from neurovpr.backendkit.chips import chip_target
from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import Backend
from neurovpr.runtime.simulation import Simulation

from .capabilities import CAPABILITIES

__all__ = ["SpeckBackend", "BACKEND"]


class SpeckBackend(Backend):
    """Declaration of the ``speck`` backend."""

    name = "speck"
    description = "Sinabs's DYNAP-CNN layers: Speck's integer IAF neurons, discretised as DynapcnnNetwork does (inference)"
    requires: tuple[str, ...] = ("sinabs", "torch")
    version_of = "sinabs"
    extra = "synsense"
    capabilities = CAPABILITIES

    def _compile(self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget | None, **options: Any) -> Simulation:
        from .simulation import SinabsSimulation

        # The backend is the chip: the network must fit Speck whether or not hardware= was given.
        target = chip_target(network, self.name, "speck", hardware, dt=dt, seed=seed)
        return SinabsSimulation(network, dt=dt, seed=seed, hardware=target)


BACKEND = SpeckBackend()
