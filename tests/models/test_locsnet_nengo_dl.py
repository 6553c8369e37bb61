"""LoCS-Net trained with NengoDL (``--trainer nengo-dl``): the same network as the torch trainer's, a run eval reads."""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.data import synthetic_traverse, write_generic
from neurovpr.models.locsnet import MODEL, rate_forward, small_architecture
from neurovpr.models.locsnet.nengo_training import augment, initial_parameters, nengo_problems
from neurovpr.models.locsnet.preprocess import preprocess
from neurovpr.models.locsnet.settings import TrainingSettings
from neurovpr.runtime.registry import backend_info

REASON = backend_info("nengo-dl").reason
needs_nengo_dl = pytest.mark.skipif(REASON is not None, reason=f"nengo-dl is not available: {REASON}")
N_PLACES = 6


@pytest.fixture(scope="module")
def images() -> np.ndarray:
    return preprocess(synthetic_traverse(N_PLACES, seed=3).reference.images(), (28, 28))


def test_initialisation_sets_each_layers_input_statistics(images: np.ndarray) -> None:
    """As the torch trainer's: per channel, every layer's input J is scaled to std init_std, then shifted to mean init_mean.

    The shift adds the same amount to every weight, so it moves each image's J by its own
    summed input: the mean lands exactly, the spread stays near ``init_std``.
    """
    arch = small_architecture(N_PLACES)
    s = TrainingSettings(init_mean=1.2, init_std=1.0)
    params = initial_parameters(arch, images[:, None], s, np.random.default_rng(0))
    acts = rate_forward(arch, params, images)
    j = acts["conv3"].reshape(len(images), -1) @ params["places.weight"].T
    assert j.mean(axis=0) == pytest.approx(np.full(N_PLACES, 1.2), abs=1e-6)
    assert np.all((j.std(axis=0) > 0.5) & (j.std(axis=0) < 2.0))


def test_augmentation_keeps_shapes_and_range(images: np.ndarray) -> None:
    rng = np.random.default_rng(0)
    out = augment(images, TrainingSettings(), rng)
    assert out.shape == images.shape and out.min() >= 0.0 and out.max() <= 1.0
    plain = TrainingSettings(shift=0, contrast=0.0, brightness=0.0, noise=0.0)
    np.testing.assert_array_equal(augment(images, plain, rng), images)


def test_torch_only_options_are_named() -> None:
    arch = dataclasses.replace(small_architecture(N_PLACES), conv_bias=True)
    problems = nengo_problems(arch, TrainingSettings(quantise="kapoho-bay"), checkpoint=True)
    assert len(problems) == 3 and "--quantise kapoho-bay" in problems[0]


@needs_nengo_dl
@pytest.mark.filterwarnings("ignore:.*channels_last=False:UserWarning", "ignore::RuntimeWarning")
def test_nengo_network_computes_the_numpy_rate_model(images: np.ndarray) -> None:
    """The NengoDL rate network gives the place currents of the numpy model for the same weights (layouts agree)."""
    import nengo

    from neurovpr.models.locsnet.nengo_training import build_rate_network, import_nengo_dl

    nengo_dl = import_nengo_dl(1)
    arch = small_architecture(N_PLACES)
    s = TrainingSettings()
    params = initial_parameters(arch, images[:, None], s, np.random.default_rng(1))
    net, objs, conns = build_rate_network(nengo_dl, arch, params, s)
    with net:
        probe = nengo.Probe(objs["places"], synapse=None)
    with nengo_dl.Simulator(net, minibatch_size=N_PLACES, progress_bar=False, device="/cpu:0") as sim:
        got = sim.predict({objs["input"]: images.reshape(N_PLACES, 1, -1).astype(np.float32)}, verbose=0)[probe][:, -1]
        kernel = sim.data.get_params((conns["conv2"], "weights"))[0]
    np.testing.assert_allclose(np.transpose(kernel, (3, 2, 0, 1)), params["conv2.weight"], rtol=1e-6)  # (out, in, kh, kw)
    acts = rate_forward(arch, params, images)["conv3"].reshape(N_PLACES, -1)
    np.testing.assert_allclose(got, acts @ params["places.weight"].T, rtol=0, atol=1e-4)


@needs_nengo_dl
def test_nengo_dl_training_writes_a_run_that_eval_reads(tmp_path) -> None:
    data = write_generic(synthetic_traverse(N_PLACES, seed=5), tmp_path / "data")
    run = tmp_path / "run"
    summary = MODEL.train(
        data=data,
        out=run,
        trainer="nengo-dl",
        preset="small",
        epochs=4,
        batch_size=4,
        calibration_images=3,
        presentation=20.0,
        input_coding="regular",
    )
    assert summary["trainer"] == "nengo-dl" and summary["epochs"] == 4 and math.isfinite(summary["loss"])
    info = json.loads((run / "run.json").read_text())
    assert info["trainer"] == "nengo-dl" and "checkpoint" not in info["files"]
    assert not (run / "model.pt").exists()
    result = MODEL.evaluate(run=run, queries=3, no_plots=True)
    assert set(result["metrics"]) >= {"R@1", "P@100R"} and result["queries"] == 3
    assert set(result["layer_spikes_per_query"]) >= {"conv1", "conv2", "conv3", "places"}
    with pytest.raises(nv.UnsupportedFeatureError, match="only the torch trainer"):
        MODEL.train(data=data, out=tmp_path / "run2", trainer="nengo-dl", preset="small", quantise="kapoho-bay")
    assert not (tmp_path / "run2").exists()


_TRAIN_WITHOUT_NENGO_DL = """
import sys
sys.modules["nengo_dl"] = None  # as if NengoDL were not installed
from neurovpr.cli.main import main
sys.exit(main(["train", "--model", "locsnet", "--trainer", "nengo-dl", "--data", sys.argv[1], "--out", sys.argv[2],
               "--preset", "small"]))
"""


def test_train_refuses_in_one_sentence_without_nengo_dl(tmp_path) -> None:
    """``train --trainer nengo-dl`` without NengoDL: exit 2, one sentence naming the trainer and the install script, no run."""
    data = write_generic(synthetic_traverse(3, seed=1), tmp_path / "data")
    out = tmp_path / "run"
    proc = subprocess.run(
        [sys.executable, "-c", _TRAIN_WITHOUT_NENGO_DL, str(data), str(out)], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 2, proc.stderr
    message = proc.stderr.strip()
    assert len(message.splitlines()) == 1 and message.count(". ") == 0, message
    assert "--trainer nengo-dl needs NengoDL" in message and "install_nengo_dl.sh" in message
    assert not out.exists()
