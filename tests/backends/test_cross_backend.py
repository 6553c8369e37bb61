"""Cross-backend agreement: one Modular-SNN module trained on reference and on brian2.

Both backends get the same network (the model's own module graph, seeded initial
weights and delays), the same presentation order and the same input spikes: the
Poisson trains of every presentation are drawn once here and fed to both as a
``SpikeSourceArray``. Any difference in the learned weights or the place
predictions is then a difference of the simulators' numerics.

Figures when this test was written (5 synthetic places, 40 neurons, 5 epochs, seed 3,
dt 0.5 ms): learned input weights correlate with r = 1.0 (largest absolute
difference 1.4e-16); the place predictions agree on 5/5 reference images (4 distinct
places recognised) and 5/5 query images.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.data.encoding import RateCoding
from neurovpr.data.preprocess import preprocess_images
from neurovpr.data.synthetic import synthetic_traverse
from neurovpr.runtime.registry import discover

training = pytest.importorskip("neurovpr.models.modular_snn.training")
network = pytest.importorskip("neurovpr.models.modular_snn.network")
inference = pytest.importorskip("neurovpr.models.modular_snn.inference")

PLACES, NEURONS, EPOCHS, SEED = 5, 40, 5, 3


def _spike_trains(images: np.ndarray, rng: np.random.Generator, coding: RateCoding, dt: float) -> nv.SpikeSourceArray:
    """One Poisson presentation of each image as explicit spike trains (at most one spike per step)."""
    out = []
    steps = round(coding.presentation_ms / dt)
    for image in images:
        p = coding.rates(image) * dt / 1000.0
        t_idx, n_idx = np.nonzero(rng.random((steps, p.size)) < p)
        out.append(nv.SpikeSourceArray.from_events(t_idx * dt, n_idx, p.size))
    return out


def _run(backend: str, reference: np.ndarray, query: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    settings = training.TrainingSettings(
        params=dataclasses.replace(network.ModuleParameters(), n_neurons=NEURONS), epochs=EPOCHS, module_size=PLACES
    )
    net = settings.network("module", SEED)
    net.replace_population(net.populations[network.INPUT].replace(cell_type=nv.SpikeSourceArray.from_lists([[]] * 784)))
    sim = nv.compile(net, backend=backend, dt=settings.dt, seed=SEED)
    rng = np.random.default_rng(SEED)
    order = [p for _ in range(EPOCHS) for p in rng.permutation(PLACES)]
    train_trains = _spike_trains(reference[order], rng, settings.coding, settings.dt)
    test_trains = _spike_trains(np.concatenate([reference, query]), rng, settings.coding, settings.dt)

    def present(trains: nv.SpikeSourceArray) -> np.ndarray:
        sim.run(settings.coding.presentation_ms, inputs={network.INPUT: trains})
        counts = sim.spike_counts(network.EXC)
        sim.reset()
        return counts

    for trains in train_trains:
        training.normalise_input_weights(sim, settings.weight_sum, settings.params.w_max)
        present(trains)
    sim.plasticity(False)
    counts = np.array([present(t) for t in test_trains])
    responses, q_counts = counts[:PLACES], counts[PLACES:]
    assignment = inference.assign_neurons(responses, np.arange(PLACES))
    # neurons that fire for every reference place carry no place information
    ignore = inference.hyperactive_neurons(inference.reference_activity(responses, measure="images"), PLACES)
    r_pred = inference.module_similarity(responses, assignment, PLACES, ignore=ignore).argmax(axis=0)
    q_pred = inference.module_similarity(q_counts, assignment, PLACES, ignore=ignore).argmax(axis=0)
    return sim.weights(network.INPUT_PROJECTION, format="list"), r_pred, q_pred


def test_module_learns_the_same_on_reference_and_brian2() -> None:
    info = discover().get("brian2")
    if info is None or not info.available:
        pytest.skip(f"brian2 backend not available: {info.reason if info else 'not declared'}")
    trav = synthetic_traverse(PLACES, seed=SEED)
    reference = preprocess_images(trav.references[0].array).reshape(PLACES, -1)
    query = preprocess_images(trav.query.array).reshape(PLACES, -1)
    w_ref, r_ref, q_ref = _run("reference", reference, query)
    w_b2, r_b2, q_b2 = _run("brian2", reference, query)
    r = np.corrcoef(w_ref, w_b2)[0, 1]
    assert r > 0.999, f"learned weights correlate with r = {r:.6f}"
    assert np.abs(w_ref - w_b2).max() < 1e-6
    assert (r_ref == r_b2).all(), f"reference predictions {r_ref} vs {r_b2}"
    assert (q_ref == q_b2).mean() >= 0.8, f"query predictions {q_ref} vs {q_b2}"
    assert len(set(r_ref.tolist())) >= 3, f"the module should tell reference places apart, got {r_ref}"
