"""NeuroBench's own metrics on an snnTorch model agree exactly with neurovpr's on the same model.

The model (Linear -> Leaky -> Linear -> Leaky, no biases, reset to zero without delay) is
measured by the ``neurobench`` package (``SNNTorchModel`` with ``Footprint``,
``ConnectionSparsity``, ``SynapticOperations``, ``ActivationSparsity``, ``MembraneUpdates``),
exported to NIR, imported through neurovpr's NIR importer, run on the reference backend with
the same input spikes, and measured by :mod:`neurovpr.evaluation.neurobench`.

Definitional mapping (see that module's docstring):

* each IR projection adds one step of latency and spikes are stamped at the end of their
  step, so layer ``L`` spikes ``2 L`` steps after snnTorch's: the run is ``2 L_max`` steps
  longer, and each population's membrane trace (recorded one row ahead of
  its spike stamps) is read from rows ``2 L - 1`` to ``2 L - 2 + T``, the sample's ``T`` steps;
* the input's last steps are silent, so every spike of the sample falls inside the run,
  and its first step is silent, so NeuroBench's "every neuron counts on the first step"
  meets neurons whose membrane is still at rest in both simulations;
* NeuroBench's footprint counts snnTorch's buffers: ``beta``, ``threshold`` and ``mem`` per
  neuron (``mem`` holds one value per neuron once the model has stepped, which NIR export
  does) are neurovpr's three values per neuron; the two scalars per neuron layer
  (``graded_spikes_factor``, float32, ``reset_mechanism_val``, int64: 12 bytes) are added.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.evaluation.neurobench import NeuroBenchCounter, static_metrics

torch = pytest.importorskip("torch")
snn = pytest.importorskip("snntorch")
pytest.importorskip("nir")
pytest.importorskip("nirtorch")
pytest.importorskip("neurobench", reason="neurobench is installed by scripts/install_neurobench.sh (bootstrap test)")

from neurobench.benchmarks import Benchmark  # noqa: E402
from neurobench.metrics.static import ConnectionSparsity, Footprint  # noqa: E402
from neurobench.metrics.workload import ActivationSparsity, MembraneUpdates, SynapticOperations  # noqa: E402
from neurobench.models import SNNTorchModel  # noqa: E402
from snntorch.export_nir import export_to_nir  # noqa: E402

from neurovpr.interop.nir import import_nir  # noqa: E402

H = 0.1  # ms: snnTorch's NIR step
pytestmark = pytest.mark.filterwarnings("ignore")


class _Loader(list):
    """What NeuroBench's Benchmark reads from a DataLoader: iteration and ``.dataset``."""

    @property
    def dataset(self) -> list:
        return [x for batch in self for x in batch[0]]


def _model(n_in: int, n_h: int, n_o: int):
    torch.manual_seed(3)
    model = torch.nn.Sequential(
        torch.nn.Linear(n_in, n_h, bias=False),
        snn.Leaky(beta=torch.full((n_h,), 0.9), threshold=torch.ones(n_h), init_hidden=True,
                  reset_mechanism="zero", reset_delay=False),
        torch.nn.Linear(n_h, n_o, bias=False),
        snn.Leaky(beta=torch.full((n_o,), 0.85), threshold=torch.ones(n_o), init_hidden=True, output=True,
                  reset_mechanism="zero", reset_delay=False),
    )  # fmt: skip
    with torch.no_grad():
        model[0].weight.mul_(3.0)
        model[2].weight.mul_(3.0)
    return model


def test_neurobench_counts_agree_exactly_on_an_snntorch_model(tmp_path: Path) -> None:
    n_in, n_h, n_o, steps, samples, tail = 20, 16, 8, 60, 2, 6
    model = _model(n_in, n_h, n_o)
    rng = np.random.default_rng(0)
    data = (rng.random((samples, steps, n_in)) < 0.2).astype(np.float32)
    data[:, 0] = 0.0
    data[:, -tail:] = 0.0

    # NeuroBench's side: its own model wrapper, metrics and benchmark loop
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nir_graph = export_to_nir(model, torch.zeros(1, n_in), ignore_dims=[0])
    loader = _Loader([(torch.tensor(data), torch.zeros(samples))])
    bench = Benchmark(SNNTorchModel(model), loader, [], [],
                      [[Footprint, ConnectionSparsity], [SynapticOperations, ActivationSparsity, MembraneUpdates]])  # fmt: skip
    theirs = bench.run(verbose=False)
    assert theirs["SynapticOperations"]["Effective_ACs"] > 0 and theirs["ActivationSparsity"] < 1.0

    # neurovpr's side: the same model through the NIR importer, run on the reference backend
    import nir

    nir.write(tmp_path / "model.nir", nir_graph)
    net = import_nir(tmp_path / "model.nir", integration="euler", dt=H).network
    layers = {"n_1": 1, "n_3": 2}
    assert set(layers) == {p for p, pop in net.populations.items() if not pop.is_source}
    counter = NeuroBenchCounter(net, dt=H)
    sim = nv.compile(net, backend="reference", dt=H, seed=0)
    for pop in layers:
        sim.record(pop, "v")
    run_steps = steps + 2 * max(layers.values())
    for sample in data:
        sim.reset()
        trains = [list(np.flatnonzero(sample[:, i]) * H) for i in range(n_in)]
        sim.run(run_steps * H, inputs={"input": trains})
        membrane = {pop: sim.trace(pop, "v")[1][2 * layer - 1 : 2 * layer - 1 + steps] for pop, layer in layers.items()}
        counts = {name: sim.spike_counts(name) for name in net.populations}
        counter.add_sample(steps=steps, spike_counts=counts, membrane=membrane)
    ours = counter.result()
    static = static_metrics(net, dt=H)

    assert ours["synaptic_operations"] == theirs["SynapticOperations"]
    assert ours["activation_sparsity"] == theirs["ActivationSparsity"]
    assert ours["membrane_updates"] == theirs["MembraneUpdates"]
    assert round(static["connection_sparsity"], 4) == theirs["ConnectionSparsity"]
    assert static["footprint_bytes"] + 2 * 12 == theirs["Footprint"]


def test_connection_sparsity_with_zero_weights_agrees_after_export_to_snntorch(tmp_path: Path) -> None:
    """Zero weights survive export to NIR (a dense Linear), so NeuroBench sees the same zeros.

    The other direction cannot show this: NIR import stores a Linear with zeros as a
    FromListConnector of its non-zero weights. The weights' bytes are snnTorch's parameters;
    the neuron part of its footprint differs by design (the imported layer keeps shared scalars).
    """
    from snntorch.import_nir import import_from_nir

    from neurovpr.interop.nir import export_nir, read_graph

    rng = np.random.default_rng(0)
    lif = {"tau_refrac": 0.0, "v_rest": 0.0, "v_reset": 0.0, "v_thresh": 1.0}
    net = nv.Network("zeros")
    net.add_population("inp", 12, nv.SpikeSourceArray.from_lists([[]] * 12))
    net.add_population("hid", 10, nv.IF_curr_exp(cm=0.5, tau_m=2.0, tau_syn_E=1.0, tau_syn_I=1.0, **lif))
    w = rng.normal(0.3, 0.5, (12, 10))
    w[rng.random(w.shape) < 0.4] = 0.0
    net.connect("inp", "hid", nv.AllToAllConnector(), nv.StaticSynapse(weight=w))
    export_nir(net, tmp_path / "zeros.nir", integration="euler", dt=H)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = SNNTorchModel(import_from_nir(read_graph(tmp_path / "zeros.nir")))
    ours = static_metrics(net, dt=H)
    assert ours["zero_weights"] == int((w == 0).sum()) > 0
    assert round(ours["connection_sparsity"], 4) == ConnectionSparsity()(model)
    assert ours["footprint_weight_bytes"] == sum(p.numel() * p.element_size() for p in model.__net__().parameters())
