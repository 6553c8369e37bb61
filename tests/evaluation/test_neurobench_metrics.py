"""neurovpr's NeuroBench metrics on small networks whose counts are worked out by hand."""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.errors import ValidationError
from neurovpr.evaluation.neurobench import NeuroBenchCounter, neurobench_block, neurobench_from_activity, static_metrics
from neurovpr.hardware.energy import write_activity


def _net() -> nv.Network:
    net = nv.Network("nb")
    net.add_population("inp", 3, nv.SpikeSourceArray.from_lists([[]] * 3))
    net.add_population("out", 2, nv.IF_curr_exp())
    w = np.array([[1.0, 0.0], [0.5, 0.5], [0.0, 0.0]])  # 3 of 6 weights are zero
    net.connect("inp", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=w))
    return net


def test_static_metrics_count_weights_zeros_and_neuron_values() -> None:
    s = static_metrics(_net())
    assert s["synapses"] == 6 and s["zero_weights"] == 3 and s["connection_sparsity"] == 0.5
    assert s["footprint_weight_bytes"] == 6 * 4 and s["footprint_neuron_bytes"] == 2 * 3 * 4
    assert s["footprint_bytes"] == 48


def test_counter_follows_neurobench_definitions() -> None:
    c = NeuroBenchCounter(_net(), dt=1.0)
    # input neuron 0 fires twice (1 non-zero synapse), 1 once (2), 2 three times (0); out fires once
    v = np.array([[0.0, 0.0], [0.5, 0.0], [0.5, 0.0], [0.25, 0.1]])
    c.add_sample(steps=4, spike_counts={"inp": np.array([2, 1, 3]), "out": np.array([1, 0])}, membrane={"out": v})
    r = c.result()
    assert r["synaptic_operations"] == {"Effective_MACs": 0.0, "Effective_ACs": 4.0, "Dense": 24.0}
    assert r["activation_sparsity"] == (8 - 1) / 8
    assert r["membrane_updates"] == 2 + 1 + 0 + 2  # all on the first step, then the changes
    c.add_sample(steps=4, spike_counts={"inp": np.zeros(3), "out": np.zeros(2)})
    r = c.result()
    assert r["membrane_updates"] is None and r["synaptic_operations"]["Effective_ACs"] == 2.0 and r["samples"] == 2


def test_counter_reads_a_reference_run() -> None:
    net = _net()
    sim = nv.compile(net, backend="reference", dt=1.0, seed=0)
    sim.record("out", "v")
    sim.run(10.0, inputs={"inp": [[1.0, 3.0], [2.0], []]})
    c = NeuroBenchCounter(net, dt=1.0)
    c.add_run(sim)
    r = c.result()
    assert r["synaptic_operations"]["Effective_ACs"] == 2 * 1 + 1 * 2
    assert r["synaptic_operations"]["Dense"] == 6 * r["steps_per_sample"]
    assert r["membrane_updates"] is not None and 2 <= r["membrane_updates"] <= r["membrane_updates_dense"]


def test_counter_refuses_wrong_shapes() -> None:
    c = NeuroBenchCounter(_net(), dt=1.0)
    with pytest.raises(ValidationError, match="'inp'"):
        c.add_sample(steps=2, spike_counts={"inp": np.zeros(2), "out": np.zeros(2)})
    with pytest.raises(ValidationError, match="steps"):
        c.add_sample(steps=0, spike_counts={"inp": np.zeros(3), "out": np.zeros(2)})
    with pytest.raises(ValidationError, match="membrane of 'out'"):
        c.add_sample(steps=3, spike_counts={"inp": np.ones(3), "out": np.ones(2)}, membrane={"out": np.zeros((2, 2))})
    r = c.result()  # a refused sample leaves nothing behind
    assert r["samples"] == 0 and r["synaptic_operations"]["Effective_ACs"] == 0 and r["membrane_updates"] == 0


def test_block_from_activity_totals() -> None:
    activity = {"steps": 10.0, "synaptic_events": 7.0, "dt_ms": 1.0, "population_spikes": {"inp": 5.0, "out": 4.0}}
    b = neurobench_from_activity(_net(), activity)
    assert b["synaptic_operations"] == {"Effective_MACs": 0.0, "Effective_ACs": 7.0, "Dense": 60.0}
    assert b["activation_sparsity"] == 1 - 4.0 / 20.0 and b["membrane_updates"] is None
    assert b["connection_sparsity"] == 0.5


def test_eval_block_from_a_run_directory(tmp_path) -> None:
    """``eval --json``'s "neurobench" block: from RUN_DIR's activity and network, or the reason."""
    assert neurobench_block(tmp_path) == {"reason": "the run directory has no activity.json"}
    write_activity(tmp_path, {"steps": 20, "neuron_updates": 40, "spikes": 12, "synaptic_events": 14}, 2, dt_ms=1.0,
                   population_spikes={"inp": 10, "out": 2})  # fmt: skip
    assert neurobench_block(tmp_path) == {"reason": "the run directory has no network.h5"}
    nv.save(_net(), tmp_path / "network.h5")
    b = neurobench_block(tmp_path)
    assert b["synaptic_operations"]["Effective_ACs"] == 7.0 and b["synaptic_operations"]["Dense"] == 60.0
    assert b["activation_sparsity"] == 1 - 1.0 / 20.0


_BACKENDS = [
    "reference",
    "nengo",
    pytest.param("brian2", marks=pytest.mark.slow),
    pytest.param("lava", marks=pytest.mark.slow),
]


@pytest.mark.parametrize("backend", _BACKENDS)
def test_counts_are_the_same_on_every_backend(backend: str) -> None:
    """The same run on another backend gives the same NeuroBench counts (worked out for the reference run)."""
    from neurovpr.runtime.registry import discover

    info = discover()[backend]
    if not info.available:
        pytest.skip(f"backend {backend!r} is not usable here: {info.reason}")
    net = nv.Network("nb")
    net.add_population("inp", 3, nv.SpikeSourceArray.from_lists([[]] * 3))
    net.add_population("out", 2, nv.IF_curr_exp())
    net.connect(
        "inp", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=12 * np.array([[1.0, 0.0], [0.5, 0.5], [0.0, 0.0]]))
    )
    sim = nv.compile(net, backend=backend, dt=1.0, seed=0)
    sim.record("out", "v")
    sim.run(30.0, inputs={"inp": [[1.0, 3.0, 9.0, 11.0], [2.0, 10.0, 20.0], [5.0]]})
    c = NeuroBenchCounter(net, dt=1.0)
    c.add_run(sim)
    r = c.result()
    assert r["synaptic_operations"] == {"Effective_MACs": 0.0, "Effective_ACs": 4 * 1 + 3 * 2 + 1 * 0, "Dense": 6 * 30}
    assert r["activation_sparsity"] == 1 - sim.spike_counts("out").sum() / 60 == 0.7
    assert r["membrane_updates"] == 50.0
