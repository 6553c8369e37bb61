"""The PyNN backends: PyNN standard models on NEST (``pynn``) and on Brian2 (``pynn:brian2``).

The IR compiles to PyNN's standard cell types (``IF_curr_exp``, ``IF_cond_exp``,
``SpikeSourceArray``), ``FromListConnector`` projections holding the canonical
connections, and ``StaticSynapse`` / ``STDPMechanism(SpikePairRule, Additive- or
MultiplicativeWeightDependence)``. What PyNN has no standard model for
(``IF_cond_exp_adaptive``, ``IF_curr_exp_ca2_adaptive``, ``DiehlCookSTDP``) is refused
by name at compile time. Importing this package imports neither PyNN nor a simulator.

Options of :func:`neurovpr.compile` for ``pynn:brian2``: ``codegen_target="numpy"``
(default) or ``"cython"`` (compiled into neurovpr's cache folder).
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any

from neurovpr.errors import ValidationError
from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import Backend, Capabilities
from neurovpr.runtime.simulation import Simulation

from .build import quiet
from .capabilities import CAPABILITIES_BRIAN2, CAPABILITIES_NEST, Simulator, feature_problems

__all__ = ["PyNNBackend", "BACKEND", "BACKEND_BRIAN2"]


class PyNNBackend(Backend):
    """Declaration of a PyNN backend on one simulator."""

    version_of = "PyNN"
    extra = "pynn"
    options = MappingProxyType({"codegen_target": "numpy", "threads": 1})

    def __init__(
        self, *, name: str, simulator: Simulator, description: str, requires: tuple[str, ...], capabilities: Capabilities
    ) -> None:
        self.name = name
        self.simulator: Simulator = simulator
        self.description = description
        self.requires = requires
        self.capabilities = capabilities

    def unavailable_reason(self) -> str | None:
        """``None`` when PyNN and the simulator import (NEST's banner silenced)."""
        with quiet():
            return super().unavailable_reason()

    def network_problems(self, network: Network) -> list[str]:
        """Parameter combinations the PyNN simulator cannot express, with PyNN's reason."""
        return feature_problems(network, self.simulator)

    def _compile(
        self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget | None, **options: Any
    ) -> Simulation:
        target = options["codegen_target"]
        if target not in ("numpy", "cython"):
            raise ValidationError(f"Backend {self.name!r}: codegen_target must be 'numpy' or 'cython', got {target!r}.")
        threads = options["threads"]
        if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
            raise ValidationError(f"Backend {self.name!r}: threads must be a whole number of at least 1, got {threads!r}.")
        if threads != 1 and self.simulator != "nest":
            raise ValidationError(f"Backend {self.name!r}: threads={threads} needs NEST; Brian2 under PyNN runs one thread.")
        # PyNN and the simulator are imported when a network is compiled, not with the declaration
        from .simulation import PyNNSimulation

        return PyNNSimulation(
            network, backend=self.name, simulator=self.simulator, dt=dt, seed=seed, codegen_target=target,
            threads=threads,
        )  # fmt: skip


BACKEND = PyNNBackend(
    name="pynn",
    simulator="nest",
    description="PyNN 0.13 standard models on NEST 3 (exact integration on the time grid)",
    requires=("pyNN", "nest"),
    capabilities=CAPABILITIES_NEST,
)

BACKEND_BRIAN2 = PyNNBackend(
    name="pynn:brian2",
    simulator="brian2",
    description="PyNN 0.13 standard models on Brian2 (numpy code generation by default)",
    requires=("pyNN", "brian2"),
    capabilities=CAPABILITIES_BRIAN2,
)
