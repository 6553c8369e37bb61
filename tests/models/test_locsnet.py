"""LoCS-Net: SoftLIF, architecture, training with torch, conversion to a spiking network, runs, bad input."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.data import GroundTruth, synthetic_traverse, write_generic
from neurovpr.data.preprocess import patch_normalise
from neurovpr.ir.cells import SoftLIF

torch = pytest.importorskip("torch", reason="LoCS-Net training needs torch (the 'locsnet' extra)")

from neurovpr.models.locsnet import (  # noqa: E402
    MODEL,
    Architecture,
    ConvSpec,
    SpikingClassifier,
    SpikingParameters,
    frame_labels,
    grid_labels,
    lif_rate,
    paper_architecture,
    place_ground_truth,
    rate_forward,
    small_architecture,
    softlif_rate,
    to_spiking_network,
    trained_parameters,
)
from neurovpr.models.locsnet.calibration import calibrate_places  # noqa: E402
from neurovpr.models.locsnet.places import distance_confusion, query_tiles  # noqa: E402
from neurovpr.models.locsnet.preprocess import box_patch_normalise, preprocess  # noqa: E402
from neurovpr.models.locsnet.quantise import quantise_weights, weight_format  # noqa: E402
from neurovpr.models.locsnet.runs import load_checkpoint, load_run, save_checkpoint  # noqa: E402
from neurovpr.models.locsnet.torchnet import softlif  # noqa: E402
from neurovpr.models.locsnet.training import TrainingSettings, check_labels, train  # noqa: E402

N_PLACES = 12
NEURON = SoftLIF(tau_rc=10.0, tau_ref=1.0, sigma=0.02, amplitude=10.0)
TRAIN = TrainingSettings(epochs=40, batch_size=4, learning_rate=5e-3, shift=1, noise=0.02, seed=0)
SPIKING = SpikingParameters(presentation=40.0, input_coding="regular", tau_syn=1.0)


def _arch(n_places: int = N_PLACES) -> Architecture:
    return dataclasses.replace(small_architecture(n_places), neuron=NEURON, dense_bias=False)


@pytest.fixture(scope="module")
def images() -> np.ndarray:
    """Reference images of a small synthetic traverse, preprocessed to 28x28."""
    tr = synthetic_traverse(N_PLACES, seed=3)
    return preprocess(tr.reference.images(), (28, 28))


@pytest.fixture(scope="module")
def trained(images: np.ndarray):
    """The small architecture trained for a few epochs on one image per place."""
    return train(_arch(), images, np.arange(N_PLACES), TRAIN)


# -- SoftLIF --------------------------------------------------------------------------------
def test_softlif_matches_the_lif_closed_form_for_large_currents() -> None:
    j = np.array([1.5, 2.0, 5.0, 20.0, 100.0])
    exact = 1.0 / (NEURON.tau_ref + NEURON.tau_rc * np.log1p(1.0 / (j - 1.0))) * NEURON.amplitude
    assert np.allclose(lif_rate(j, NEURON), exact, rtol=1e-12)
    assert np.allclose(softlif_rate(j, NEURON), exact, rtol=1e-3)
    torch_rate = softlif(torch.tensor(j), NEURON.tau_rc, NEURON.tau_ref, NEURON.sigma, NEURON.amplitude).numpy()
    assert np.allclose(torch_rate, softlif_rate(j, NEURON), rtol=1e-9)
    # below threshold the smoothed rate is small and falls towards 0 (like sigma / (tau_rc |j - 1|))
    below = softlif_rate(np.array([0.0, -10.0, -1000.0]), NEURON)
    assert below[0] < 0.05 * exact[0] and below[1] < below[0] / 5 and below[2] < 1e-4
    assert lif_rate(np.array([0.5, 1.0]), NEURON).tolist() == [0.0, 0.0]


def test_softlif_gradient_is_finite_and_positive_everywhere() -> None:
    j = torch.linspace(-200.0, 200.0, 4001, dtype=torch.float64, requires_grad=True)
    softlif(j, NEURON.tau_rc, NEURON.tau_ref, NEURON.sigma, NEURON.amplitude).sum().backward()
    assert torch.isfinite(j.grad).all()
    assert (j.grad > 0).all()
    small = torch.linspace(-2.0, 3.0, 41, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda x: softlif(x, 10.0, 1.0, 0.1, 10.0), (small,))


# -- architecture ---------------------------------------------------------------------------
def test_paper_architecture_shapes_and_json_roundtrip() -> None:
    arch = paper_architecture(3072)
    assert arch.layer_shapes() == {"input": (1, 56, 56), "conv1": (8, 26, 26), "conv2": (16, 12, 12),
                                   "conv3": (32, 5, 5), "places": (3072,)}
    assert arch.parameter_shapes()["places.weight"] == (3072, 800)
    assert "conv1.bias" not in arch.parameter_shapes()  # biases removed from the conv layers, as the paper did
    again = Architecture.from_dict(json.loads(arch.to_json()))
    assert again.to_dict() == arch.to_dict()
    with pytest.raises(nv.ValidationError, match="does not fit"):
        Architecture(n_places=4, input_size=(8, 8), convs=(ConvSpec(filters=2, kernel=5, stride=2),) * 3)
    with pytest.raises(nv.ValidationError, match="format"):
        Architecture.from_dict({"format": "other"})


def test_network_synapse_count_matches_the_expanded_connections(trained) -> None:
    arch = _arch()
    net = to_spiking_network(arch, trained.parameters, SPIKING)
    total = sum(len(nv.expand(net, name, seed=0, dt=1.0)) for name in net.projections)
    assert total == arch.n_synapses()


# -- training and conversion ------------------------------------------------------------------
def test_training_learns_the_places(trained, images: np.ndarray) -> None:
    assert trained.history[-1]["loss"] < trained.history[0]["loss"]
    rates = rate_forward(_arch(), trained.parameters, images)["places"]
    assert np.mean(np.argmax(rates, axis=1) == np.arange(N_PLACES)) >= 0.75


def test_conversion_gives_a_valid_ir_network_that_recognises_the_training_places(trained, images, tmp_path) -> None:
    arch = _arch()
    net = to_spiking_network(arch, trained.parameters, SPIKING)
    assert set(net.populations) == {"input", "conv1", "conv2", "conv3", "places"}
    assert all(isinstance(net.populations[p].cell_type, nv.IF_curr_exp) for p in ("conv1", "conv2", "conv3", "places"))
    assert isinstance(net.projections["input->conv1"].connector, nv.ConvolutionConnector)
    nv.save(net, tmp_path / "net.h5")
    loaded = nv.load(tmp_path / "net.h5")
    back = trained_parameters(loaded, arch, SPIKING)
    for name, value in trained.parameters.items():
        assert np.allclose(back[name], value, rtol=1e-12, atol=1e-12), name
    result = SpikingClassifier(loaded, arch, SPIKING).run(images)
    accuracy = np.mean(np.argmax(result.counts, axis=0) == np.arange(N_PLACES))
    assert accuracy > 3.0 / N_PLACES  # chance is 1 / N_PLACES
    assert result.activity["steps"] == SPIKING.presentation / SPIKING.dt
    assert result.layer_spikes["places"] > 0


def test_conv3_feature_groups_compute_the_same_network(trained, images) -> None:
    arch = _arch()
    grouped = dataclasses.replace(SPIKING, feature_groups=4)
    net = to_spiking_network(arch, trained.parameters, grouped)
    assert {"conv3.0", "conv3.3"} <= set(net.populations) and "conv3" not in net.populations
    assert net.populations["conv3.1"].size == arch.layer_sizes()["conv3"] // 4
    back = trained_parameters(net, arch, grouped)
    assert all(np.allclose(back[k], v, rtol=1e-12, atol=1e-12) for k, v in trained.parameters.items())
    plain = SpikingClassifier(to_spiking_network(arch, trained.parameters, SPIKING), arch, SPIKING).run(images[:4])
    split = SpikingClassifier(net, arch, grouped).run(images[:4])
    assert np.array_equal(plain.counts, split.counts)  # deterministic input: identical spikes
    assert plain.layer_spikes == split.layer_spikes
    with pytest.raises(nv.ValidationError, match="do not divide the 8 channels"):
        to_spiking_network(arch, trained.parameters, dataclasses.replace(SPIKING, feature_groups=3))


def test_spiking_rates_approach_the_lif_rates_of_the_rate_model(trained, images) -> None:
    arch = _arch()
    long = dataclasses.replace(SPIKING, presentation=400.0)
    clf = SpikingClassifier(to_spiking_network(arch, trained.parameters, long), arch, long)
    clf.query(images[0])
    measured = clf.sim.spike_counts("conv1") / long.presentation * NEURON.amplitude
    expected = rate_forward(arch, trained.parameters, images[:1], exact_lif=True)["conv1"].ravel()
    assert np.corrcoef(measured, expected)[0, 1] > 0.95
    assert abs(measured.mean() - expected.mean()) < 0.25 * expected.mean()


def test_quantisation_aware_training_keeps_weights_on_the_chip_grid(images) -> None:
    fmt = weight_format("kapoho-bay")
    assert fmt.levels == 127  # 7-bit magnitude and a sign (hwspecs/kapoho-bay.toml)
    settings = dataclasses.replace(TRAIN, epochs=3, quantise="kapoho-bay")
    result = train(_arch(), images, np.arange(N_PLACES), settings, weight_format=fmt)
    for name in ("conv1.weight", "conv2.weight", "conv3.weight"):
        w = result.parameters[name]
        assert np.allclose(quantise_weights(w, fmt), w, atol=1e-9 * np.abs(w).max()), name
        assert np.unique(np.round(w / (np.abs(w).max() / 127))).size <= 255


def test_place_calibration_keeps_each_images_order() -> None:
    rng = np.random.default_rng(0)
    params = {"places.weight": rng.normal(size=(5, 7))}
    acts = rng.random((20, 7))
    currents = acts @ params["places.weight"].T
    new, info = calibrate_places(params, currents, acts.sum(1), drive=6.0, active=2)
    after = acts @ new["places.weight"].T
    assert (np.argsort(after, axis=1) == np.argsort(currents, axis=1)).all()
    assert np.isclose(np.sort(after, axis=1)[:, -1].mean(), 6.0)
    assert np.isclose(np.sort(after, axis=1)[:, -2].mean(), 1.0)
    assert info["scale"] > 0


# -- places, preprocessing --------------------------------------------------------------------
def test_frame_and_grid_labels_and_place_ground_truth() -> None:
    labels = frame_labels(10, 3)
    assert labels.n_places == 4 and labels.labels.tolist() == [0, 0, 0, 1, 1, 1, 2, 2, 2, 3]
    gt = place_ground_truth(GroundTruth.aligned(10), labels)
    assert gt.shape == (4, 10) and gt[1, 4] and not gt[0, 4]
    xy = np.array([[0, 0], [5, 5], [30, 2], [31, 3], [80, 80]], dtype=float)
    grid = grid_labels(xy, tile_size=25.0, min_images=2)
    assert grid.n_places == 2 and grid.labels.tolist() == [0, 0, 1, 1, -1]  # the rare tile is dropped
    assert query_tiles(grid, np.array([[1.0, 1.0], [90.0, 90.0]])).tolist() == [0, -1]
    conf = distance_confusion(grid, np.array([0, 1]), np.array([[12.5, 12.5], [40.0, 12.5]]))
    assert conf["within_25m"] == 1.0 and conf["median_error_m"] < 1e-9 + 2.5


def test_box_patch_normalisation_agrees_with_the_reference_definition() -> None:
    img = np.random.default_rng(1).random((2, 20, 24)) * 255
    assert np.allclose(box_patch_normalise(img, 7), patch_normalise(img, 7), atol=1e-9)
    out = preprocess([np.full((32, 64, 3), 90, dtype=np.uint8)], (28, 28))
    assert out.shape == (1, 28, 28) and np.allclose(out, 0.5)  # a flat image normalises to 0 -> 0.5


# -- bad input --------------------------------------------------------------------------------
def test_a_place_without_training_images_is_refused_before_training(images) -> None:
    labels = np.arange(N_PLACES)
    labels[5] = 4
    with pytest.raises(nv.ValidationError, match="place 5 has no training images"):
        train(_arch(), images, labels, TRAIN)
    with pytest.raises(nv.ValidationError, match="outside the 12 places"):
        check_labels(_arch(), np.arange(1, N_PLACES + 1), N_PLACES)


def test_a_query_of_the_wrong_shape_is_refused(trained) -> None:
    arch = _arch()
    clf = SpikingClassifier(to_spiking_network(arch, trained.parameters, SPIKING), arch, SPIKING)
    with pytest.raises(nv.ValidationError, match=r"takes 28x28 grayscale images"):
        clf.query(np.zeros((56, 56)))
    with pytest.raises(nv.ValidationError, match=r"pixel values in \[2, 2\], expected \[0, 1\]"):
        clf.query(np.full((28, 28), 2.0))
    with pytest.raises(nv.ValidationError, match="NaN"):
        clf.query(np.full((28, 28), np.nan))


def test_integrate_and_fire_form_keeps_the_weights_without_leak_or_groups(trained) -> None:
    from neurovpr.models.locsnet.deployment import integrate_and_fire_form

    grouped = dataclasses.replace(SPIKING, feature_groups=2)
    net = to_spiking_network(_arch(), trained.parameters, grouped)
    assert {"conv3.0", "conv3.1"} <= set(net.populations)
    form, spiking = integrate_and_fire_form(net, _arch(), grouped)
    assert spiking.feature_groups == 1 and "conv3" in form.populations and "conv3.0" not in form.populations
    cells = [pop.cell_type for pop in form.populations.values() if not pop.is_source]
    assert cells and all(cell.tau_m == nv.NO_LEAK for cell in cells)
    assert all(cell.replace(tau_m=10.0) == net.populations["conv1"].cell_type for cell in cells[:1])
    expected = to_spiking_network(_arch(), trained.parameters, dataclasses.replace(SPIKING, feature_groups=1))
    for name, proj in expected.projections.items():
        assert np.array_equal(np.asarray(form.projections[name].synapse.weight), np.asarray(proj.synapse.weight)), name


def test_a_checkpoint_or_network_of_another_architecture_is_refused(trained, tmp_path) -> None:
    save_checkpoint(tmp_path / "model.pt", trained.state_dict)
    assert set(load_checkpoint(tmp_path / "model.pt", _arch())) >= {"conv1.weight", "places.weight"}
    other = _arch(N_PLACES + 3)
    with pytest.raises(nv.ValidationError, match="different architecture"):
        load_checkpoint(tmp_path / "model.pt", other)
    wider = dataclasses.replace(_arch(), convs=(ConvSpec(filters=6, kernel=5, stride=2), *_arch().convs[1:]))
    with pytest.raises(nv.ValidationError, match="different architecture"):
        load_checkpoint(tmp_path / "model.pt", wider)
    net = to_spiking_network(_arch(), trained.parameters, SPIKING)
    with pytest.raises(nv.ValidationError, match="different architecture"):
        trained_parameters(net, other, SPIKING)
    with pytest.raises(nv.ValidationError, match="different architecture"):
        to_spiking_network(other, trained.parameters, SPIKING)
    (tmp_path / "junk.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(nv.ValidationError, match="not a readable torch state dict"):
        load_checkpoint(tmp_path / "junk.pt", _arch())


# -- the model API (typed requests; the command line builds the same) ---------------------------
def test_train_and_eval_write_a_complete_run_directory(tmp_path, capsys) -> None:
    data = write_generic(synthetic_traverse(10, seed=5), tmp_path / "data")
    run = tmp_path / "run"
    args = dict(data=data, out=run, preset="small", epochs=20, batch_size=4, calibration_images=5, presentation=20.0,
                input_coding="regular")
    summary = MODEL.train(**args)
    assert summary["n_places"] == 10 and math.isfinite(summary["loss"])
    for name in ("run.json", "network.h5", "architecture.json", "places.npz", "model.pt"):
        assert (run / name).is_file(), name
    info = json.loads((run / "run.json").read_text())
    assert info["model"] == "locsnet" and info["backend"] == "reference" and info["n_places"] == 10
    assert info["dt_ms"] == info["spiking"]["dt"]  # what `neurovpr check --run` reads
    loaded = load_run(run)
    assert loaded.network.populations["places"].size == 10
    with pytest.raises(nv.ValidationError, match="already holds a finished run"):
        MODEL.train(**args)
    result = MODEL.evaluate(run=run, queries=6, run_info=info)
    assert set(result["metrics"]) >= {"R@1", "R@5", "P@100R", "AUC_PR"}
    assert result["queries"] == 6 and "SAD" in result["baselines"]
    activity = json.loads((run / "activity.json").read_text())
    assert activity["inferences"] == 6 and activity["steps"] == 20
    assert all(Path(p).is_file() for p in result["plots"])
    from neurovpr.cli.main import main

    assert main(["check", "--run", str(run), "--hw", "kapoho-bay", "--json"]) == 0
    capsys.readouterr()
    plots = tmp_path / "activity"
    # with NeuroBench's metrics of the run, and the raster and rates of the first query
    assert main(["eval", "--run", str(run), "--queries", "6", "--json", "--activity-plots", str(plots)]) == 0
    printed = json.loads(capsys.readouterr().out)
    block = printed["neurobench"]
    summary = json.loads((plots / "activity_summary.json").read_text())
    assert printed["activity_plots"]["raster"] == str(plots / "raster.png") and (plots / "rates.png").is_file()
    assert summary["title"].startswith("LoCS-Net, query image 0") and summary["duration_ms"] == 20.0
    assert summary["populations"]["places"]["neurons"] == 10 and summary["populations"]["input"]["spikes"] > 0
    activity = json.loads((run / "activity.json").read_text())
    assert block["synaptic_operations"]["Effective_ACs"] == activity["synaptic_events"] > 0
    assert block["synaptic_operations"]["Dense"] == block["synapses"] * 20 and 0.0 < block["activation_sparsity"] < 1.0
    # on Speck (no leak): the integrate-and-fire form runs, and the row says so (Sinabs: the test command installs it)
    from neurovpr.apps import compare

    if nv.get_backend("speck").unavailable_reason() is None:
        result = compare.compare_model(run, data, "reference,speck", progress=False, model=MODEL)
        assert [row.backend for row in result.rows if row.ran] == ["reference", "speck"], result.table()
        assert result.rows[1].output_counts.shape == (10, 10) and result.rows[1].output_counts.sum() > 0
        assert any("integrate-and-fire form" in note and "tau_m 10 ms dropped" in note for note in result.notes())
        # with a hwspec, the speck row's energy uses the partition of the form that ran there
        on_chip = compare.compare_model(run, data, "reference,speck", hardware="speck", progress=False, model=MODEL)
        assert any("speck: its energy uses the partition of the form that ran: it fits speck" in n for n in on_chip.notes())


def test_train_refuses_a_dataset_with_too_few_places(tmp_path) -> None:
    data = write_generic(synthetic_traverse(3, seed=5), tmp_path / "data")
    with pytest.raises(nv.ValidationError, match="at least 2 are needed"):
        MODEL.train(data=data, out=tmp_path / "run", preset="small", frames_per_place=3)
    assert not (tmp_path / "run").exists()


# -- other backends (slow) --------------------------------------------------------------------
_RUN_ON_BACKEND = """
import json, sys
import numpy as np
import neurovpr as nv
from neurovpr.models.locsnet import Architecture, SpikingClassifier, SpikingParameters
folder, backend = sys.argv[1], sys.argv[2]
spec = json.load(open(folder + "/spec.json"))
arch = Architecture.from_dict(spec["architecture"])
spiking = SpikingParameters.from_dict(spec["spiking"])
clf = SpikingClassifier(nv.load(folder + "/net.h5"), arch, spiking, backend=backend)
print(json.dumps(clf.run(np.load(folder + "/images.npy")).counts.tolist()))
"""


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["nengo", "nengo-loihi", "lava", "lava-fixed"])
def test_the_converted_network_runs_on_the_other_backends(backend, trained, images, tmp_path) -> None:
    import subprocess
    import sys

    from neurovpr.runtime.registry import backend_infos

    info = {i.name: i for i in backend_infos()}.get(backend)
    if info is None or not info.available:
        pytest.skip(f"backend {backend!r} is not installed here")
    arch = _arch()
    nv.save(to_spiking_network(arch, trained.parameters, SPIKING), tmp_path / "net.h5")
    np.save(tmp_path / "images.npy", images)
    (tmp_path / "spec.json").write_text(json.dumps({"architecture": arch.to_dict(), "spiking": SPIKING.to_dict()}))
    reference = SpikingClassifier(nv.load(tmp_path / "net.h5"), arch, SPIKING).run(images).counts
    # a fresh interpreter: Lava forks its workers, which must not inherit this process's threads
    proc = subprocess.run([sys.executable, "-c", _RUN_ON_BACKEND, str(tmp_path), backend],
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]
    counts = np.asarray(json.loads(proc.stdout.strip().splitlines()[-1]))
    agree = np.mean(np.argmax(counts, axis=0) == np.argmax(reference, axis=0))
    accuracy = np.mean(np.argmax(counts, axis=0) == np.arange(N_PLACES))
    assert agree >= 0.5 and accuracy > 3.0 / N_PLACES, (agree, accuracy)


@pytest.mark.slow
def test_nordland_places_are_recognised_above_chance(shared_data, tmp_path) -> None:
    """200 real Nordland places (summer reference, winter query): both the rate model and the spiking network beat chance."""
    from neurovpr.data import open_traverse

    traverse = open_traverse(shared_data / "nordland64").first(200)
    arch = paper_architecture(200)
    ref = preprocess(traverse.reference.images(), arch.input_size)
    qry = preprocess(traverse.query.images(), arch.input_size)
    result = train(arch, ref, np.arange(200), TrainingSettings(epochs=20))
    spiking = SpikingParameters()
    rates = rate_forward(arch, result.parameters, qry)["places"]
    counts = SpikingClassifier(to_spiking_network(arch, result.parameters, spiking), arch, spiking).run(qry).counts
    assert np.mean(np.argmax(rates, axis=1) == np.arange(200)) > 10 / 200
    assert np.mean(np.argmax(counts, axis=0) == np.arange(200)) > 5 / 200


def test_torch_backend_gives_the_reference_spike_counts_on_the_same_input_spikes(trained, images) -> None:
    pytest.importorskip("torch")
    arch = _arch()
    net = to_spiking_network(arch, trained.parameters, SPIKING)  # regular coding: the input spikes are explicit
    reference = SpikingClassifier(net, arch, SPIKING).run(images)
    batched = SpikingClassifier(net, arch, SPIKING, backend="torch", batch_size=5).run(images)
    np.testing.assert_array_equal(batched.counts, reference.counts)
    np.testing.assert_array_equal(np.argmax(batched.counts, axis=0), np.argmax(reference.counts, axis=0))
    assert batched.layer_spikes == reference.layer_spikes
