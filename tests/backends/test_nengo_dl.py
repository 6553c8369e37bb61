"""The ``nengo-dl`` backend: NengoDL runs the ``nengo`` backend's network with the same spikes; its refusal without NengoDL."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("nengo")

import neurovpr as nv
from neurovpr.backends.nengo_dl import NENGO_DL
from neurovpr.runtime.registry import declared_names

REASON = NENGO_DL.unavailable_reason()
needs_nengo_dl = pytest.mark.skipif(REASON is not None, reason=f"nengo-dl is not available: {REASON}")


def _network() -> nv.Network:
    """Poisson inputs onto two LIF layers: delays of one and two steps, both receptors, a convolution."""
    rng = np.random.default_rng(0)
    net = nv.Network("small")
    net.add_population("src", 32, nv.SpikeSourcePoisson(rate=150.0))
    net.add_population("a", 8, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=2.0, tau_refrac=2.0))
    net.add_population("b", 4, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=2.0, tau_syn_I=3.0))
    conv = nv.ConvolutionConnector(input_shape=(2, 4, 4), kernel_shape=(3, 3), out_channels=2)
    net.connect("src", "a", conv, nv.StaticSynapse(weight=rng.uniform(0.0, 1.5, conv.weight_shape), delay=1.0))
    net.connect("a", "b", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.uniform(0.0, 3.0, (8, 4)), delay=2.0))
    net.connect(
        "src", "b", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.uniform(0.0, 0.5, (32, 4))), receptor_type="inhibitory"
    )
    return net


def _counts(backend: str) -> list[np.ndarray]:
    sim = nv.compile(_network(), backend=backend, dt=0.5, seed=3)
    out = []
    for duration in (100.0, 50.0):  # a run continues the previous one
        sim.run(duration)
        out += [sim.spike_counts("a").copy(), sim.spike_counts("b").copy()]
    sim.reset()
    sim.run(100.0)
    out += [sim.spike_counts("a").copy(), sim.spike_counts("b").copy()]
    getattr(sim, "close", lambda: None)()
    return out


def test_declared_with_the_nengo_capabilities() -> None:
    from neurovpr.backends.nengo import NENGO

    assert "nengo-dl" in declared_names()
    assert NENGO_DL.capabilities.cell_types == NENGO.capabilities.cell_types
    assert set(NENGO_DL.capabilities.unsupported) == set(NENGO.capabilities.unsupported)


@needs_nengo_dl
def test_spike_counts_equal_the_nengo_backend() -> None:
    """Same network, seed and source spikes: NengoDL (float64) gives Nengo's spike counts, across runs and a reset."""
    expected, got = _counts("nengo"), _counts("nengo-dl")
    assert sum(int(c.sum()) for c in expected) > 0
    for e, g in zip(expected, got, strict=True):
        np.testing.assert_array_equal(g, e)


_WITHOUT_NENGO_DL = """
import json, sys
sys.modules["nengo_dl"] = None  # as if NengoDL were not installed
import neurovpr as nv
from neurovpr.runtime.registry import backend_info
info = backend_info("nengo-dl")
net = nv.Network("one")
net.add_population("lif", 1, nv.IF_curr_exp(i_offset=1.0))
try:
    nv.compile(net, backend="nengo-dl", dt=1.0, seed=0)
    error = None
except nv.NeurovprError as exc:
    error = f"{type(exc).__name__}: {exc}"
print(json.dumps({"available": info.available, "reason": info.reason, "error": error}))
"""


def test_refuses_in_one_sentence_without_nengo_dl() -> None:
    """Without NengoDL the backend is listed as unavailable, and compiling for it is refused, naming the install script."""
    proc = subprocess.run([sys.executable, "-c", _WITHOUT_NENGO_DL], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.splitlines()[-1])
    assert out["available"] is False and "install_nengo_dl.sh" in out["reason"]
    assert out["error"].startswith("BackendUnavailableError") and "nengo-dl" in out["error"]
    assert "install_nengo_dl.sh" in out["error"] and out["error"].count(". ") == 0, out["error"]
