"""The models' query phases through Simulation.run_batch: the torch backend predicts as the reference does."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from modular_tiny import TINY, synthetic_dataset, tiny_images

import neurovpr as nv
from neurovpr.models.modular_snn.deployment import static_network
from neurovpr.models.modular_snn.inference import assign_neurons, module_similarity
from neurovpr.models.modular_snn.network import EXC, INPUT
from neurovpr.models.modular_snn.training import Presenter, record_responses, train_module

pytest.importorskip("torch")


def _explicit_spikes(rates: np.ndarray, duration: float, dt: float, rng: np.random.Generator) -> list[list[float]]:
    """Bernoulli spike times (one list per input neuron) for ``rates`` Hz."""
    steps = round(duration / dt)
    raster = rng.random((steps, rates.size)) < rates * dt / 1000.0
    return [(np.flatnonzero(raster[:, i]) * dt).tolist() for i in range(rates.size)]


def test_modular_snn_module_predicts_identically_on_torch_with_the_same_input_spikes() -> None:
    images = tiny_images(6, seed=1)
    places = np.arange(3)
    network, own, _, _ = train_module(images, places, TINY, seed=5, name="m")
    assignment = assign_neurons(own, places)
    static = static_network(network)
    pixels = static.populations[INPUT]
    static.replace_population(pixels.replace(cell_type=nv.SpikeSourceArray(spike_times=[[] for _ in range(pixels.size)])))
    rng = np.random.default_rng(7)
    items = [{INPUT: _explicit_spikes(TINY.coding.rates(im.ravel()), TINY.coding.presentation_ms, TINY.dt, rng)} for im in images]
    results = {}
    for backend in ("reference", "torch"):
        sim = nv.compile(static, backend=backend, dt=TINY.dt, seed=3)
        sim.plasticity(False)
        results[backend] = sim.run_batch(TINY.coding.presentation_ms, items, populations=[EXC]).counts[EXC]
    np.testing.assert_array_equal(results["torch"], results["reference"])
    assert results["reference"].sum() > 0
    sims = {b: module_similarity(c, assignment, 3) for b, c in results.items()}
    np.testing.assert_array_equal(np.argmax(sims["torch"], axis=0), np.argmax(sims["reference"], axis=0))


def test_record_responses_through_run_batch_equals_presenting_one_by_one() -> None:
    images = tiny_images(4, seed=2).reshape(4, -1)
    network, _, _, _ = train_module(tiny_images(3, seed=0), np.arange(3), TINY, seed=1, name="m")
    batched = nv.compile(network, backend="reference", dt=TINY.dt, seed=8)
    batched.plasticity(False)
    looped = nv.compile(network, backend="reference", dt=TINY.dt, seed=8)
    looped.plasticity(False)
    presenter = Presenter(looped, TINY)
    expected = np.asarray([presenter.present(im) for im in images], dtype=np.int32)
    np.testing.assert_array_equal(record_responses(Presenter(batched, TINY), images), expected)


def test_modular_snn_eval_runs_on_the_torch_backend(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from neurovpr.cli.main import main

    data = synthetic_dataset(tmp_path, 5)
    run_dir = tmp_path / "run"
    opts = ["--members", "1", "--epochs", "1", "--module-size", "3", "--neurons", "10", "--workers", "1", "--no-progress"]
    assert main(["train", "--model", "modular", "--data", str(data), "--out", str(run_dir), "--seed", "2", "--json", *opts]) == 0
    capsys.readouterr()
    assert main(["eval", "--run", str(run_dir), "--backend", "torch", "--json", "--no-progress"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["backend"] == "torch" and {"R@1", "P@100R"} <= set(result["metrics"])
    # the backend's own options from the command line: float64 fused gives the eager step's answers
    fused_args = ["--backend-option", "fuse=true", "--backend-option", "dtype=float64"]
    assert main(["eval", "--run", str(run_dir), "--backend", "torch", *fused_args, "--json", "--no-progress"]) == 0
    fused = json.loads(capsys.readouterr().out)
    assert fused["metrics"] == result["metrics"]
    assert main(["eval", "--run", str(run_dir), "--backend", "torch", "--backend-option", "colour=red", "--no-progress"]) == 2
    assert "has no option 'colour'" in capsys.readouterr().err
    assert main(["eval", "--run", str(run_dir), "--backend", "torch", "--backend-option", "fuse", "--no-progress"]) == 2
    assert "--backend-option 'fuse' is not KEY=VALUE" in capsys.readouterr().err


def test_backend_option_values_read_as_bools_numbers_none_or_strings() -> None:
    from neurovpr.cli.arguments import backend_options

    got = backend_options(["fuse=TRUE", "batch_size=64", "rate=1.5", "device=none", "dtype=float32", "name=a=b"])
    assert got == {"fuse": True, "batch_size": 64, "rate": 1.5, "device": None, "dtype": "float32", "name": "a=b"}
    assert backend_options(None) == {}
