"""``hardware="xylo"`` on the reference backend reproduces XyloSim spike for spike.

Random networks within Xylo Audio 2's limits (integer weights on both synapses, bit-shift
decays, integer thresholds, recurrent hidden neurons, a bias) run on the reference backend
in Xylo's integers and on XyloSim (``XyloSim.from_specification``, Rockpool's module around
the C++ bit-accurate simulator ``xylosim.v2``) with the same integers and the same input
raster; every hidden and output spike of every step must agree.
"""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.errors import BackendUnavailableError

try:
    from neurovpr.backends.xylo.compat import import_xylo

    XYLO = import_xylo()
except BackendUnavailableError as exc:  # pragma: no cover - depends on the install
    pytest.skip(f"Rockpool/XyloSim not importable: {exc}", allow_module_level=True)

STEPS = 200


def _random_case(seed: int):
    rng = np.random.default_rng(seed)
    n_in, n_hid, n_out = int(rng.integers(2, 17)), int(rng.integers(5, 60)), int(rng.integers(1, 9))
    w_in = rng.integers(-60, 100, size=(n_in, n_hid, 2)) * (rng.random((n_in, n_hid, 2)) < 0.5)
    w_in[:, :, 1] = -np.abs(w_in[:, :, 1])  # synapse 2: inhibitory projections
    w_rec = rng.integers(-40, 40, size=(n_hid, n_hid)) * (rng.random((n_hid, n_hid)) < 0.2)
    w_out = rng.integers(-50, 90, size=(n_hid, n_out)) * (rng.random((n_hid, n_out)) < 0.6)
    p = {
        "dash_mem": int(rng.integers(1, 6)), "dash_syn": int(rng.integers(1, 5)), "dash_syn_2": int(rng.integers(1, 5)),
        "dash_mem_out": int(rng.integers(1, 6)), "dash_syn_out": int(rng.integers(1, 5)),
        "vth": int(rng.integers(20, 150)), "vth_out": int(rng.integers(20, 150)), "bias": int(rng.integers(-3, 4)),
    }
    raster = (rng.random((STEPS, n_in)) < 0.3).astype(int)
    return w_in, w_rec, w_out, p, raster


def _neurovpr(w_in, w_rec, w_out, p, raster):
    n_in, n_hid, _ = w_in.shape
    n_out = w_out.shape[1]
    times = [list(np.flatnonzero(raster[:, i]).astype(float)) for i in range(n_in)]
    net = nv.Network("xylo_random")
    net.add_population("in", n_in, nv.SpikeSourceArray(spike_times=times))
    hid = nv.IF_curr_exp(tau_m=2.0 ** p["dash_mem"], tau_syn_E=2.0 ** p["dash_syn"], tau_syn_I=2.0 ** p["dash_syn_2"],
                         v_rest=0.0, v_reset=0.0, v_thresh=float(p["vth"]), i_offset=float(p["bias"]), tau_refrac=0.0)
    out = nv.IF_curr_exp(tau_m=2.0 ** p["dash_mem_out"], tau_syn_E=2.0 ** p["dash_syn_out"],
                         tau_syn_I=2.0 ** p["dash_syn_out"], v_rest=0.0, v_reset=0.0, v_thresh=float(p["vth_out"]),
                         tau_refrac=0.0)
    net.add_population("hidden", n_hid, hid)
    net.add_population("out", n_out, out)
    net.connect("in", "hidden", nv.AllToAllConnector(), nv.StaticSynapse(weight=w_in[:, :, 0].astype(float)))
    net.connect("in", "hidden", nv.AllToAllConnector(), nv.StaticSynapse(weight=-w_in[:, :, 1].astype(float)),
                receptor_type="inhibitory", name="in_inh")
    net.connect("hidden", "hidden", nv.AllToAllConnector(allow_self_connections=True),
                nv.StaticSynapse(weight=w_rec.astype(float)), name="rec")
    net.connect("hidden", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=w_out.astype(float)))
    sim = nv.compile(net, backend="reference", hardware="xylo", dt=1.0, seed=0)
    sim.run(STEPS * 1.0)
    rasters = {}
    for name, size in (("hidden", n_hid), ("out", n_out)):
        times, idx = sim.spike_trains(name)
        r = np.zeros((STEPS, size), dtype=int)
        np.add.at(r, (np.round(times).astype(int) - 1, idx), 1)  # a spike of step j is recorded at (j + 1) dt
        rasters[name] = r
    return rasters


def _xylosim(w_in, w_rec, w_out, p, raster):
    n_hid, n_out = w_in.shape[1], w_out.shape[1]
    rec = np.zeros((n_hid, n_hid, 2), dtype=int)
    rec[:, :, 0] = w_rec
    mod = XYLO.sim.XyloSim.from_specification(
        weights_in=w_in, weights_rec=rec, weights_out=w_out,
        dash_mem=np.full(n_hid, p["dash_mem"]), dash_syn=np.full(n_hid, p["dash_syn"]),
        dash_syn_2=np.full(n_hid, p["dash_syn_2"]), dash_mem_out=np.full(n_out, p["dash_mem_out"]),
        dash_syn_out=np.full(n_out, p["dash_syn_out"]), threshold=np.full(n_hid, p["vth"]),
        threshold_out=np.full(n_out, p["vth_out"]), bias=np.full(n_hid, p["bias"]), bias_out=np.zeros(n_out, int),
        dt=1e-3,
    )
    out, _, record = mod(raster, record=True)
    return {"hidden": np.asarray(record["Spikes"]).astype(int), "out": np.asarray(out).astype(int)}


def test_reference_xylo_reproduces_xylosim_spike_for_spike():
    """12 random networks: every hidden and output spike count of every step equal to XyloSim's."""
    active = 0
    for seed in range(12):
        case = _random_case(seed)
        mine, theirs = _neurovpr(*case), _xylosim(*case)
        active += int(theirs["hidden"].sum() > 0 and theirs["out"].sum() > 0)
        np.testing.assert_array_equal(mine["hidden"], theirs["hidden"], err_msg=f"seed {seed}: hidden spikes")
        np.testing.assert_array_equal(mine["out"], theirs["out"], err_msg=f"seed {seed}: output spikes")
    assert active >= 10  # the networks spike (several up to XyloSim's 31 spikes per step)


def test_xylo_emulation_refuses_what_xylo_cannot_hold():
    net = nv.Network("bad_tau")
    net.add_population("in", 2, nv.SpikeSourceArray(spike_times=[]))
    net.add_population("h", 3, nv.IF_curr_exp(tau_m=1e6, v_rest=0.0, v_thresh=10.0))
    net.add_population("o", 1, nv.IF_curr_exp(v_rest=0.0, v_thresh=10.0))
    net.connect("in", "h", nv.AllToAllConnector(), nv.StaticSynapse(weight=3.0))
    net.connect("h", "o", nv.AllToAllConnector(), nv.StaticSynapse(weight=3.0))
    with pytest.raises(nv.ValidationError, match=r"tau_m: log2\(tau / dt 1 ms\) rounds to 20\.\.20, outside Xylo's 4-bit"):
        nv.compile(net, backend="reference", hardware="xylo", dt=1.0, seed=0).run(1.0)
