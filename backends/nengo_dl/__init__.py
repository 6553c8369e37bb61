"""The ``nengo-dl`` backend: NengoDL's Simulator (TensorFlow, CPU) running the ``nengo`` backend's network.

NengoDL (the LoCS-Net paper's own toolchain) simulates Nengo networks with TensorFlow.
This backend builds the Nengo network of :mod:`neurovpr.backends.nengo` (its LIF with
the network's weights) and runs it on NengoDL's Simulator; it runs inference, like
``nengo``. LoCS-Net's NengoDL trainer (``neurovpr train --model locsnet --trainer
nengo-dl``) reaches NengoDL through :meth:`NengoDLBackend.import_nengo_dl`, found by the
registry, so the model imports no backend.

NengoDL 3.6.0 installs next to TensorFlow 2.15 and Keras 2.15 only with ``--no-deps``
and needs one import fixed in memory (:mod:`.compat`); ``scripts/install_nengo_dl.sh``
installs it. Importing this package imports neither Nengo nor TensorFlow.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

from neurovpr.backends.nengo import NengoBackend
from neurovpr.errors import BackendUnavailableError
from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.network import Network
from neurovpr.runtime.simulation import Simulation

from .capabilities import NENGO_DL_CAPABILITIES

__all__ = ["NengoDLBackend", "NENGO_DL"]


class NengoDLBackend(NengoBackend):
    """Declaration of the ``nengo-dl`` backend (NengoDL's Simulator on the CPU)."""

    name = "nengo-dl"
    description = "NengoDL simulator (TensorFlow on the CPU, off-chip; inference), LoCS-Net's NengoDL trainer"
    requires = ("nengo", "nengo_dl")
    version_of = "nengo-dl"
    extra = "nengo-dl"
    capabilities = NENGO_DL_CAPABILITIES
    loihi = False

    def unavailable_reason(self) -> str | None:
        """``None`` when Nengo and NengoDL import (through :mod:`.compat`), otherwise why not and how to install it."""
        try:
            self.import_nengo_dl()
        except BackendUnavailableError as exc:
            return str(exc).rstrip(".")
        return None

    def import_nengo_dl(self, threads: int | None = 1) -> ModuleType:
        """The ``nengo_dl`` module, imported through the Keras fix of :mod:`.compat`.

        Raises
        ------
        BackendUnavailableError
            One sentence: what does not import and how to install it.
        """
        from .compat import import_nengo_dl

        try:
            import nengo  # noqa: F401 - NengoDL needs Nengo first
        except ImportError as exc:
            raise BackendUnavailableError(
                f"Nengo is not installed ({exc}); install it with: pip install 'neurovpr[nengo]'."
            ) from None
        return import_nengo_dl(threads)

    def _compile(self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget | None, **options: Any) -> Simulation:
        from .simulation import NengoDLSimulation

        return NengoDLSimulation(network, backend=self.name, dt=dt, seed=seed, hardware=hardware, **options)


NENGO_DL = NengoDLBackend()
