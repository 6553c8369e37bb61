"""Forward-Euler cells (``integration="euler"``): where they run, and the one-sentence refusals elsewhere.

What the steps compute is the conformance suite's (``neurovpr/conformance/test_integration.py``);
the torch backend's spikes equal the reference's in ``tests/backends/test_torch.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

import neurovpr as nv


def _network(cell: nv.IF_cond_exp | nv.IF_cond_exp_adaptive) -> nv.Network:
    net = nv.Network("euler")
    net.add_population("src", 2, nv.SpikeSourceArray.from_lists([[1.0], [2.0]]))
    net.add_population("cells", 2, cell)
    net.connect("src", "cells", nv.OneToOneConnector(), nv.StaticSynapse(weight=0.5, delay=1.0))
    return net


def test_capabilities_say_which_backends_run_euler_steps() -> None:
    runs = {name for name in ("reference", "torch", "brian2") if nv.get_backend(name).capabilities.euler_integration}
    assert runs == {"reference", "torch", "brian2"}
    for name in ("pynn", "pynn:brian2", "spinnaker"):
        caps = nv.get_backend(name).capabilities
        assert not caps.euler_integration and caps.reasons["euler integration"].strip()


def test_a_backend_without_euler_steps_refuses_them_in_one_sentence() -> None:
    with pytest.raises(nv.UnsupportedFeatureError) as info:
        nv.compile(_network(nv.IF_cond_exp(integration="euler")), backend="spinnaker", dt=0.1)
    message = str(info.value)
    assert "forward-Euler integration (IF_cond_exp(integration='euler'), population 'cells')" in message
    assert "fixed-point form" in message and message.count(". ") == 0, message


def test_the_reference_backend_refuses_euler_cells_on_chip_arithmetic() -> None:
    refusal = r"cannot emulate hardware .* population 'cells': its cells take forward-Euler"
    with pytest.raises(nv.UnsupportedFeatureError, match=refusal):
        nv.compile(_network(nv.IF_cond_exp(integration="euler")), backend="reference", dt=1.0, hardware="spinn5")


@pytest.mark.parametrize("backend", ["reference", "brian2"])
def test_a_step_not_below_every_time_constant_is_refused(backend: str) -> None:
    cell = nv.IF_cond_exp(tau_syn_E=0.5, integration="euler")
    refusal = r"IF_cond_exp\(integration='euler'\)\.tau_syn_E = 0\.5 ms needs a time step below it, got dt = 0\.5 ms"
    with pytest.raises(nv.ValidationError, match=refusal):
        nv.compile(_network(cell), backend=backend, dt=0.5)
    nv.compile(_network(cell.replace(integration="exact")), backend=backend, dt=0.5)


def test_euler_and_exact_steps_differ_and_exact_is_unchanged() -> None:
    """The same network with each integration: exact steps are what they were (the default), Euler ones differ."""
    cell = nv.IF_cond_exp_adaptive(tau_m=5.0, tau_syn_E=1.0, v_thresh=-20.0)
    traces = {}
    for integration in (None, "exact", "euler"):
        use = cell if integration is None else cell.replace(integration=integration)
        sim = nv.compile(_network(use), backend="reference", dt=0.1)
        sim.record("cells", "v")
        sim.run(20.0)
        traces[integration] = sim.trace("cells", "v")[1]
    np.testing.assert_array_equal(traces[None], traces["exact"])
    assert np.max(np.abs(traces["euler"] - traces["exact"])) > 1e-3
