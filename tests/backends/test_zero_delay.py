"""Zero-delay synapses (``delay=0``, docs/semantics.md): accepted by the IR, run where declared, refused by name elsewhere."""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.backendkit.timing import delay_steps

DT = 0.1
POST = {"cm": 1.0, "tau_m": 10.0, "tau_syn_E": 1.0, "tau_refrac": 5.0, "v_rest": -65.0, "v_reset": -65.0, "v_thresh": -50.0}


def _source_to_post(delay: float) -> nv.Network:
    net = nv.Network("zero_from_source")
    net.add_population("src", 1, nv.SpikeSourceArray(spike_times=[5.0, 30.0]))
    net.add_population("post", 1, nv.IF_curr_exp(**POST))
    net.connect("src", "post", nv.OneToOneConnector(), nv.StaticSynapse(weight=100.0, delay=delay))
    return net


def _post_times(backend: str, delay: float) -> np.ndarray:
    sim = nv.compile(_source_to_post(delay), backend=backend, dt=DT, seed=0)
    sim.run(60.0)
    return sim.spike_trains("post")[0]


def test_the_ir_takes_zero_and_refuses_negative_or_sub_step_delays() -> None:
    assert nv.StaticSynapse(weight=1.0, delay=0.0).delay == 0.0
    assert delay_steps(np.array([0.0, 0.1, 0.25, 1.0]), DT).tolist() == [0, 1, 2, 10]
    with pytest.raises(nv.ValidationError, match=r"StaticSynapse.delay must be >= 0 ms, got -0.1"):
        nv.StaticSynapse(weight=1.0, delay=-0.1)
    with pytest.raises(nv.ValidationError, match=r"delay 0.05 ms is shorter than the time step 0.1 ms \(and not 0\)"):
        nv.compile(_source_to_post(0.05), dt=DT, seed=0)
    listed = nv.FromListConnector([(0, 0, 1.0, 0.0)])
    net = nv.Network("listed")
    net.add_population("a", 1, nv.IF_curr_exp())
    net.add_population("b", 1, nv.IF_curr_exp())
    net.connect("a", "b", listed, nv.StaticSynapse(weight=1.0))
    assert net.projections["a->b"].zero_delay and not _source_to_post(0.1).projections["src->post"].zero_delay


@pytest.mark.parametrize("backend", ["reference", "torch"])
def test_a_source_spike_with_zero_delay_acts_in_the_step_it_is_stamped(backend: str) -> None:
    """A source spike at ``t`` through delay 0 arrives at ``t``: every post spike one step before delay ``dt``'s."""
    if nv.get_backend(backend).unavailable_reason() is not None:
        pytest.skip(f"backend {backend!r} is not installed")
    zero, one = _post_times(backend, 0.0), _post_times(backend, DT)
    assert zero.size == one.size == 2
    np.testing.assert_allclose(one - zero, DT, rtol=0, atol=1e-9)


def test_backends_without_zero_delays_refuse_them_by_name() -> None:
    net = _source_to_post(0.0)
    assert nv.get_backend("nengo").unsupported_features(net) == [
        "a zero delay (projection 'src->post'): its synaptic delays start at one time step (a zero delay is not built)"
    ]
    with pytest.raises(nv.UnsupportedFeatureError, match=r"projection 'src->post': it has a zero delay"):
        nv.compile(net, backend="reference", dt=1.0, seed=0, hardware="kapoho-bay")
    if nv.get_backend("brian2").unavailable_reason() is None:
        with pytest.raises(nv.UnsupportedFeatureError, match=r"a zero delay from a spike source"):
            nv.compile(net, backend="brian2", dt=DT, seed=0)
