"""Modular SNN: the training loop written out, and training on several reference traverses."""

from __future__ import annotations

import dataclasses
import importlib.metadata
import io
import json
from pathlib import Path

import numpy as np
import pytest
from modular_tiny import TINY, synthetic_dataset, tiny_images

import neurovpr as nv
from neurovpr.data.ground_truth import GroundTruth
from neurovpr.models.modular_snn import (
    MODEL,
    fuse_modules,
    hyperactive_neurons,
    member_similarities,
    module_similarity,
    query_responses,
    record_assignments,
    train_module,
    train_run,
)
from neurovpr.models.modular_snn.parallel import read_npz, train_job


def test_training_repeats_the_written_out_loop() -> None:
    """One presentation order drawn per module and repeated every epoch; assignment from the last presentations."""
    from neurovpr.models.modular_snn.network import INPUT_PROJECTION
    from neurovpr.models.modular_snn.training import Presenter, normalise_input_weights, record_responses

    settings = dataclasses.replace(TINY, epochs=3, assignment_presentations=4)
    images, places, seed = tiny_images(5, seed=4).reshape(5, -1), np.array([0, 2, 3]), 6
    sim = nv.compile(settings.network("module", seed), backend=settings.backend, dt=settings.dt, seed=seed)
    presenter = Presenter(sim, settings)
    order = np.random.default_rng([seed, 1]).permutation(places.size)
    summed, shown = np.zeros((3, 10)), np.zeros(3)
    for epoch in range(settings.epochs):
        for j, k in enumerate(order):
            normalise_input_weights(sim, settings.weight_sum, settings.params.w_max)
            counts = presenter.present(images[places[k]])
            if epoch * 3 + j >= settings.epochs * 3 - 4:  # the last 4 presentations, while learning
                summed[k] += counts
                shown[k] += 1
    sim.plasticity(False)
    recorded = record_responses(presenter, images)
    net, own, responses, _ = train_module(images, places, settings, seed=seed)
    np.testing.assert_array_equal(responses, recorded)
    np.testing.assert_array_equal(own, summed / np.maximum(shown, 1)[:, None])
    assert sorted(shown.tolist()) == [1.0, 1.0, 2.0]  # the last place of the order is counted in the last two epochs
    learned = sim.to_network("module").projections[INPUT_PROJECTION].synapse.weight
    np.testing.assert_array_equal(net.projections[INPUT_PROJECTION].synapse.weight, learned)


def test_extra_traverse_is_presented_every_epoch_and_recorded() -> None:
    ref, extra, places = tiny_images(5, seed=1), tiny_images(5, seed=7), np.array([1, 3, 4])
    ticks = {"one": 0, "two": 0}

    def counter(key: str):
        def tick() -> None:
            ticks[key] += 1

        return tick

    net_1, _, resp_1, _ = train_module(ref, places, TINY, seed=2, tick=counter("one"))
    net_2, own_2, resp_2, _ = train_module(ref, places, TINY, seed=2, tick=counter("two"), extra_references=[extra])
    # places x traverses x epochs training presentations, then every image of every traverse once
    assert ticks == {"one": 3 * 1 * TINY.epochs + 5, "two": 3 * 2 * TINY.epochs + 2 * 5}
    assert resp_1.shape == (5, 10) and resp_2.shape == (10, 10) and resp_2[5:].sum() > 0 and own_2.shape == (3, 10)
    w_1, w_2 = (n.projections["pixels->exc"].synapse.weight for n in (net_1, net_2))
    assert not np.array_equal(w_1, w_2)
    with pytest.raises(nv.ValidationError, match="training traverse 1"):
        train_module(ref, places, TINY, seed=2, extra_references=[tiny_images(4)])
    # the module record: the assignment responses, activity over the main traverse (the code's record mode)
    cfg = json.dumps(TINY.as_dict(), sort_keys=True)
    shared = np.concatenate([ref, extra]).reshape(10, -1)
    result = train_job(shared, cfg, "m", places, 2, "fp", 2)
    with np.load(io.BytesIO(result["record"]), allow_pickle=False) as rec:
        np.testing.assert_array_equal(rec["own_responses"], own_2)
        np.testing.assert_array_equal(rec["total_spikes"], resp_2[:5].sum(axis=0))
        np.testing.assert_array_equal(rec["images_fired"], np.count_nonzero(resp_2[:5], axis=0))
        assert int(rec["n_traverses"]) == 2


def test_run_with_an_extra_traverse_records_it_and_resume_checks_it(tmp_path: Path) -> None:
    ref, extra, other = tiny_images(4, seed=1), tiny_images(4, seed=8), tiny_images(4, seed=9)
    kw = {"members": 1, "seed": 5, "workers": 1, "progress": False, "theta": 3.0}
    part = train_run(tmp_path / "run", ref, TINY, max_modules=1, extra_references=[extra], **kw)
    assert not part["complete"] and part["training_traverses"] == 2
    for changed in ([other], []):  # another extra traverse, or none: refused, never mixed in
        with pytest.raises(nv.ValidationError, match="other settings, data"):
            train_run(tmp_path / "run", ref, TINY, resume=True, extra_references=changed, **kw)
    done = train_run(tmp_path / "run", ref, TINY, resume=True, extra_references=[extra], **kw)
    assert done["complete"] and done["skipped_finished"] == 1
    info = json.loads((tmp_path / "run" / "run.json").read_text())
    assert info["training_traverses"] == 2 and len(info["extra_reference_digests"]) == 1
    assert info["extra_reference_digests"][0] != info["reference_digest"]
    assert info["hyperactive"]["theta"] == 3.0 and info["calibration_places"] == []
    for mod in info["modules"]:
        rec = read_npz(tmp_path / "run" / "modules" / f"{mod['name']}.npz")
        n_places = len(mod["places"])
        assert int(rec["n_traverses"]) == 2 and int(rec["n_presentations"]) == 2 * (TINY.epochs * n_places + 4)
        assert rec["own_responses"].shape == (n_places, 10) and int(rec["images_fired"].max()) <= 4
    with pytest.raises(nv.ValidationError, match="extra reference traverse 1 has 3 images"):
        train_run(tmp_path / "bad", ref, TINY, extra_references=[tiny_images(3)], **kw)
    assert not (tmp_path / "bad").exists()
    # the fixed threshold applies to the images each neuron fired for, every place is reported
    records = [read_npz(tmp_path / "run" / "modules" / f"{m['name']}.npz") for m in info["modules"]]
    counts = query_responses(tmp_path / "run", info, tiny_images(4, seed=2), progress=False)
    ms = member_similarities(tmp_path / "run", info, counts, GroundTruth.aligned(4))
    expected = fuse_modules(
        [
            module_similarity(
                counts[m["name"]],
                record_assignments(r),
                4,
                ignore=hyperactive_neurons(r["images_fired"], 3.0),
            )
            for m, r in zip(info["modules"], records, strict=True)
        ]
    )
    np.testing.assert_array_equal(ms.similarities[0], expected)
    np.testing.assert_array_equal(ms.places, np.arange(4))
    assert ms.thresholds == [3.0] and ms.calibration == [{}]
    # the neurons behind each reported place, from the same assignments and threshold
    anatomy = ms.anatomy[0]
    assignments = np.concatenate([record_assignments(r) for r in records])
    fired = np.concatenate([r["images_fired"] for r in records])
    np.testing.assert_array_equal(anatomy["assigned"], np.bincount(assignments[assignments >= 0], minlength=4))
    keep = (assignments >= 0) & (fired < 3)
    np.testing.assert_array_equal(anatomy["kept"], np.bincount(assignments[keep], minlength=4))


def _conditions_dataset(folder: Path, n: int, season: float, name: str) -> Path:
    from neurovpr.data.generic import write_generic
    from neurovpr.data.synthetic import AppearanceChange, synthetic_traverse

    change = AppearanceChange(season=season, illumination=0.8, contrast=0.9)
    return write_generic(synthetic_traverse(n, seed=2, reference=change), folder / name)


def _entry_point_installed() -> bool:
    return any(ep.name == "modular" for ep in importlib.metadata.entry_points(group="neurovpr.models"))


def _train_cli(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, dict, str]:
    """``neurovpr train --model modular ARGS``: exit code, JSON summary and error text."""
    if _entry_point_installed():
        from neurovpr.cli.main import main

        code = main(["train", "--model", "modular", "--json", *args])
        out = capsys.readouterr()
        return code, json.loads(out.out) if code == 0 else {}, out.err
    from neurovpr.cli.train_cmd import train_request

    try:  # the entry point is not installed yet: build the request the way the CLI does
        return 0, MODEL.train(train_request(MODEL, ["--model", "modular", *args])[1]), ""
    except nv.ValidationError as exc:
        return 2, {}, str(exc)


def test_cli_trains_on_an_extra_reference_traverse(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = synthetic_dataset(tmp_path, 5)
    extra = _conditions_dataset(tmp_path, 6, 0.5, "autumn")
    opts = ["--epochs", "1", "--module-size", "3", "--neurons", "10", "--workers", "1", "--no-progress", "--places", "5"]
    run_dir = tmp_path / "run"
    code, summary, _ = _train_cli(["--data", str(data), "--out", str(run_dir), "--extra-reference", str(extra), *opts], capsys)
    assert code == 0 and summary["complete"] and summary["training_traverses"] == 2
    info = json.loads((run_dir / "run.json").read_text())
    assert info["extra_references"] == [str(extra.resolve())] and info["training_traverses"] == 2
    rec = read_npz(run_dir / "modules" / "m00_k000.npz")
    assert int(rec["n_presentations"]) == 2 * (1 * 3 + 5)
    code, _, _ = _train_cli(["--data", str(data), "--out", str(tmp_path / "alone"), *opts], capsys)
    w = [nv.load(d / "modules" / "m00_k000.h5").projections["pixels->exc"].synapse.weight for d in (run_dir, tmp_path / "alone")]
    assert code == 0 and not np.array_equal(w[0], w[1])  # the extra traverse's images were learned from
    # without --places the counts (5 and 6) differ: one error naming both, before anything is trained
    bad = tmp_path / "bad"
    code, _, error = _train_cli(["--data", str(data), "--out", str(bad), "--extra-reference", str(extra), *opts[:-2]], capsys)
    assert code == 2 and error.strip().count("\n") == 0
    assert all(s in error for s in (str(extra), str(data), "has 6 reference places", "has 5"))
    assert not bad.exists()
