"""The ``nengo`` and ``nengo-loihi`` backends.

``nengo`` runs a network on Nengo's reference simulator (off-chip, floating point);
``nengo-loihi`` builds the same Nengo network with NengoLoihi and runs it on
NengoLoihi's Loihi emulator (on-chip: NengoLoihi's block splitting and Loihi
number formats, no hardware needed). Both run inference: ``IF_curr_exp``
populations with fixed weights, dense, sparse and convolutional projections,
Poisson and array sources. See :mod:`.translation` for the mapping and where its
numerics differ from docs/semantics.md.

Importing this package does not import Nengo.
"""

from __future__ import annotations

import warnings
from types import MappingProxyType
from typing import Any

from neurovpr.backendkit.tensorflow_env import tensorflow_defaults
from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import Backend
from neurovpr.runtime.simulation import Simulation

from .capabilities import NENGO_CAPABILITIES, NENGO_LOIHI_CAPABILITIES, network_problems

__all__ = ["NengoBackend", "NengoLoihiBackend", "NENGO", "NENGO_LOIHI"]


class NengoBackend(Backend):
    """Declaration of the ``nengo`` backend (Nengo's reference simulator)."""

    name = "nengo"
    description = "Nengo reference simulator (off-chip, floating point; inference)"
    requires: tuple[str, ...] = ("nengo",)
    version_of = "nengo"
    extra = "nengo"
    capabilities = NENGO_CAPABILITIES
    #: Build for NengoLoihi's emulator.
    loihi = False

    def unavailable_reason(self) -> str | None:
        """``None`` when the simulators import, otherwise why not (with the extra to install).

        NengoLoihi 1.1 warns at import that it was tested up to Nengo 3.2; it runs on
        Nengo 4.1 (its own emulator tests pass), so the warning is not repeated here.
        """
        tensorflow_defaults()  # NengoLoihi imports TensorFlow when it is installed (Keras's home: a temporary folder)
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*nengo_loihi.*has not been tested.*")
            return super().unavailable_reason()

    def network_problems(self, network: Network) -> list[str]:
        """The parameters Nengo's (or NengoLoihi's) LIF cannot express."""
        return network_problems(network, loihi=self.loihi)

    def _compile(
        self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget | None, **options: Any
    ) -> Simulation:
        # Nengo is imported when a network is compiled, not with the declaration
        from .simulation import NengoSimulation

        return NengoSimulation(network, backend=self.name, dt=dt, seed=seed, loihi=self.loihi, hardware=hardware, **options)


class NengoLoihiBackend(NengoBackend):
    """Declaration of the ``nengo-loihi`` backend (NengoLoihi's Loihi emulator)."""

    name = "nengo-loihi"
    description = "NengoLoihi Loihi emulator (on-chip: Loihi partitioning and number formats; inference)"
    requires = ("nengo", "nengo_loihi")
    version_of = "nengo-loihi"
    capabilities = NENGO_LOIHI_CAPABILITIES
    loihi = True
    options = MappingProxyType({"block_shapes": None})


NENGO = NengoBackend()
NENGO_LOIHI = NengoLoihiBackend()
