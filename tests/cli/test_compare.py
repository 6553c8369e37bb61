"""``neurovpr compare``: one trained model on several backends, refusals, broken backends, JSON and PNG.

The model is a small template-matching network written for these tests (a real
:class:`~neurovpr.apps.modelapi.ModelPlugin`: it trains by imprinting the reference images
as weights, saves ``network.h5`` and runs the saved weights on any backend); the
backends are the real reference simulator, Nengo, NengoLoihi's emulator and Lava's
bit-accurate Loihi 2 models.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.apps import compare, modelapi
from neurovpr.cli import compare_cmd
from neurovpr.data.generic import open_traverse, write_generic
from neurovpr.data.synthetic import synthetic_traverse
from neurovpr.errors import NeurovprError
from neurovpr.evaluation.metrics import distance_from_similarity, evaluate
from neurovpr.runtime.registry import get_backend

N_PLACES = 6
#: Images are averaged over 8x8 blocks: 32x64 pixels -> 4x8 = 32 inputs.
BLOCK = 8
DURATION = 100.0
DT = 1.0
MAX_RATE = 200.0


def _pixels(images: np.ndarray) -> np.ndarray:
    """``(N, H, W[, C])`` uint8 images -> ``(N, 32)`` values in [0, 1] (gray, 8x8 block means, contrast-stretched)."""
    arr = np.asarray(images, dtype=np.float64)
    if arr.ndim == 4:
        arr = arr.mean(axis=3)
    n, h, w = arr.shape
    blocks = arr.reshape(n, h // BLOCK, BLOCK, w // BLOCK, BLOCK).mean(axis=(2, 4)).reshape(n, -1)
    lo, hi = blocks.min(axis=1, keepdims=True), blocks.max(axis=1, keepdims=True)
    return (blocks - lo) / np.maximum(hi - lo, 1e-9)


class TemplatePlugin(modelapi.ModelPlugin):
    """Place neurons whose input weights are the reference images (a matched filter)."""

    name = "template"
    description = "template matching with one IF neuron per place (tests only)"

    def train_run(self, data: Path, out: Path, *, cell: str = "curr") -> Path:
        """Imprint the reference images of ``data`` into ``out/network.h5`` and write ``run.json``."""
        traverse = open_traverse(data)
        ref = _pixels(np.stack(traverse.reference.images()))
        if cell == "curr":
            # signed currents: the zero-mean, unit-norm reference image of each place
            centred = ref - ref.mean(axis=1, keepdims=True)
            weights = (centred / np.linalg.norm(centred, axis=1, keepdims=True)).T * 4.0  # (inputs, places)
            neurons = nv.IF_curr_exp(cm=1.0, tau_m=20.0, tau_refrac=2.0, tau_syn_E=2.0, tau_syn_I=2.0,
                                     v_rest=0.0, v_reset=0.0, v_thresh=1.0)  # fmt: skip
        else:
            weights = (ref / ref.sum(axis=1, keepdims=True)).T * 0.06
            neurons = nv.IF_cond_exp()
        net = nv.Network("template")
        net.add_population("input", ref.shape[1], nv.SpikeSourcePoisson(rate=0.0))
        net.add_population("places", ref.shape[0], neurons)
        net.connect("input", "places", nv.AllToAllConnector(), nv.StaticSynapse(weight=weights.ravel(), delay=DT))
        out.mkdir(parents=True, exist_ok=True)
        nv.save(net, out / "network.h5")
        (out / "run.json").write_text(json.dumps({"model": self.name, "backend": "reference", "seed": 0}))
        return out

    def infer(self, run_dir: Path, data: Path | None, backend: str, *, seed: int = 0) -> dict[str, Any]:
        """Query every image of ``data`` on ``backend`` with the saved weights."""
        traverse = open_traverse(data)
        queries = _pixels(np.stack(traverse.query.images()))
        sim = nv.compile(nv.load(Path(run_dir) / "network.h5"), backend=backend, dt=DT, seed=seed)
        try:
            before = sim.statistics()
            counts = np.zeros((len(queries), traverse.n_reference), dtype=np.int64)
            start = time.perf_counter()
            for q, x in enumerate(queries):
                sim.reset()
                sim.run(DURATION, inputs={"input": x * MAX_RATE})
                counts[q] = sim.spike_counts("places")
            seconds = (time.perf_counter() - start) / len(queries)
            after = sim.statistics()
        finally:
            close = getattr(sim, "close", None)
            if close is not None:
                close()
        activity = {k: (after[k] - before[k]) / len(queries) for k in ("steps", "neuron_updates", "spikes", "synaptic_events")}
        activity["dt_ms"] = DT
        metrics = evaluate(distance_from_similarity(counts.T.astype(float)), traverse.ground_truth, n_values=(1,))
        return {
            "metrics": metrics,
            "predictions": counts.argmax(axis=1),
            "output_counts": counts,
            "seconds_per_query": seconds,
            "activity": activity,
        }


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tiny synthetic traverse in the generic layout."""
    out = tmp_path_factory.mktemp("compare") / "traverse"
    return write_generic(synthetic_traverse(N_PLACES, seed=3), out)


@pytest.fixture(scope="module")
def runs(dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A current-based run (runs everywhere) and a conductance-based one (reference only)."""
    base = tmp_path_factory.mktemp("runs")
    plugin = TemplatePlugin()
    return {"curr": plugin.train_run(dataset, base / "curr"), "cond": plugin.train_run(dataset, base / "cond", cell="cond")}


@pytest.fixture()
def plugin(monkeypatch: pytest.MonkeyPatch) -> TemplatePlugin:
    """The test model, found by name as an installed model would be."""
    model = TemplatePlugin()
    real = modelapi.get_model
    monkeypatch.setattr(modelapi, "get_model", lambda name: model if name == model.name else real(name))
    return model


@pytest.fixture(scope="module")
def four(dataset: Path, runs: dict[str, Path]) -> compare.Comparison:
    """The current-based run compared on reference, nengo, nengo-loihi and lava-fixed, with Loihi 2 energy."""
    model = TemplatePlugin()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(modelapi, "get_model", lambda name: model)
        return compare.compare_model(
            runs["curr"], dataset, "reference,nengo,nengo-loihi,lava-fixed", hardware="loihi2", progress=False
        )


def _cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """Run ``neurovpr compare ARGV`` as the program's main does (exit 2 on any neurovpr error)."""
    parser = argparse.ArgumentParser(prog="neurovpr")
    sub = parser.add_subparsers(dest="command")
    compare_cmd.add_parser(sub)
    args = parser.parse_args(["compare", *argv])
    try:
        code = args.handler(args)
    except NeurovprError as exc:
        print(f"neurovpr compare: error: {exc}", file=sys.stderr)
        code = 2
    out, err = capsys.readouterr()
    return code, out, err


def test_four_backends_agreement_and_correlation(four: compare.Comparison):
    """Every backend runs; agreement and correlation are computed against the first backend's output."""
    assert [r.backend for r in four.rows] == ["reference", "nengo", "nengo-loihi", "lava-fixed"]
    assert all(r.ran for r in four.rows)
    assert four.reference_backend == "reference"
    ref = four.rows[0]
    assert ref.agreement == 1.0 and ref.deployed_from is None
    for row in four.rows:
        assert row.predictions is not None and row.output_counts is not None
        assert row.predictions.shape == (N_PLACES,) and row.output_counts.shape == (N_PLACES, N_PLACES)
        assert row.agreement == pytest.approx(np.mean(row.predictions == ref.predictions))
        expected_r = np.corrcoef(row.output_counts.ravel(), ref.output_counts.ravel())[0, 1]
        assert row.spike_count_correlation == pytest.approx(expected_r)
        assert 0.0 <= row.metrics["R@1"] <= 1.0
        assert row.seconds_per_query > 0
        if row.backend != "reference":
            assert row.deployed_from == "reference"
        # the template network spikes and the backends agree on its activity to within noise
        assert row.output_counts.sum() > 0
    assert min(r.spike_count_correlation for r in four.rows) > 0.5


def test_json_schema_and_energy(four: compare.Comparison):
    """The JSON object has the contract's keys per backend, energy with --hw, deployment notes."""
    out = json.loads(json.dumps(four.as_dict()))
    assert set(out["backends"]) == {"reference", "nengo", "nengo-loihi", "lava-fixed"}
    for name, row in out["backends"].items():
        assert {"metrics", "agreement", "seconds_per_query", "spike_count_correlation", "energy"} <= set(row)
        assert row["energy"]["hardware"] == "loihi2" and row["energy"]["joules_per_inference"] > 0
        assert ("deployed_from" in row) == (name != "reference")
    assert out["reference_backend"] == "reference" and out["trained_on"] == "reference"
    assert "trained on reference, deployed to nengo, nengo-loihi, lava-fixed" in " ".join(out["notes"])
    table = four.table()
    assert "lava-fixed" in table and "J/inf loihi2" in table


def test_refusal_row_names_the_feature(plugin: TemplatePlugin, dataset: Path, runs: dict[str, Path]):
    """A model needing a cell type a backend lacks is refused before running, naming it; the others still run."""
    result = compare.compare_model(runs["cond"], dataset, ["reference", "nengo", "lava"], progress=False)
    rows = {r.backend: r for r in result.rows}
    assert rows["reference"].ran and rows["reference"].agreement == 1.0
    for name in ("nengo", "lava"):
        assert not rows[name].ran
        assert "IF_cond_exp" in rows[name].refused and name in rows[name].refused
        assert result.as_dict()["backends"][name] == {"refused": rows[name].refused}


def test_broken_backend_reports_reason_and_extra(plugin: TemplatePlugin, dataset: Path, runs: dict[str, Path],
                                                 monkeypatch: pytest.MonkeyPatch):  # fmt: skip
    """An installed backend whose simulator fails to import is refused with the import error and the extra."""
    monkeypatch.setitem(sys.modules, "nengo_loihi", None)  # import of nengo_loihi now fails
    result = compare.compare_model(runs["curr"], dataset, "reference,nengo-loihi", progress=False)
    broken = result.rows[1]
    assert not broken.ran
    assert "nengo_loihi" in broken.refused and "neurovpr[nengo]" in broken.refused
    assert "ModuleNotFoundError" in broken.refused
    assert get_backend("nengo-loihi").extra == "nengo"


def test_mapping_only_backend_is_refused(plugin: TemplatePlugin, dataset: Path, runs: dict[str, Path]):
    """A backend that maps networks but cannot run them (sPyNNaker without a board) is refused with its own reason."""
    result = compare.compare_model(runs["curr"], dataset, "spinnaker,reference", progress=False)
    spinnaker, reference = result.rows
    assert not spinnaker.ran and "SpiNNaker board" in spinnaker.refused
    assert reference.ran and result.reference_backend == "reference" and reference.agreement == 1.0


def test_cli_json_and_png(plugin: TemplatePlugin, dataset: Path, runs: dict[str, Path], tmp_path: Path,
                          capsys: pytest.CaptureFixture[str]):  # fmt: skip
    """``compare --json`` prints one JSON object, writes the PNG and exits 0."""
    png = tmp_path / "cmp.png"
    code, out, _ = _cli(["--run", str(runs["curr"]), "--data", str(dataset), "--backends", "reference,nengo",
                         "--json", "--no-progress", "--plot", str(png)], capsys)  # fmt: skip
    assert code == 0
    obj = json.loads(out)
    assert set(obj["backends"]) == {"reference", "nengo"}
    assert obj["backends"]["nengo"]["deployed_from"] == "reference"
    for row in obj["backends"].values():  # NeuroBench's metrics of each backend's run
        ops = row["neurobench"]["synaptic_operations"]
        assert ops["Dense"] >= ops["Effective_ACs"] > 0 and ops["Effective_MACs"] == 0.0
        assert row["neurobench"]["footprint_bytes"] > 0 and 0.0 <= row["neurobench"]["connection_sparsity"] < 1.0
        sparsity = row["neurobench"]["activation_sparsity"]  # None where the model kept no spikes per population
        reason = row["neurobench"].get("activation_sparsity_reason", "")
        assert (0.0 < sparsity <= 1.0) if sparsity is not None else "population_spikes" in reason
    assert obj["plot"] == str(png)
    conf = json.loads(Path(obj["confusion"]["json"]).read_text())  # predicted places of each backend against reference
    assert obj["confusion"]["plot"] == str(tmp_path / "cmp_confusion.png") and conf["reference_backend"] == "reference"
    totals = {name: sum(c for _, _, c in conf["backends"][name]["pairs"]) for name in ("reference", "nengo")}
    assert totals["reference"] == totals["nengo"] > 0  # every query once
    for name in ("reference", "nengo"):
        pairs = conf["backends"][name]["pairs"]
        same = sum(c for a, b, c in pairs if a == b) / sum(c for _, _, c in pairs)
        assert same == pytest.approx(obj["backends"][name]["agreement"])
    assert Path(obj["confusion"]["plot"]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 5000


def test_cli_all_refused_exits_1_and_table(plugin: TemplatePlugin, dataset: Path, runs: dict[str, Path],
                                           capsys: pytest.CaptureFixture[str]):  # fmt: skip
    """When no backend can run the model the command exits 1; the table says why; the plot goes to RUN_DIR."""
    code, out, err = _cli(["--run", str(runs["cond"]), "--data", str(dataset), "--backends", "nengo", "--no-progress"], capsys)
    assert code == 1
    assert "nengo: refused: Backend 'nengo' cannot run cell type IF_cond_exp" in out
    assert "no backend could run" in err
    assert (runs["cond"] / compare_cmd.PLOT_FILE).is_file()


@pytest.mark.parametrize(
    ("backends", "message"),
    [
        ("reference,nosuch", "Unknown backend 'nosuch'"),
        ("reference,,nengo", "without empty entries"),
        ("nengo,nengo", "more than once"),
    ],
)
def test_bad_backend_lists_exit_2(plugin: TemplatePlugin, dataset: Path, runs: dict[str, Path], backends: str, message: str,
                                  capsys: pytest.CaptureFixture[str]):  # fmt: skip
    """Unknown, empty or repeated backend names are bad input (exit 2) before anything runs."""
    code, _, err = _cli(["--run", str(runs["curr"]), "--data", str(dataset), "--backends", backends, "--no-progress"], capsys)
    assert code == 2 and message in err and err.count("\n") == 1


def test_bad_run_and_data_exit_2(plugin: TemplatePlugin, dataset: Path, runs: dict[str, Path], tmp_path: Path,
                                 capsys: pytest.CaptureFixture[str]):  # fmt: skip
    """A folder without run.json, a missing dataset and an unknown hwspec are one-line errors with exit 2."""
    code, _, err = _cli(["--run", str(tmp_path), "--data", str(dataset), "--backends", "reference"], capsys)
    assert code == 2 and "run.json" in err
    code, _, err = _cli(["--run", str(runs["curr"]), "--data", str(tmp_path / "absent"), "--backends", "reference"], capsys)
    assert code == 2 and "does not exist" in err
    code, _, err = _cli(["--run", str(runs["curr"]), "--data", str(dataset), "--backends", "reference", "--hw", "nochip"],
                        capsys)  # fmt: skip
    assert code == 2 and "nochip" in err


def test_model_without_inference_is_refused(dataset: Path, runs: dict[str, Path], monkeypatch: pytest.MonkeyPatch):
    """A model that does not implement ``infer`` cannot be compared, and says so before any backend runs."""

    class NoInference(modelapi.ModelPlugin):
        name = "template"

    monkeypatch.setattr(modelapi, "get_model", lambda name: NoInference())
    with pytest.raises(nv.UnsupportedFeatureError, match="does not implement inference"):
        compare.compare_model(runs["curr"], dataset, "reference", progress=False)


def test_agreement_and_correlation_arithmetic():
    """Agreement is the fraction of equal predictions; r is Pearson's, undefined (None) for constant counts."""
    assert compare.agreement(np.array([1, 2, 3, 4]), np.array([1, 2, 0, 4])) == 0.75
    a = np.array([[0, 3], [5, 1]])
    b = np.array([[1, 2], [6, 0]])
    assert compare.spike_count_correlation(a, b) == pytest.approx(np.corrcoef(a.ravel(), b.ravel())[0, 1])
    assert compare.spike_count_correlation(np.zeros((2, 2)), b) is None
    with pytest.raises(nv.ValidationError):
        compare.agreement(np.array([1, 2]), np.array([1, 2, 3]))
    assert compare.parse_backends(" reference , nengo ") == ("reference", "nengo")


# -- the real models -----------------------------------------------------------------------------
def test_locsnet_converted_network_on_loihi_emulators(dataset: Path, tmp_path: Path):
    """A tiny trained LoCS-Net runs its converted IF_curr_exp network on reference, NengoLoihi's and Lava's fixed-point
    emulators; the comparison reports the paper's metric and the deployment."""
    pytest.importorskip("torch")
    from neurovpr.models.locsnet.plugin import MODEL

    MODEL.train(data=dataset, out=tmp_path / "run", preset="small", epochs=3, calibration_images=4, presentation=20.0)
    result = compare.compare_model(tmp_path / "run", dataset, "reference,nengo-loihi,lava-fixed", progress=False, model=MODEL)
    assert [r.backend for r in result.rows if r.ran] == ["reference", "nengo-loihi", "lava-fixed"]
    for row in result.rows:
        assert row.output_counts.shape == (N_PLACES, N_PLACES)  # one place per frame
        assert {"P@100R", "R@1", "AUC_PR"} <= set(row.metrics)
        assert row.agreement == pytest.approx(np.mean(row.predictions == result.rows[0].predictions))
    assert result.rows[1].deployed_from == result.rows[2].deployed_from == "reference"


def test_modular_snn_deployed_on_nengo_and_same_as_eval_on_reference(dataset: Path, tmp_path: Path):
    """On Nengo the module runs as its current-based approximation, and compare says so. On the
    reference backend compare reproduces ``eval``'s ensemble metrics (same seeds, plasticity off)."""
    from neurovpr.models.modular_snn.plugin import MODEL

    run = tmp_path / "run"
    from neurovpr.cli.train_cmd import train_request  # the command line builds the same typed request

    argv = ["--model", "modular", "--data", str(dataset), "--out", str(run), "--neurons", "8", "--module-size", "3",
            "--epochs", "1", "--workers", "1", "--members", "2", "--no-progress"]  # fmt: skip
    MODEL.train(train_request(MODEL, argv)[1])
    result = compare.compare_model(run, dataset, "reference,nengo", progress=False, model=MODEL)
    ref, nengo = result.rows
    assert nengo.ran, nengo.refused
    assert nengo.output_counts.shape == ref.output_counts.shape
    assert any("current-based approximation" in note for note in nengo.notes)
    assert any(line.startswith("nengo: ") and "current-based" in line for line in result.notes())
    assert "notes" in nengo.as_dict() and not ref.notes
    assert ref.ran and ref.output_counts.shape == (N_PLACES, 2 * 2 * 8)  # 2 members x 2 modules x 8 neurons
    ev = MODEL.eval_request(run=run, data=dataset, backend="reference", workers=1, report=tmp_path / "eval", progress=False)
    expected = MODEL.evaluate(ev)["metrics"]
    for key, value in expected.items():
        assert ref.metrics[key] == pytest.approx(value, abs=1e-6), key


def test_energy_and_verdict_share_the_partition_check_makes(plugin: TemplatePlugin, dataset: Path, runs: dict[str, Path],
                                                           tmp_path: Path, capsys: pytest.CaptureFixture[str]):  # fmt: skip
    """compare --hw partitions once, as `check --run` does (the run's dt, the caller's seed); energy uses that partition."""
    import shutil

    from neurovpr.cli.main import main
    from neurovpr.hardware.check import check_network

    run = Path(shutil.copytree(runs["curr"], tmp_path / "run"))
    (run / "run.json").write_text(json.dumps({"model": plugin.name, "backend": "reference", "seed": 0, "dt_ms": 0.1}))
    network = nv.load(run / "network.h5")
    cores = {dt: len(check_network(network, "spinn5", dt=dt, seed=5).partition.cores) for dt in (0.1, 1.0)}
    assert cores[0.1] != cores[1.0]  # sPyNNaker splits synapse cores below 1 ms: the step matters
    result = compare.compare_model(run, dataset, "reference", hardware="spinn5", seed=5, progress=False)
    assert main(["check", "--run", str(run), "--hw", "spinn5", "--seed", "5", "--json"]) == 0
    checked = json.loads(capsys.readouterr().out)
    assert result.hardware_fit == {"fits": checked["fits"], "dt_ms": 0.1, "chips": checked["chips"],
                                   "cores": checked["cores"], "violations": 0}  # fmt: skip
    assert result.rows[0].energy["cores"] == checked["cores"] == cores[0.1]
    assert any("the partition of every energy figure" in note for note in result.notes())
    assert result.as_dict()["hardware_fit"]["cores"] == cores[0.1]
