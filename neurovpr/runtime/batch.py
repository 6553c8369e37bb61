"""Batched presentation: many independent inputs through one compiled network.

:meth:`neurovpr.Simulation.run_batch` runs each item of a batch for the same duration from
the reset state and returns what every item produced as one :class:`BatchResult`. Item
``k`` gives exactly what this loop gives on the same backend::

    sim.run(duration, inputs=items[k])   # the simulation is at time 0 (just compiled or reset)
    counts_k = sim.spike_counts(pop)     # (and spike_trains, trace of recorded variables)
    sim.reset()

so a backend without a batched engine runs that loop (:func:`run_items`), and a backend
that simulates many items at once (``torch``) overrides the hook
``Simulation._run_batch``. Sources not named by the items keep their activity for every
item; after the batch the simulation is reset and its sources hold the last item's inputs,
as after the loop.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from neurovpr.runtime.simulation import Simulation

__all__ = ["BatchResult", "run_items"]


@dataclass(frozen=True, slots=True, kw_only=True)
class BatchResult:
    """What every item of a batch produced.

    Attributes
    ----------
    counts
        Population name -> ``(n_items, size)`` ``int64`` spike counts per item.
    trains
        Population name -> one ``(times_ms, neuron_indices)`` pair per item (times since the
        item's start); empty unless ``spike_trains=True`` was asked for.
    traces
        ``(population, variable)`` -> ``(n_items, n_steps, n_recorded)`` values of every
        variable recorded with :meth:`~neurovpr.Simulation.record`, sampled at the end of
        each step.
    """

    counts: Mapping[str, np.ndarray]
    trains: Mapping[str, tuple[tuple[np.ndarray, np.ndarray], ...]] = field(default_factory=dict)
    traces: Mapping[tuple[str, str], np.ndarray] = field(default_factory=dict)

    def __len__(self) -> int:
        first = next(iter(self.counts.values()), None)
        return 0 if first is None else int(first.shape[0])


def run_items(
    sim: Simulation,
    n_steps: int,
    items: Sequence[Mapping[str, Any]],
    populations: Sequence[str],
    spike_trains: bool,
    *,
    apply: Callable[[str, Any], None],
    advance: Callable[[int], None],
    tick: Callable[[], None] | None = None,
) -> BatchResult:
    """The batch as a loop of run, read-out and reset (any backend).

    ``items`` hold validated inputs; ``apply`` and ``advance`` are the backend's
    ``_set_input`` and ``_run`` hooks (validation was done once for the whole batch).
    """
    counts = {name: [] for name in populations}
    trains: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {name: [] for name in populations} if spike_trains else {}
    recorded = list(sim._recording)
    traces: dict[tuple[str, str], list[np.ndarray]] = {key: [] for key in recorded}
    for item in items:
        for name, value in item.items():
            apply(name, value)
        advance(n_steps)
        for name in populations:
            counts[name].append(sim.spike_counts(name))
            if spike_trains:
                trains[name].append(sim.spike_trains(name))
        for pop, var in recorded:
            traces[(pop, var)].append(sim.trace(pop, var)[1])
        sim.reset()
        if tick is not None:
            tick()
    return BatchResult(
        counts={name: np.stack(rows).astype(np.int64) for name, rows in counts.items()},
        trains={name: tuple(parts) for name, parts in trains.items()},
        traces={key: np.stack(values) for key, values in traces.items()},
    )
