"""The brian2 backend: the network compiled to Brian2 objects.

Every population becomes a ``NeuronGroup`` (LIF models), ``PoissonGroup`` or
``SpikeGeneratorGroup``, every projection one ``Synapses`` object connected with the
canonical connection list of :func:`neurovpr.ir.connectivity.expand`, so connections,
weights and delays equal every other backend's for the same seed. Equations come from
the fixed templates in :mod:`.translation`; no string from a network or a model file
reaches Brian2's code generation.

Options of ``nv.compile(..., backend="brian2", ...)``:

``target``
    ``"numpy"`` (default) or ``"cython"``. Cython code is compiled into
    ``neurovpr.paths.cache_dir("brian2")`` (``NEUROVPR_CACHE`` or the repository's
    ``.cache/``) and reused by later runs.

Timing. Brian2 integrates step ``j`` (``[j dt, (j + 1) dt)``), then tests thresholds and
stamps a spike ``j dt``; the semantics stamp it ``(j + 1) dt``, so neuron spike times and
recorded samples (taken at the end of each step) are read out one step later. Arrivals
run in Brian2's ``start`` slot, at the start of the step in which they act, as in the
semantics; spikes found in the last step of a run are handed to the next run (Brian2
itself forgets them), so ``run(a); run(b)`` equals ``run(a + b)``. ``reset()`` restores
a snapshot taken at compile time and writes back weights and ``theta``.

Numerics compared with docs/semantics.md:

- current-based neurons: Brian2's ``exact`` integrator (the same exact propagation);
  where ``tau_syn`` equals ``tau_m`` for every neuron the template uses the degenerate
  solution; where it does for some neurons only, their ``tau_syn`` is moved 1e-6
  (relative) away from ``tau_m``, with a warning;
- conductance-based neurons: Brian2's ``exponential_euler`` on a template that uses the
  step's mean conductance, which is exactly the semantics' update;
- Poisson sources are Brian2 ``PoissonGroup``s drawing from Brian2's generator (another
  random stream than the reference backend's, with the same statistics), seeded before
  every run from the compile seed and a run counter (Brian2's ``seed()`` is global, so
  this makes results independent of other simulations run in between);
  ``start``/``duration`` windows are applied by running the steps inside and outside the
  window separately with the rates set to zero outside;
- with explicit spike times the results equal the reference backend's to round-off
  (spike trains, traces, weights, ``theta`` and activity counts);
- a neuron of a ``SpikeSourceArray`` may fire at most once per step (Brian2's
  ``SpikeGeneratorGroup``); two spikes rounding to the same step are refused.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any

from neurovpr.errors import ValidationError
from neurovpr.hardware.check import HardwareTarget
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import Backend
from neurovpr.runtime.simulation import Simulation

from .capabilities import CAPABILITIES

#: Brian2's code generation targets.
TARGETS = ("numpy", "cython")


class Brian2Backend(Backend):
    """Declaration of the ``brian2`` backend."""

    name = "brian2"
    description = "Brian2 (numpy or cython code generation) from fixed equation templates"
    requires = ("brian2",)
    version_of = "brian2"
    extra = "brian2"
    capabilities = CAPABILITIES
    options = MappingProxyType({"target": "numpy"})

    def network_problems(self, network: Network) -> list[str]:
        """Zero delays from spike sources: such a spike acts in the step it is stamped at, before Brian2 delivers it."""
        return [
            f"a zero delay from a spike source (projection {proj.name!r}): it acts in the step the source spike is stamped "
            "at, and Brian2 delivers it one step later (zero delays between neurons run)"
            for proj in network.projections.values()
            if proj.zero_delay and network.populations[proj.pre].is_source
        ]

    def _compile(
        self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget | None, **options: Any
    ) -> Simulation:
        target = options["target"]
        if target not in TARGETS:
            raise ValidationError(f"Backend 'brian2': target must be one of {', '.join(map(repr, TARGETS))}, got {target!r}.")
        # Brian2 is imported when a network is compiled, not with the declaration
        from .simulation import Brian2Simulation

        return Brian2Simulation(network, dt=dt, seed=seed, target=target)


BACKEND = Brian2Backend()
