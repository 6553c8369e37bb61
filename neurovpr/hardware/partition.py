"""Partitioning a network onto a hardware target.

:func:`partition` runs the partitioner of the architecture the hwspec names (found by
:func:`~.architectures.get_architecture`: NengoLoihi's block splitting for ``loihi``,
sPyNNaker's slicing and PACMAN's placement for ``spinnaker``, ...) and adds the checks
common to every target: neuron models, plasticity rules, connectors and delays the chip
cannot host are reported as :class:`~.cores.Violation` objects, never raised. What a
partition is lives in :mod:`.cores`.
"""

from __future__ import annotations

import math

import numpy as np

from neurovpr.ir.connectors import FromListConnector
from neurovpr.ir.network import Network, Projection

from .architectures import get_architecture
from .cores import CoreSlice, Partition, Violation, expand_on_chip
from .hwspec import HwSpec

__all__ = ["CoreSlice", "Violation", "Partition", "partition", "feature_violations", "expand_on_chip"]


def _max_delay_ms(proj: Projection, network: Network, spec: HwSpec, seed: int) -> float:
    """The longest delay of a projection in ms, expanding it only when the spec is random."""
    delay = proj.synapse.delay
    listed = isinstance(proj.connector, FromListConnector) and proj.connector.conn_list.shape[1] == 4
    if not listed:
        if delay is None:
            return spec.timing.time_step_ms
        if isinstance(delay, float):
            return delay
        if isinstance(delay, np.ndarray):
            return float(delay.max())
    conns = expand_on_chip(network, proj, spec, seed)
    return float(conns.delay.max()) if len(conns) else spec.timing.time_step_ms


def feature_violations(network: Network, spec: HwSpec, seed: int = 0) -> list[Violation]:
    """Neuron models, plasticity rules, connectors and delays the target cannot host."""
    out: list[Violation] = []
    feats = spec.features
    for pop in network.populations.values():
        model = type(pop.cell_type).__name__
        if not pop.is_source and model not in feats.neuron_models:
            out.append(
                Violation(
                    limit="neuron model",
                    where=pop.name,
                    value=1,
                    maximum=0,
                    message=(
                        f"Population {pop.name!r}: neuron model {model} is not available on {spec.name} "
                        f"(it hosts {', '.join(feats.neuron_models) or 'none'})."
                    ),
                )
            )
    for proj in network.projections.values():
        rule = type(proj.synapse).__name__
        if proj.plastic and rule not in feats.plasticity:
            out.append(
                Violation(
                    limit="plasticity rule",
                    where=proj.name,
                    value=1,
                    maximum=0,
                    message=(
                        f"Projection {proj.name!r}: plasticity rule {rule} is not available on {spec.name} "
                        f"(it runs {', '.join(feats.plasticity) or 'none'})."
                    ),
                )
            )
        conn = type(proj.connector).__name__
        if conn not in feats.connectors:
            out.append(
                Violation(
                    limit="connector",
                    where=proj.name,
                    value=1,
                    maximum=0,
                    message=f"Projection {proj.name!r}: connector {conn} cannot be mapped to {spec.name}.",
                )
            )
        steps = math.floor(_max_delay_ms(proj, network, spec, seed) / spec.timing.time_step_ms + 0.5)
        if steps > spec.timing.max_delay_steps:
            out.append(
                Violation(
                    limit="delay",
                    where=proj.name,
                    value=steps,
                    maximum=spec.timing.max_delay_steps,
                    message=(
                        f"Projection {proj.name!r}: delay of {steps} steps exceeds the maximum of "
                        f"{spec.timing.max_delay_steps} steps on {spec.name} (step {spec.timing.time_step_ms:g} ms)."
                    ),
                )
            )
    return out


def partition(network: Network, spec: HwSpec, *, seed: int = 0) -> Partition:
    """Split ``network`` onto the target described by ``spec``.

    Parameters
    ----------
    network
        The network to place.
    spec
        The hardware target.
    seed
        Seed for random connectors without their own seed (as in ``nv.compile``).

    Returns
    -------
    Partition
        Per-core slices, the chip count and every violated limit.
    """
    arch = get_architecture(spec.partitioner)
    spec, notes = arch.runs_at(spec)
    result = arch.partition(network, spec, seed=seed)
    # The vendor rules bound delays exactly per projection where they can (SpiNNaker), on the step they run:
    # keep only one delay violation per projection.
    exact = {v.where for v in result.violations if v.limit == "delay"}
    extra = [v for v in feature_violations(network, spec, seed) if not (v.limit == "delay" and v.where in exact)]
    return Partition(
        hardware=result.hardware,
        cores=result.cores,
        chips=result.chips,
        violations=tuple(extra) + result.violations,
        host=result.host,
        notes=notes + result.notes,
    )
