"""Number-format emulation of ``spinn5`` (``nv.compile(..., backend="reference", hardware="spinn5")``).

The s16.15 arithmetic on its own, sPyNNaker's host conversions, and the firing rate under a
constant current against the closed form within the fixed-point error.
"""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.hardware import load_hwspec

kf = pytest.importorskip("neurovpr.backends.reference.kernels_fixed")
kl = pytest.importorskip("neurovpr.backends.reference.kernel_layout")


# -- SpiNNaker (spinn5) -----------------------------------------------------------------
def test_s1615_arithmetic():
    one = 1 << 15
    assert kf.mul_round(3 * one // 2, one // 2, 15) == 3 * one // 4  # 1.5 * 0.5
    assert kf.mul_round(1, one // 2, 15) == 1  # 2**-15 * 0.5 rounds half up
    assert kf.mul_round(-1, one // 2, 15) == 0  # -2**-16 rounds half up, toward zero
    assert kf.mul_round(-3, one // 2, 15) == -1  # -1.5 LSB -> -1
    assert kf.mul_round(2**31 - 1, 2 * one, 15) == 2**31 - 1  # saturates
    assert kf.mul_round(-(2**31), -(2**31), 15) == 2**31 - 1  # the -1 x -1 special case of stdfix
    assert kf.mul_trunc(-1, one // 2, 15) == -1  # truncation rounds toward minus infinity
    assert kf.decay_u032(one, 2**31) == one // 2
    assert kf.decay_u032(-1, 2**31) == -1  # arithmetic shift
    assert kf.wrap32(2**31) == -(2**31) and kf.wrap32(-(2**31) - 1) == 2**31 - 1
    np.testing.assert_array_equal(kf.div_fixed(np.array([one, -one, 7]), np.array([3 * one, 3 * one, 2]), 15),
                                  [10922, -10922, 114688])  # fmt: skip
    np.testing.assert_array_equal(kf.ceil_fixed(np.array([one, one + 1, -one - 1]), 15), [1, 2, -1])
    assert int(kf.exp_fixed(np.array([0]), 15, 32)[0]) == 2**32 - 1  # u0.32 cannot hold 1.0


def test_spinnaker_host_conversions_match_spynnaker():
    ds = pytest.importorskip("spinn_front_end_common.interface.ds")
    rng = np.random.default_rng(7)
    values = rng.uniform(-1000, 1000, 500)
    ours = kf.to_fixed(values, 15)
    theirs = [ds.DataType.S1615.encode_as_int(float(v)) for v in values]
    np.testing.assert_array_equal(ours, theirs)
    pv = pytest.importorskip("spynnaker.pyNN.models.neuron.population_vertex")
    spec = load_hwspec("spinn5")
    for shift in range(0, 8):
        expected = pv.PopulationVertex._PopulationVertex__get_weight_scale(shift)  # sPyNNaker's own scale
        assert 2.0 ** (-(shift + spec.formats.weight_exponent_offset)) == expected


def test_ring_buffer_shift_and_saturation():
    """The shift covers the largest summed weight; a ring-buffer sum saturates at 16 bits."""
    net = nv.Network("shift")
    net.add_population("src", 10, nv.SpikeSourceArray.from_lists([[5.0]] * 10))
    net.add_population("n", 2, nv.IF_curr_exp())
    net.connect("src", "n", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.75))  # summed: 7.5 nA -> shift 3
    sim = nv.compile(net, backend="reference", dt=1.0, seed=0, hardware="spinn5")
    assert sim.quantised.blocks[-1]["shift_excitatory"] == 3
    assert np.all(sim.quantised.weights["src->n"]["value"] == round(0.75 * 2**12))
    sim.set_weights("src->n", np.full(20, 0.5))  # summed 5 nA: still shift 3, weights requantised
    assert np.all(sim.quantised.weights["src->n"]["value"] == 2**11)
    np.testing.assert_array_equal(sim.weights("src->n"), 0.5)
    sim.normalise_weights("src->n", 2.5)  # each neuron's 10 weights to sum 2.5 nA: 0.25, requantised (shift 2)
    np.testing.assert_array_equal(sim.weights("src->n"), 0.25)
    assert sim.quantised.blocks[-1]["shift_excitatory"] == 2
    assert np.all(sim.quantised.weights["src->n"]["value"] == round(0.25 * 2**13))
    acc = np.zeros((2, 1), dtype=np.int64)
    record = kl.SpikeRecord(np.zeros(1, np.bool_), np.zeros(4, np.int64), np.zeros(4, np.int64), np.zeros(1, np.int64))
    syn = kf.FixedSynapses(np.array([0, 1]), np.array([0]), np.array([40000]), np.array([1]))
    for _ in range(2):
        kf._emit(0, 0, np.zeros(1, np.int64), np.zeros(5, np.int64), record, syn, acc, 2**16 - 1)
    assert acc[1, 0] == 2**16 - 1


def _closed_form_spikes(i_offset, tau_m, cm, v_rest, v_thresh, v_reset, refrac_steps, n_steps):
    """Spike count and smallest threshold margin of the exact constant-current LIF on the 1 ms grid."""
    e = np.exp(-1.0 / tau_m)
    alpha = v_rest + i_offset * tau_m / cm
    v, hold, count, margin = v_rest, 0, 0, np.inf
    for _ in range(n_steps):
        if hold > 0:
            hold -= 1
        else:
            v = alpha - e * (alpha - v)
        margin = min(margin, abs(v - v_thresh))
        if v >= v_thresh:
            count, v, hold = count + 1, v_reset, refrac_steps
    return count, margin


def test_spinnaker_rate_under_constant_current_matches_closed_form():
    currents = np.array([0.76, 0.8, 0.9, 1.0, 1.2, 1.5, 2.0, 3.0, 5.0])
    net = nv.Network("rate")
    net.add_population("n", currents.size, nv.IF_curr_exp(tau_m=20.0, tau_refrac=2.0, i_offset=currents))
    sim = nv.compile(net, backend="reference", dt=1.0, seed=0, hardware="spinn5")
    sim.record("n", "v")
    sim.run(2000.0)
    counts = sim.spike_counts("n")
    # per-step error: exp_TC and R to 2**-16 relative, two roundings of 2**-16 mV; contracted by 1 - exp(-1/20)
    bound = (15.0 * 2**-16 + 5.0 * 20 * 2**-16 + 2 * 2**-16) / (1 - np.exp(-1 / 20))
    for k, i_off in enumerate(currents):
        expected, margin = _closed_form_spikes(i_off, 20.0, 1.0, -65.0, -50.0, -65.0, 2, 2000)
        if margin > bound:
            assert counts[k] == expected, (i_off, counts[k], expected)
        else:
            assert abs(int(counts[k]) - expected) <= 1, (i_off, counts[k], expected)
    v = sim.trace("n", "v")[1]
    assert np.all(v <= -50.0 + 2**-15) and np.all(v >= -65.0)


def test_spinnaker_models_run_and_differ_from_float_only_by_formats():
    """IF_curr_exp_ca2_adaptive and IF_cond_exp run; the synaptic input carries sPyNNaker's init factor."""
    net = nv.Network("models")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[5.0]]))
    net.add_population("ca", 1, nv.IF_curr_exp_ca2_adaptive(i_offset=2.0))
    net.add_population("g", 1, nv.IF_cond_exp())
    net.connect("src", "g", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.05))
    fx = nv.compile(net, backend="reference", dt=1.0, seed=0, hardware="spinn5")
    fl = nv.compile(net, backend="reference", dt=1.0, seed=0)
    for sim in (fx, fl):
        sim.record("g", "gsyn_exc")
        sim.record("ca", "i_ca2")
        sim.run(500.0)
    g_fx, g_fl = fx.trace("g", "gsyn_exc")[1][:, 0], fl.trace("g", "gsyn_exc")[1][:, 0]
    init = 5.0 * (1 - np.exp(-1 / 5.0))  # (tau / dt)(1 - exp(-dt / tau)), sPyNNaker's exponential-synapse scaling
    assert g_fx[6] == pytest.approx(g_fl[6] * init, rel=2e-3)
    assert 0 < fx.spike_counts("ca")[0] < fl.spike_counts("ca")[0] * 1.2
    assert fx.trace("ca", "i_ca2")[1].max() > 0
