"""The reference backend: neurovpr's own numba simulator.

Exact integration of the linear subthreshold dynamics per step, event-driven CSR
spike propagation with delays, Poisson and array sources, pair STDP and the
Diehl & Cook rule with per-synapse traces, adaptive thresholds and the Ca2+
adaptation current. The whole step loop runs in one compiled function.
With ``hardware=`` it computes in a chip's number formats instead (:mod:`.fixed_point`).
"""

from __future__ import annotations

from typing import Any

from neurovpr.runtime.backend import Backend

from .capabilities import CAPABILITIES


class ReferenceBackend(Backend):
    """Declaration of the ``reference`` backend."""

    name = "reference"
    description = "neurovpr's numba simulator (exact integration, event-driven, STDP)"
    requires = ("numba",)
    version_of = "neurovpr"
    extra = ""
    capabilities = CAPABILITIES

    def _compile(self, network: Any, *, dt: float, seed: int, hardware: Any, **options: Any) -> Any:
        if hardware is not None:
            from .fixed_point import FixedPointSimulation

            return FixedPointSimulation(network, dt=dt, seed=seed, hardware=hardware, **options)
        from .simulation import ReferenceSimulation

        return ReferenceSimulation(network, dt=dt, seed=seed, **options)


BACKEND = ReferenceBackend()
