"""The ``lava`` and ``lava-fixed`` backends.

Both compile a network to Lava processes (LIF, Dense/Sparse, DelayDense/DelaySparse,
Conv with a delay, injectors for spike sources and extractors for spikes) and run them with
``Loihi2SimCfg``: ``lava`` selects
the ``floating_pt`` models (off-chip), ``lava-fixed`` the ``fixed_pt`` models,
bit-accurate with Loihi 2's number formats. They run inference: ``IF_curr_exp``
populations with fixed weights, every connector, Poisson and array sources. See
:mod:`.translation` for the mapping, and :mod:`neurovpr.backendkit.loihi2` for the
fixed-point integers (Loihi 2's formats, read from the ``loihi2`` hwspec).

lava-nc 0.10.0 declares Python 3.10 only; on Python 3.11 it is installed with
scripts/install_lava.sh and imported through :mod:`.compat`, which fixes its one
incompatible module in memory. Importing this package does not import Lava.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any

from neurovpr.errors import BackendUnavailableError
from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import Backend
from neurovpr.runtime.simulation import Simulation

from .capabilities import LAVA_CAPABILITIES, LAVA_FIXED_CAPABILITIES, network_problems
from .compat import import_lava

__all__ = ["LavaBackend", "LavaFixedBackend", "LAVA", "LAVA_FIXED"]


class LavaBackend(Backend):
    """Declaration of the ``lava`` backend (floating-point process models)."""

    name = "lava"
    description = "Lava processes on Loihi2SimCfg, floating_pt models (off-chip; inference)"
    requires: tuple[str, ...] = ("lava",)
    version_of = "lava-nc"
    extra = "lava"
    capabilities = LAVA_CAPABILITIES
    options = MappingProxyType({"buffer_steps": 1000})
    #: Select the fixed-point (bit-accurate Loihi 2) models.
    fixed = False

    def unavailable_reason(self) -> str | None:
        """``None`` when Lava imports (through the Python 3.11 fix), otherwise why not and how to reinstall."""
        try:
            import_lava()
        except BackendUnavailableError as exc:
            return str(exc).rstrip(".")
        return None

    def network_problems(self, network: Network) -> list[str]:
        """The parameters Lava's LIF cannot express."""
        return network_problems(network)

    def _compile(
        self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget | None, **options: Any
    ) -> Simulation:
        # Lava's runtime is imported when a network is compiled, not with the declaration
        from .simulation import LavaSimulation

        return LavaSimulation(network, backend=self.name, dt=dt, seed=seed, fixed=self.fixed, hardware=hardware, **options)


class LavaFixedBackend(LavaBackend):
    """Declaration of the ``lava-fixed`` backend (fixed-point models, bit-accurate Loihi 2)."""

    name = "lava-fixed"
    description = "Lava processes on Loihi2SimCfg, fixed_pt models (bit-accurate Loihi 2; inference)"
    capabilities = LAVA_FIXED_CAPABILITIES
    fixed = True


LAVA = LavaBackend()
LAVA_FIXED = LavaFixedBackend()
