"""The ``xylo`` backend: SynSense Xylo Audio 2 (SYNS61201) through Rockpool's XyloSim.

A network that fits the ``xylo`` hwspec (checked first, with Rockpool's mapper rules:
:mod:`neurovpr.hardware.xylo`) runs on ``XyloSim.from_specification``, Rockpool's module
around the C++ bit-accurate simulator ``xylosim.v2``, in Xylo's integer chip units
(:mod:`.simulation`). Inference only, explicit spike-array inputs. Rockpool's Xylo package
is imported without its samna-dependent ``__init__`` (:mod:`.compat`); what needs samna (the
chip configuration, the hardware) is not run. Importing this package does not import Rockpool.
"""

from __future__ import annotations

from typing import Any

from neurovpr.backendkit.chips import chip_target
from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import Backend
from neurovpr.runtime.simulation import Simulation

from .capabilities import CAPABILITIES

__all__ = ["XyloBackend", "BACKEND"]


class XyloBackend(Backend):
    """Declaration of the ``xylo`` backend."""

    name = "xylo"
    description = "Rockpool's XyloSim: the C++ bit-accurate Xylo Audio 2 simulator (integer chip units; inference)"
    requires: tuple[str, ...] = ("rockpool", "xylosim")
    version_of = "rockpool"
    extra = "synsense"
    capabilities = CAPABILITIES

    def _compile(
        self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget | None, **options: Any
    ) -> Simulation:
        from .simulation import XyloSimSimulation

        # The backend is the chip: the network must fit Xylo whether or not hardware= was given.
        target = chip_target(network, self.name, "xylo", hardware, dt=dt, seed=seed)
        return XyloSimSimulation(network, dt=dt, seed=seed, hardware=target)


BACKEND = XyloBackend()
