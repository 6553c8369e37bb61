"""The ``speck`` backend (Sinabs's DYNAP-CNN layers): equal to the reference backend's Speck arithmetic, its
refusals naming the limit, its listing, and ``neurovpr compare`` rows off- and on-chip."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.apps import compare
from neurovpr.data.generic import write_generic
from neurovpr.data.synthetic import synthetic_traverse
from neurovpr.errors import BackendUnavailableError
from neurovpr.runtime.registry import backend_info

try:
    from neurovpr.backends.speck.compat import import_dynapcnn

    import_dynapcnn()
except BackendUnavailableError as exc:  # pragma: no cover - depends on the install
    pytest.skip(f"Sinabs not importable: {exc}", allow_module_level=True)

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "cli"))
from test_compare import TemplatePlugin  # compare's own test model: a real ModelPlugin

IAF = {"tau_m": nv.NO_LEAK, "tau_syn_E": 1.0, "tau_syn_I": 1.0, "cm": 1.0, "v_rest": 0.0, "v_reset": 0.0}


def _convnet(seed: int, *, tau_m: float = nv.NO_LEAK, layers: int = 1) -> nv.Network:
    """Input (2, 8, 8) -> ``layers`` 3x3 convolutions (4 channels, one of them inhibitory) -> 10 dense neurons with a bias."""
    rng = np.random.default_rng(seed)
    times = [list(np.flatnonzero(rng.random(60) < 0.2).astype(float)) for _ in range(128)]
    net = nv.Network(f"speck_{seed}")
    net.add_population("input", 128, nv.SpikeSourceArray(spike_times=times))
    prev, shape = "input", (2, 8, 8)
    for k in range(layers):
        conv = nv.ConvolutionConnector(input_shape=shape, kernel_shape=(3, 3), out_channels=4, padding=(1, 1))
        name = f"conv{k}"
        net.add_population(name, 256, nv.IF_curr_exp(**{**IAF, "tau_m": tau_m}, v_thresh=1.0))
        inh = k == 1
        net.connect(
            prev,
            name,
            conv,
            nv.StaticSynapse(
                weight=np.abs(rng.normal(0.1, 0.3, conv.weight_shape)) if inh else rng.normal(0.1, 0.3, conv.weight_shape)
            ),
            receptor_type="inhibitory" if inh else "excitatory",
        )
        prev, shape = name, conv.output_shape
    net.add_population("dense", 10, nv.IF_curr_exp(**IAF, v_thresh=2.0, i_offset=0.05))
    net.connect(prev, "dense", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.normal(0, 0.3, (256, 10))))
    return net


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_speck_backend_equals_reference_speck_arithmetic(seed):
    net = _convnet(seed, layers=1 + seed % 2)
    runs = {}
    for backend, hw in (("speck", None), ("reference", "speck")):
        sim = nv.compile(net, backend=backend, hardware=hw, dt=1.0, seed=0)
        sim.run(25.0)
        sim.run(35.0)  # the layers' membranes carry over between runs
        first = {p: sim.spike_trains(p) for p in net.populations}
        sim.reset()
        sim.run(60.0)  # reset: the same spikes again
        again = {p: sim.spike_trains(p) for p in net.populations}
        runs[backend] = (first, again, sim.statistics())
    assert sum(t[0].size for p, t in runs["speck"][0].items() if p != "input") > 200
    for pop in net.populations:
        for k in (0, 1):
            np.testing.assert_array_equal(runs["speck"][k][pop][0], runs["reference"][k][pop][0], err_msg=pop)
            np.testing.assert_array_equal(runs["speck"][k][pop][1], runs["reference"][k][pop][1], err_msg=pop)
    for key in ("steps", "spikes", "synaptic_events"):
        assert runs["speck"][2][key] == runs["reference"][2][key], key


def test_speck_backend_feeds_a_long_run_in_chunks_with_the_same_spikes(monkeypatch: pytest.MonkeyPatch):
    from neurovpr.backends.speck import simulation

    net = _convnet(4, layers=2)
    whole = nv.compile(net, backend="speck", dt=1.0, seed=0)
    whole.run(60.0)
    monkeypatch.setattr(simulation, "_CHUNK_VALUES", 7 * sum(p.size for p in net.populations.values()))
    chunked = nv.compile(net, backend="speck", dt=1.0, seed=0)
    chunked.run(60.0)  # 9 chunks of 7 steps (the last shorter)
    for pop in net.populations:
        for a, b in zip(whole.spike_trains(pop), chunked.spike_trains(pop), strict=True):
            np.testing.assert_array_equal(a, b)
    assert whole.spike_counts("dense").sum() > 0


def test_reference_speck_arithmetic_records_the_integer_membrane_in_mv():
    net = _convnet(1)
    sim = nv.compile(net, backend="reference", hardware="speck", dt=1.0, seed=0)
    sim.record("dense", "v")
    sim.run(60.0)
    block = next(b for b in sim.quantised.blocks if b["population"] == "dense")
    times, v = sim.trace("dense", "v")
    assert times.size == 60 and v.shape == (60, 10)
    units = v * block["scale"]  # v_rest is 0: the membrane in chip units
    np.testing.assert_allclose(units, np.round(units), atol=1e-6 * block["threshold"])
    assert np.all(units < block["threshold"]) and np.all(units >= block["min_v_mem"])
    assert np.ptp(units) > 0


def test_speck_backend_runs_poisson_input_and_counts_activity():
    net = _convnet(0)
    pois = nv.Network("speck_poisson")
    for name, pop in net.populations.items():
        pois.add_population(name, pop.size, nv.SpikeSourcePoisson(rate=0.0) if pop.is_source else pop.cell_type)
    for proj in net.projections.values():
        pois.connect(proj.pre, proj.post, proj.connector, proj.synapse, receptor_type=proj.receptor_type, name=proj.name)
    sim = nv.compile(pois, backend="speck", dt=1.0, seed=3)
    sim.run(100.0, inputs={"input": np.full(128, 200.0)})
    n_in = int(sim.spike_counts("input").sum())
    assert 128 * 100 * 0.2 * 0.8 < n_in < 128 * 100 * 0.2 * 1.2
    stats = sim.statistics()
    assert stats["steps"] == 100 and stats["neuron_updates"] == 100 * (256 + 10)
    assert stats["spikes"] == sum(int(sim.spike_counts(p).sum()) for p in pois.populations)


def test_speck_backend_refuses_what_speck_cannot_hold_naming_the_limit():
    with pytest.raises(nv.UnsupportedFeatureError, match=r"does not fit speck .*10 layers but speck has 9 cores"):
        nv.compile(_convnet(0, layers=9), backend="speck", dt=1.0, seed=0)
    for backend, hw in (("speck", None), ("reference", "speck")):
        with pytest.raises(nv.UnsupportedFeatureError, match=r"'conv0': tau_m 20 ms leaks.*nv.NO_LEAK"):
            nv.compile(_convnet(0, tau_m=20.0), backend=backend, hardware=hw, dt=1.0, seed=0)
    with pytest.raises(nv.UnsupportedFeatureError, match=r"steps of 1 ms"):
        nv.compile(_convnet(0), backend="speck", dt=0.5, seed=0)
    huge = nv.Network("huge_weight")
    huge.add_population("input", 4, nv.SpikeSourceArray(spike_times=[[1.0]] * 4))
    huge.add_population("out", 2, nv.IF_curr_exp(**IAF, v_thresh=1.0))
    huge.connect("input", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=np.array([[300.0, 1.0]] * 4)))
    for backend, hw in (("speck", None), ("reference", "speck")):
        with pytest.raises(nv.UnsupportedFeatureError, match=r"'out': its threshold 1 mV rounds to 0 .*300 mV"):
            nv.compile(huge, backend=backend, hardware=hw, dt=1.0, seed=0)


def test_speck_backend_is_listed_with_its_capabilities(capsys):
    from neurovpr.cli import main as cli

    info = backend_info("speck")
    assert info.available and info.version == "3.1.3"
    caps = info.backend.capabilities
    assert caps.arithmetic == frozenset({"speck"}) and not caps.learns
    assert caps.connectors == frozenset({"AllToAllConnector", "ConvolutionConnector"})
    assert "non-leaky" in caps.unsupported["psp_curr"] and "0.1 ms" in caps.unsupported["poisson"]
    assert cli.main(["backends", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    text = json.dumps(listed)
    assert '"speck"' in text and "DynapcnnNetwork" in text


# -- neurovpr compare: off- vs on-chip rows -------------------------------------------------
class _IAFTemplate(TemplatePlugin):
    """compare's template model with its place neurons made non-leaky integrate-and-fire (what Speck holds)."""

    name = "iaf_template"

    def train_run(self, data: Path, out: Path, *, cell: str = "curr") -> Path:
        super().train_run(data, out, cell=cell)
        net = nv.load(out / "network.h5")
        iaf = nv.Network(net.name)
        for name, pop in net.populations.items():
            iaf.add_population(name, pop.size, pop.cell_type if pop.is_source else nv.IF_curr_exp(**IAF, v_thresh=1.0))
        for proj in net.projections.values():
            iaf.connect(proj.pre, proj.post, proj.connector, proj.synapse, name=proj.name)
        nv.save(iaf, out / "network.h5")
        return out


def test_compare_reference_and_speck_off_and_on_chip(tmp_path: Path):
    """A non-leaky template model gets an off-chip (reference) and an on-chip (speck) row; the leaky one a refusal."""
    data = write_generic(synthetic_traverse(6, seed=3), tmp_path / "traverse")
    model = _IAFTemplate()
    result = compare.compare_model(model.train_run(data, tmp_path / "iaf"), data, "reference,speck", progress=False, model=model)
    assert [r.backend for r in result.rows if r.ran] == ["reference", "speck"], [r.refused for r in result.rows]
    speck = result.rows[1]
    assert speck.output_counts.shape == (6, 6) and speck.output_counts.sum() > 0
    assert 0.0 <= speck.agreement <= 1.0 and "R@1" in speck.metrics
    leaky = TemplatePlugin()  # IF_curr_exp with tau_m 20 ms
    refused = compare.compare_model(
        leaky.train_run(data, tmp_path / "leaky"), data, "reference,speck", progress=False, model=leaky
    )
    row = refused.rows[1]
    assert refused.rows[0].ran and not row.ran and "tau_m 20 ms leaks" in row.refused
    assert "speck: refused: " in refused.table()
