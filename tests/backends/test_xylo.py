"""The ``xylo`` backend (XyloSim) against the reference backend's Xylo arithmetic, its refusals and its listing."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.errors import BackendUnavailableError
from neurovpr.runtime.registry import backend_info

try:
    from neurovpr.backends.xylo.compat import import_xylo

    import_xylo()
except BackendUnavailableError as exc:  # pragma: no cover - depends on the install
    pytest.skip(f"Rockpool/XyloSim not importable: {exc}", allow_module_level=True)

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "hardware"))
from synsense_oracles import xylo_chain


def _network(seed: int) -> nv.Network:
    rng = np.random.default_rng(seed)
    net = xylo_chain(12, [40, 20], 6, recurrent=(0,), w_max=60, seed=seed)
    times = [list(np.flatnonzero(rng.random(150) < 0.3).astype(float)) for _ in range(12)]
    return _with_inputs(net, times)


def _with_inputs(net: nv.Network, times) -> nv.Network:
    out = nv.Network(net.name)
    for name, pop in net.populations.items():
        out.add_population(name, pop.size, nv.SpikeSourceArray(spike_times=times) if pop.is_source else pop.cell_type)
    for proj in net.projections.values():
        out.connect(proj.pre, proj.post, proj.connector, proj.synapse, receptor_type=proj.receptor_type, name=proj.name)
    return out


@pytest.mark.parametrize("seed", [0, 1])
def test_xylo_backend_equals_reference_xylo_arithmetic(seed):
    net = _network(seed)
    runs = {}
    for backend, hw in (("xylo", None), ("reference", "xylo")):
        sim = nv.compile(net, backend=backend, hardware=hw, dt=1.0, seed=0)
        sim.record("h0", "v")
        sim.run(80.0)
        sim.run(70.0)  # XyloSim keeps its state between runs
        runs[backend] = ({p: sim.spike_trains(p) for p in ("h0", "h1", "out")}, sim.trace("h0", "v")[1])
    assert sum(t[0].size for t in runs["xylo"][0].values()) > 50
    for pop in ("h0", "h1", "out"):
        np.testing.assert_array_equal(runs["xylo"][0][pop][0], runs["reference"][0][pop][0])
        np.testing.assert_array_equal(runs["xylo"][0][pop][1], runs["reference"][0][pop][1])
    np.testing.assert_array_equal(runs["xylo"][1], runs["reference"][1])


def test_xylo_backend_refuses_a_network_that_does_not_fit_naming_the_limit():
    # an unsupported feature, so that `neurovpr compare` reports a refused row
    with pytest.raises(nv.UnsupportedFeatureError, match=r"Backend 'xylo' cannot run it: .*does not fit xylo .*17 input "):
        nv.compile(xylo_chain(17, [10], 2), backend="xylo", dt=1.0, seed=0)


def test_xylo_backend_is_listed_with_its_capabilities(capsys):
    from neurovpr.cli import main as cli

    info = backend_info("xylo")
    assert info.available and info.version == "3.1.0"
    caps = info.backend.capabilities
    assert caps.arithmetic == frozenset({"xylo"}) and "SpikeSourcePoisson" not in caps.cell_types
    assert "chip units" in caps.unsupported["psp_curr"]  # conformance cases it cannot run, each with the reason
    assert cli.main(["backends", "--json"]) == 0
    text = capsys.readouterr().out
    assert '"xylo"' in text and "XyloSim" in text
