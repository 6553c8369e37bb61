"""The reference backend: neurovpr's own numba simulator.

Exact integration of the linear subthreshold dynamics per step, event-driven CSR
spike propagation with delays, Poisson and array sources, pair STDP and the
Diehl & Cook rule with per-synapse traces, adaptive thresholds and the Ca2+
adaptation current. The whole step loop runs in one compiled function.
With ``hardware=`` it computes in the arithmetic of the chip's ``[formats]`` instead
(:mod:`.fixed_point`).

Option of ``nv.compile(..., backend="reference", ...)``: ``record_spikes``, the names of the
populations whose spike trains are kept (default: all).
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any

from neurovpr.errors import UnsupportedFeatureError
from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.cells import euler_integrated
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import Backend
from neurovpr.runtime.simulation import Simulation

from .capabilities import CAPABILITIES


class ReferenceBackend(Backend):
    """Declaration of the ``reference`` backend."""

    name = "reference"
    description = "neurovpr's numba simulator (exact integration, event-driven, STDP)"
    requires = ("numba",)
    version_of = "neurovpr"
    extra = ""
    capabilities = CAPABILITIES
    options = MappingProxyType({"record_spikes": None})

    def _compile(
        self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget | None, **options: Any
    ) -> Simulation:
        # the simulator (numba and its compiled kernels) loads when a network is compiled, not with the declaration
        zero = next((p.name for p in network.projections.values() if p.zero_delay), None)
        if hardware is not None and zero is not None:
            raise UnsupportedFeatureError(
                f"Backend 'reference' cannot emulate hardware {hardware.name!r} with projection {zero!r}: it has a zero "
                "delay, where the chips' synapses take at least one time step."
            )
        euler = next((p.name for p in network.populations.values() if euler_integrated(p.cell_type)), None)
        if hardware is not None and euler is not None:
            raise UnsupportedFeatureError(
                f"Backend 'reference' cannot emulate hardware {hardware.name!r} with population {euler!r}: its cells take "
                "forward-Euler steps (integration='euler'), where the chips integrate in their own arithmetic."
            )
        if hardware is not None and hardware.spec.formats.arithmetic == "xylo":
            from .xylo import XyloSimulation

            return XyloSimulation(network, dt=dt, seed=seed, hardware=hardware, **options)
        if hardware is not None and hardware.spec.formats.arithmetic == "speck":
            from .speck import SpeckSimulation

            return SpeckSimulation(network, dt=dt, seed=seed, hardware=hardware, **options)
        if hardware is not None:
            from .fixed_point import FixedPointSimulation

            return FixedPointSimulation(network, dt=dt, seed=seed, hardware=hardware, **options)
        from .simulation import ReferenceSimulation

        return ReferenceSimulation(network, dt=dt, seed=seed, **options)


BACKEND = ReferenceBackend()
