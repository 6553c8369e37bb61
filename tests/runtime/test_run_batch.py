"""Simulation.run_batch: independent items from the reset state, equal to the item-by-item loop."""

from __future__ import annotations

import numpy as np
import pytest
from batch_networks import array_items, conv_current, diehl_cook_like

import neurovpr as nv


def _loop(sim: nv.Simulation, duration: float, items: list[dict], pops: list[str]) -> tuple[dict, list]:
    counts: dict[str, list[np.ndarray]] = {p: [] for p in pops}
    trains = []
    for item in items:
        sim.run(duration, inputs=item)
        for p in pops:
            counts[p].append(sim.spike_counts(p))
        trains.append(sim.spike_trains(pops[0]))
        sim.reset()
    return {p: np.stack(v) for p, v in counts.items()}, trains


def test_run_batch_equals_the_loop_on_reference_with_poisson_input() -> None:
    rng = np.random.default_rng(0)
    items = [{"pixels": rng.uniform(0.0, 120.0, 30)} for _ in range(5)]
    pops = ["exc", "inh"]
    expected, trains = _loop(nv.compile(diehl_cook_like(), backend="reference", dt=0.1, seed=7), 60.0, items, pops)
    sim = nv.compile(diehl_cook_like(), backend="reference", dt=0.1, seed=7)
    result = sim.run_batch(60.0, items, populations=pops, spike_trains=True)
    assert len(result) == 5
    assert expected["exc"].sum() > 0 and expected["inh"].sum() > 0
    for p in pops:
        np.testing.assert_array_equal(result.counts[p], expected[p])
    for k in range(5):
        np.testing.assert_array_equal(result.trains["exc"][k][0], trains[k][0])
        np.testing.assert_array_equal(result.trains["exc"][k][1], trains[k][1])
    assert sim.time == 0.0


def test_run_batch_returns_recorded_traces_per_item() -> None:
    items = [{"image": spikes} for spikes in array_items(3, 72, duration=30.0, rate_hz=150.0, seed=1)]
    sim = nv.compile(conv_current(), backend="reference", dt=0.1, seed=2)
    sim.record("places", "v", [0, 2])
    result = sim.run_batch(30.0, items)
    assert result.traces[("places", "v")].shape == (3, 300, 2)
    loop = nv.compile(conv_current(), backend="reference", dt=0.1, seed=2)
    loop.record("places", "v", [0, 2])
    for k, item in enumerate(items):
        loop.run(30.0, inputs=item)
        np.testing.assert_array_equal(result.traces[("places", "v")][k], loop.trace("places", "v")[1])
        np.testing.assert_array_equal(result.counts["maps"][k], loop.spike_counts("maps"))
        loop.reset()


def test_run_batch_refuses_bad_batches() -> None:
    sim = nv.compile(diehl_cook_like(), backend="reference", dt=0.1, seed=1)
    with pytest.raises(nv.ValidationError, match="non-empty sequence"):
        sim.run_batch(10.0, [])
    with pytest.raises(nv.ValidationError, match="non-empty sequence"):
        sim.run_batch(10.0, {"pixels": 5.0})  # type: ignore[arg-type]
    with pytest.raises(nv.ValidationError, match="same sources"):
        sim.run_batch(10.0, [{"pixels": 5.0}, {}])
    with pytest.raises(nv.ValidationError, match="whole number"):
        sim.run_batch(10.05, [{"pixels": 5.0}])
    with pytest.raises(nv.ValidationError, match="does not exist"):
        sim.run_batch(10.0, [{"pixels": 5.0}], populations=["nope"])
    sim.run(1.0)
    with pytest.raises(nv.SimulationError, match="call reset"):
        sim.run_batch(10.0, [{"pixels": 5.0}])
