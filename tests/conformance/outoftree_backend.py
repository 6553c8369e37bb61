"""A backend package outside neurovpr, for the tests of the conformance plugin (never installed, never shipped).

``test_plugin.py`` copies this module next to a ``.dist-info`` folder whose entry points
declare its two backends in the ``neurovpr.backends`` group, as a third-party wheel would.
Both wrap the reference backend:

- ``wrapped-reference`` runs it as is, but declares less than it can do: no
  ``DiehlCookSTDP``, the ``poisson`` case unsupported (with a reason) and a looser bound
  for ``psp_curr``;
- ``biased-reference`` records every state variable 1e-6 above its value and declares a
  looser trace bound for ``lif_rate_curr`` only, so the suite must pass that case and fail
  ``lif_rate_cond``.
"""

from __future__ import annotations

import dataclasses
from types import MappingProxyType
from typing import Any

import numpy as np

from neurovpr.backends.reference import BACKEND as REFERENCE
from neurovpr.backends.reference.simulation import ReferenceSimulation
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import Backend, ToleranceOverride
from neurovpr.runtime.simulation import Simulation

#: How far above its value ``biased-reference`` records a state variable (mV, nA, uS).
BIAS = 1e-6


class WrappedReference(Backend):
    """The reference backend behind another name, declaring less than it can do."""

    name = "wrapped-reference"
    description = "the reference backend, wrapped by an out-of-tree package"
    requires = ("numba",)
    capabilities = dataclasses.replace(
        REFERENCE.capabilities,
        synapses=frozenset({"StaticSynapse", "STDPMechanism"}),
        reasons=MappingProxyType({"DiehlCookSTDP": "this package leaves Diehl & Cook's rule out"}),
        unsupported=MappingProxyType({"poisson": "its random numbers come from the host of this package"}),
        tolerances=MappingProxyType(
            {"psp_curr": ToleranceOverride(changes={"trace_rel": 1e-6}, reason="a looser bound this package declares")}
        ),
    )

    def _compile(self, network: Network, *, dt: float, seed: int, hardware: Any, **options: Any) -> Simulation:
        return REFERENCE.compile(network, dt=dt, seed=seed, hardware=hardware, **options)


class _Biased(ReferenceSimulation):
    def _trace(self, population: str, variable: str) -> tuple[np.ndarray, np.ndarray]:
        times, values = super()._trace(population, variable)
        return times, values + BIAS


class BiasedReference(Backend):
    """The reference backend recording state variables slightly high, with a looser bound for one case only."""

    name = "biased-reference"
    description = "the reference backend recording every state variable 1e-6 high"
    requires = ("numba",)
    capabilities = dataclasses.replace(
        REFERENCE.capabilities,
        tolerances=MappingProxyType(
            {"lif_rate_curr": ToleranceOverride(changes={"trace_rel": 1e-6}, reason="traces are recorded 1e-6 mV high")}
        ),
    )

    def _compile(self, network: Network, *, dt: float, seed: int, hardware: Any, **options: Any) -> Simulation:
        return _Biased(network, dt=dt, seed=seed)


WRAPPED = WrappedReference()
BIASED = BiasedReference()
