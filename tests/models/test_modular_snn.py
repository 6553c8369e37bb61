"""Modular SNN: graph, training, inference equations, plan, resume, Dask, command line."""

from __future__ import annotations

import argparse
import dataclasses
import importlib.metadata
import io
import json
from pathlib import Path

import numpy as np
import pytest
from modular_tiny import TINY, synthetic_dataset, tiny_images

import neurovpr as nv
from neurovpr.evaluation.metrics import distance_from_similarity
from neurovpr.ir.connectivity import expand
from neurovpr.models.modular_snn import (
    MODEL,
    ModuleParameters,
    TrainingSettings,
    assign_neurons,
    build_module,
    draw_hyperactive_threshold,
    ensemble_similarity,
    fuse_modules,
    hyperactive_neurons,
    make_plan,
    member_similarities,
    module_similarity,
    query_responses,
    reference_activity,
    train_module,
    train_run,
)
from neurovpr.models.modular_snn.parallel import read_npz
from neurovpr.models.modular_snn.runs import describe_plan


# ----------------------------------------------------------------------------- graph
def test_graph_builder_has_the_papers_parameters() -> None:
    net = build_module()
    pops = net.populations
    assert (pops["pixels"].size, pops["exc"].size, pops["inh"].size) == (784, 400, 400)
    exc, inh = pops["exc"].cell_type, pops["inh"].cell_type
    assert isinstance(exc, nv.IF_cond_exp_adaptive) and isinstance(inh, nv.IF_cond_exp)
    # conductances in units of the leak: cm = tau_m
    assert (exc.cm, exc.tau_m, exc.v_rest, exc.e_rev_E, exc.e_rev_I) == (100.0, 100.0, -65.0, 0.0, -100.0)
    assert (exc.tau_syn_E, exc.tau_syn_I, exc.theta_plus, exc.tau_theta) == (1.0, 0.5, 0.05, 1e7)
    assert (exc.v_thresh, exc.v_reset, exc.tau_refrac, exc.theta_init) == (-52.0, -65.0, 5.0, 0.0)
    assert (inh.cm, inh.tau_m, inh.v_rest, inh.e_rev_E, inh.e_rev_I) == (10.0, 10.0, -60.0, 0.0, -85.0)
    assert (inh.tau_syn_E, inh.tau_syn_I, inh.v_thresh, inh.v_reset, inh.tau_refrac) == (1.0, 0.5, -40.0, -45.0, 2.0)
    projs = net.projections
    stdp = projs["pixels->exc"].synapse
    assert isinstance(stdp, nv.DiehlCookSTDP)
    assert (stdp.eta_pre, stdp.eta_post, stdp.w_max, stdp.mu, stdp.tau_post2) == (1e-4, 1e-2, 1.0, 1.0, None)
    assert projs["exc->inh"].synapse.weight == 10.4 and isinstance(projs["exc->inh"].connector, nv.OneToOneConnector)
    lateral = projs["lateral"]
    assert lateral.synapse.weight == 17.0 and lateral.receptor_type == "inhibitory"
    sizes = {name: expand(net, p, dt=0.5, seed=1).pre.size for name, p in projs.items()}
    assert sizes == {"pixels->exc": 784 * 400, "exc->inh": 400, "lateral": 400 * 399}


def test_graph_builder_seeded_weights_delays_and_published_rule() -> None:
    net = build_module(ModuleParameters(stdp="published"), seed=7)
    syn = net.projections["pixels->exc"].synapse
    assert (syn.mu, syn.tau_post2) == (0.0, 40.0)
    assert syn.weight.shape == (784, 400) and 0.003 <= syn.weight.min() and syn.weight.max() < 0.303
    assert syn.delay.shape == (784, 400) and 0.5 <= syn.delay.min() and syn.delay.max() < 10.0
    again = build_module(ModuleParameters(stdp="published"), seed=7).projections["pixels->exc"].synapse
    np.testing.assert_array_equal(syn.weight, again.weight)
    with pytest.raises(nv.ValidationError, match="stdp"):
        ModuleParameters(stdp="other")


# -------------------------------------------------------------------------- training
def test_training_a_tiny_module_is_deterministic() -> None:
    images = tiny_images(5)
    runs = [train_module(images, np.array([0, 1, 2]), TINY, seed=s) for s in (3, 3, 4)]
    (net_a, resp_a, _), (net_b, resp_b, _), (net_c, _, _) = runs
    w = [n.projections["pixels->exc"].synapse.weight for n in (net_a, net_b, net_c)]
    np.testing.assert_array_equal(w[0], w[1])
    np.testing.assert_array_equal(resp_a, resp_b)
    np.testing.assert_array_equal(net_a.populations["exc"].cell_type.theta_init, net_b.populations["exc"].cell_type.theta_init)
    assert resp_a.shape == (5, 10) and resp_a.sum() > 0
    assert not np.array_equal(w[0], w[2])
    assert net_a.populations["exc"].cell_type.theta_init.max() > 0  # thresholds adapted


def test_published_rule_and_simulated_rest_variants_train() -> None:
    settings = dataclasses.replace(TINY, params=dataclasses.replace(TINY.params, stdp="published"), simulate_rest=True, epochs=1)
    net = settings.network("m", seed=1)
    assert net.populations["exc"].v_init == -105.0 and net.populations["inh"].v_init == -100.0
    learned, responses, timing = train_module(tiny_images(3), np.array([0, 1]), settings, seed=2)
    assert responses.shape == (3, 10) and responses.sum() > 0 and timing["train_seconds"] > 0
    start = net.projections["pixels->exc"].synapse.weight
    assert not np.array_equal(learned.projections["pixels->exc"].synapse.weight, start)


def test_training_refuses_bad_input() -> None:
    with pytest.raises(nv.ValidationError, match="pixels"):
        train_module(tiny_images(3)[:, :4, :4], np.array([0]), TINY, seed=1)
    with pytest.raises(nv.ValidationError, match="place indices"):
        train_module(tiny_images(3), np.array([5]), TINY, seed=1)
    with pytest.raises(nv.ValidationError, match="epochs"):
        TrainingSettings(epochs=0)
    with pytest.raises(nv.ValidationError, match="delay"):
        TrainingSettings(dt=1.0)


# ------------------------------------------------------------------------- equations
def test_assignment_is_eq4_argmax_with_unassigned_silent_neurons() -> None:
    responses = np.array([[3, 0, 1, 0], [5, 0, 1, 0], [1, 2, 1, 0]])  # 3 places x 4 neurons
    a = assign_neurons(responses, np.array([10, 11, 12]))
    np.testing.assert_array_equal(a, [11, 12, 10, -1])  # tie in neuron 2 -> first place


def test_hyperactive_neurons_and_theta_draws() -> None:
    responses = np.array([[50, 0, 3], [30, 1, 0], [0, 1, 0]])
    np.testing.assert_array_equal(reference_activity(responses), [80, 2, 3])
    np.testing.assert_array_equal(reference_activity(responses, measure="images"), [2, 2, 1])
    np.testing.assert_array_equal(hyperactive_neurons(np.array([80, 2, 3]), 40.0), [True, False, False])
    np.testing.assert_array_equal(hyperactive_neurons(np.array([80, 40, 3]), 40.0), [True, True, False])
    rng = np.random.default_rng(0)
    small = [draw_hyperactive_threshold(999, rng) for _ in range(200)]
    large = [draw_hyperactive_threshold(1000, rng) for _ in range(200)]
    assert 40 <= min(small) and max(small) <= 100 and 600 <= min(large) and max(large) <= 800


def test_module_similarity_fusion_ensemble_and_distance() -> None:
    counts = np.array([[4, 1, 0, 9], [0, 2, 3, 9]])  # 2 queries x 4 neurons
    assignments = np.array([0, 2, 2, -1])
    s = module_similarity(counts, assignments, 4)
    np.testing.assert_array_equal(s, [[4, 0], [0, 0], [1, 5], [0, 0]])  # Eq. 7: spikes summed per place
    np.testing.assert_array_equal(module_similarity(counts, assignments, 4, score="mean")[2], [0.5, 2.5])
    ignored = module_similarity(counts, assignments, 4, ignore=np.array([False, True, False, False]))
    np.testing.assert_array_equal(ignored[2], [0, 3])
    other = module_similarity(np.array([[1, 1], [0, 7]]), np.array([1, 3]), 4)
    fused = fuse_modules([s, other])  # Eq. 9
    np.testing.assert_array_equal(fused, [[4, 0], [1, 0], [1, 5], [1, 7]])
    ens = ensemble_similarity([fused, fused, s])  # Eq. 10
    np.testing.assert_array_equal(ens, 2 * fused + s)
    np.testing.assert_array_equal(distance_from_similarity(fused), 7 - fused)  # Eq. 11-12


def test_plan_puts_the_remainder_in_a_last_smaller_module() -> None:
    plan = make_plan(110, 25, members=2, seed=0)
    sizes = [len(p.places) for p in plan if p.member == 0]
    assert sizes == [25, 25, 25, 25, 10]
    np.testing.assert_array_equal(np.concatenate([p.places for p in plan if p.member == 1]), np.arange(110))
    assert len({p.seed for p in plan}) == len(plan)
    assert "last, smaller module of 10" in describe_plan(110, 25)
    shuffled = make_plan(110, 25, members=2, seed=0, place_order="shuffled")
    assert sorted(np.concatenate([p.places for p in shuffled if p.member == 0]).tolist()) == list(range(110))
    assert not np.array_equal(shuffled[0].places, shuffled[5].places)


# ------------------------------------------------------------------ runs and resume
def _outcome(run_dir: Path, query: np.ndarray) -> tuple[dict, list[np.ndarray], dict[str, dict[str, np.ndarray]]]:
    info = json.loads((run_dir / "run.json").read_text())
    assert info["dt_ms"] == info["settings"]["dt"]  # what `neurovpr check --run` reads
    counts = query_responses(run_dir, info, query, progress=False)
    sims = member_similarities(run_dir, info, counts)
    records = {p.stem: read_npz(p) for p in sorted((run_dir / "modules").glob("*.npz"))}
    for rec in records.values():
        for key in [k for k in rec if k.endswith("seconds")]:
            del rec[key]
    weights = {p.stem: nv.load(p).projections["pixels->exc"].synapse.weight for p in (run_dir / "modules").glob("*.h5")}
    return info, sims, {name: {**rec, "w": weights[name]} for name, rec in records.items()}


def _assert_same(a: tuple, b: tuple) -> None:
    info_a, sims_a, rec_a = a
    info_b, sims_b, rec_b = b
    assert info_a["hyperactive"] == info_b["hyperactive"] and info_a["modules"] == info_b["modules"]
    for x, y in zip(sims_a, sims_b, strict=True):
        np.testing.assert_array_equal(x, y)
    assert rec_a.keys() == rec_b.keys()
    for name in rec_a:
        for key in rec_a[name]:
            np.testing.assert_array_equal(rec_a[name][key], rec_b[name][key], err_msg=f"{name}: {key}")


def test_resume_gives_the_same_result_as_an_uninterrupted_run(tmp_path: Path) -> None:
    ref, query = tiny_images(7, seed=1), tiny_images(7, seed=2)
    kw = {"members": 2, "seed": 5, "workers": 1, "progress": False}
    done = train_run(tmp_path / "full", ref, TINY, **kw)
    assert done["complete"] and done["modules_per_member"] == 3  # 7 places: 3 + 3 + a last module of 1
    part = train_run(tmp_path / "part", ref, TINY, max_modules=2, **kw)
    assert not part["complete"] and part["remaining_modules"] == 4 and not (tmp_path / "part" / "run.json").exists()
    with pytest.raises(nv.ValidationError, match="--resume"):
        train_run(tmp_path / "part", ref, TINY, **kw)
    rest = train_run(tmp_path / "part", ref, TINY, resume=True, **kw)
    assert rest["complete"] and rest["skipped_finished"] == 2 and rest["trained_now"] == 4
    _assert_same(_outcome(tmp_path / "full", query), _outcome(tmp_path / "part", query))
    with pytest.raises(nv.ValidationError, match="other settings"):
        train_run(tmp_path / "part", ref, dataclasses.replace(TINY, epochs=1), resume=True, **kw)


def test_members_trained_apart_equal_the_members_of_a_full_run(tmp_path: Path) -> None:
    ref, query = tiny_images(4, seed=1), tiny_images(4, seed=2)
    kw = {"members": 3, "seed": 5, "workers": 1, "progress": False}
    full = train_run(tmp_path / "full", ref, TINY, **kw)
    part = train_run(tmp_path / "part", ref, TINY, only_members=[2, 1], **kw)
    assert not part["complete"] and part["remaining_modules"] == 2 and not (tmp_path / "part" / "run.json").exists()
    info = part["run_info"]
    assert {m["member"] for m in info["modules"]} == {1, 2}
    assert info["hyperactive"] == full["run_info"]["hyperactive"]
    sims = member_similarities(tmp_path / "part", info, query_responses(tmp_path / "part", info, query, progress=False))
    full_info = full["run_info"]
    full_sims = member_similarities(
        tmp_path / "full", full_info, query_responses(tmp_path / "full", full_info, query, progress=False), members=[1, 2]
    )
    for x, y in zip(sims, full_sims, strict=True):
        np.testing.assert_array_equal(x, y)
    trained = sorted(p.stem for p in (tmp_path / "part" / "modules").glob("*.h5"))
    assert trained == ["m01_k000", "m01_k001", "m02_k000", "m02_k001"]
    rest = train_run(tmp_path / "part", ref, TINY, resume=True, only_members=[0], **kw)
    assert rest["complete"] and rest["trained_now"] == 2 and (tmp_path / "part" / "run.json").exists()
    with pytest.raises(nv.ValidationError, match="only_members"):
        train_run(tmp_path / "bad", ref, TINY, only_members=[3], **kw)


def test_dask_local_cluster_and_process_pool_equal_in_process_training(tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed")
    ref, query = tiny_images(4, seed=3), tiny_images(4, seed=4)
    kw = {"members": 2, "seed": 9, "progress": False}
    train_run(tmp_path / "inline", ref, TINY, workers=1, **kw)
    train_run(tmp_path / "pool", ref, TINY, workers=2, **kw)
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None) as cluster:
        train_run(tmp_path / "dask", ref, TINY, scheduler=cluster.scheduler_address, **kw)
    inline = _outcome(tmp_path / "inline", query)
    _assert_same(inline, _outcome(tmp_path / "pool", query))
    _assert_same(inline, _outcome(tmp_path / "dask", query))


# ---------------------------------------------------------------------- command line
def _entry_point_installed() -> bool:
    return any(ep.name == "modular" for ep in importlib.metadata.entry_points(group="neurovpr.models"))


def test_train_and_eval_write_run_json_results_and_plots(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = synthetic_dataset(tmp_path, 7)
    run_dir = tmp_path / "run"
    opts = ["--members", "2", "--epochs", "1", "--module-size", "3", "--neurons", "20", "--workers", "1", "--no-progress"]
    if _entry_point_installed():
        from neurovpr.cli.main import main

        assert (
            main(["train", "--model", "modular", "--data", str(data), "--out", str(run_dir), "--seed", "3", "--json", *opts]) == 0
        )
        summary = json.loads(capsys.readouterr().out)
        assert main(["eval", "--run", str(run_dir), "--seq-len", "2", "--json", "--no-progress"]) == 0
        result = json.loads(capsys.readouterr().out)
    else:  # the entry point is not installed yet: drive the plugin the way the CLI does
        p = argparse.ArgumentParser()
        MODEL.add_train_arguments(p)
        targs = p.parse_args(opts)
        targs.__dict__.update(data=data, out=run_dir, backend="reference", seed=3, scheduler=None, resume=False)
        summary = MODEL.train(targs)
        p = argparse.ArgumentParser()
        MODEL.add_eval_arguments(p)
        eargs = p.parse_args(["--no-progress"])
        eargs.__dict__.update(run=run_dir, data=None, backend=None, seq_len=2, scheduler=None)
        result = MODEL.evaluate(eargs, json.loads((run_dir / "run.json").read_text()))
    assert summary["complete"] and "last, smaller module of 1" in summary["plan"]
    info = json.loads((run_dir / "run.json").read_text())
    assert info["model"] == "modular" and info["members"] == 2 and len(info["modules"]) == 6
    assert result["model"] == "modular" and result["seq_len"] == 2 and result["ensemble_size"] == 2
    assert {"R@1", "R@5", "P@100R", "AUC_PR"} <= set(result["metrics"]) and "SAD" in result["baselines"]
    for key in ("json", "distance_matrix", "pr_curve", "recall_at_n"):
        path = Path(result["files"][key])
        assert path.is_file() and path.stat().st_size > 0
    assert json.loads(Path(result["files"]["json"]).read_text())["metrics"] == result["metrics"]


# ------------------------------------------------------- several training traverses
# Computed with the single-traverse code before training on extra traverses existed:
# train_module(tiny_images(5), [0, 1, 2], TINY, seed=3) and the module records of
# train_run(tiny_images(4, seed=1), TINY, members=1, seed=5).
_EXPECTED_RESPONSES = [
    [1, 2, 1, 1, 2, 3, 1, 1, 2, 1],
    [2, 1, 1, 0, 2, 2, 1, 0, 1, 2],
    [2, 2, 2, 2, 3, 2, 2, 1, 2, 3],
    [2, 1, 2, 1, 2, 2, 1, 1, 1, 1],
    [2, 2, 2, 2, 2, 0, 3, 3, 3, 2],
]
_EXPECTED_WEIGHT_SUM, _EXPECTED_THETA_SUM = 401.2168121250197, 4.849856762771639
_EXPECTED_RECORDS = {
    "m00_k000": (
        [[1, 3, 0, 3, 0, 1, 2, 0, 2, 2], [1, 2, 1, 2, 1, 3, 2, 2, 1, 2], [3, 3, 2, 0, 1, 3, 2, 3, 1, 2]],
        [5, 10, 5, 6, 4, 9, 8, 8, 6, 7],
        [3, 4, 3, 3, 3, 4, 4, 3, 4, 4],
        "9797767ea834e2d28e65b138237375e81e49058f6ebc147d0be717f0216e0a1b",
    ),
    "m00_k001": (
        [[3, 2, 2, 2, 0, 0, 1, 1, 0, 3]],
        [8, 8, 5, 6, 6, 5, 5, 6, 3, 6],
        [4, 4, 3, 4, 3, 3, 3, 4, 3, 4],
        "ae68ba00b6aeb89753c01bf86af53af7bff2be82535e93417c7fe0249206b3c8",
    ),
}


def test_single_traverse_training_is_unchanged(tmp_path: Path) -> None:
    net, responses, _ = train_module(tiny_images(5), np.array([0, 1, 2]), TINY, seed=3)
    np.testing.assert_array_equal(responses, _EXPECTED_RESPONSES)
    assert float(net.projections["pixels->exc"].synapse.weight.sum()) == pytest.approx(_EXPECTED_WEIGHT_SUM, rel=1e-12)
    assert float(net.populations["exc"].cell_type.theta_init.sum()) == pytest.approx(_EXPECTED_THETA_SUM, rel=1e-12)
    summary = train_run(tmp_path / "run", tiny_images(4, seed=1), TINY, members=1, seed=5, workers=1, progress=False)
    assert summary["training_traverses"] == 1
    info = json.loads((tmp_path / "run" / "run.json").read_text())
    assert info["training_traverses"] == 1 and info["extra_reference_digests"] == []
    for name, (own, total, fired, fingerprint) in _EXPECTED_RECORDS.items():
        rec = read_npz(tmp_path / "run" / "modules" / f"{name}.npz")
        np.testing.assert_array_equal(rec["own_responses"], own)
        np.testing.assert_array_equal(rec["total_spikes"], total)
        np.testing.assert_array_equal(rec["images_fired"], fired)
        assert str(rec["fingerprint"]) == fingerprint  # runs started before still resume
        assert int(rec["n_traverses"]) == 1 and int(rec["n_presentations"]) == TINY.epochs * len(own) + 4


def test_single_traverse_training_repeats_the_former_loop() -> None:
    """The former single-traverse loop, written out: a permutation of the places per epoch."""
    from neurovpr.models.modular_snn.network import INPUT_PROJECTION
    from neurovpr.models.modular_snn.training import Presenter, normalise_input_weights, record_responses

    images, places, seed = tiny_images(5, seed=4).reshape(5, -1), np.array([0, 2, 3]), 6
    sim = nv.compile(TINY.network("module", seed), backend=TINY.backend, dt=TINY.dt, seed=seed)
    presenter, order_rng = Presenter(sim, TINY), np.random.default_rng([seed, 1])
    _, post = sim.connections(INPUT_PROJECTION)
    for _ in range(TINY.epochs):
        for place in order_rng.permutation(places):
            normalise_input_weights(sim, TINY.weight_sum, TINY.params.w_max, post)
            presenter.present(images[place])
    sim.plasticity(False)
    former = record_responses(presenter, images)
    net, responses, _ = train_module(images, places, TINY, seed=seed)
    np.testing.assert_array_equal(responses, former)
    learned = sim.to_network("module").projections["pixels->exc"].synapse.weight
    np.testing.assert_array_equal(net.projections["pixels->exc"].synapse.weight, learned)


def test_extra_traverse_is_presented_every_epoch_and_recorded() -> None:
    ref, extra, places = tiny_images(5, seed=1), tiny_images(5, seed=7), np.array([1, 3, 4])
    ticks = {"one": 0, "two": 0}

    def counter(key: str):
        def tick() -> None:
            ticks[key] += 1

        return tick

    net_1, resp_1, _ = train_module(ref, places, TINY, seed=2, tick=counter("one"))
    net_2, resp_2, _ = train_module(ref, places, TINY, seed=2, tick=counter("two"), extra_references=[extra])
    # places x traverses x epochs training presentations, then every image of every traverse once
    assert ticks == {"one": 3 * 1 * TINY.epochs + 5, "two": 3 * 2 * TINY.epochs + 2 * 5}
    assert resp_1.shape == (5, 10) and resp_2.shape == (10, 10) and resp_2[5:].sum() > 0
    w_1, w_2 = (n.projections["pixels->exc"].synapse.weight for n in (net_1, net_2))
    assert not np.array_equal(w_1, w_2)
    with pytest.raises(nv.ValidationError, match="training traverse 1"):
        train_module(ref, places, TINY, seed=2, extra_references=[tiny_images(4)])
    # the module record: responses to a place summed over the traverses, activity over all 10 images
    from neurovpr.models.modular_snn.parallel import train_job

    cfg = json.dumps(TINY.as_dict(), sort_keys=True)
    shared = np.concatenate([ref, extra]).reshape(10, -1)
    result = train_job(shared, cfg, "m", places, 2, "fp", 2)
    with np.load(io.BytesIO(result["record"]), allow_pickle=False) as rec:
        np.testing.assert_array_equal(rec["own_responses"], resp_2[places] + resp_2[5 + places])
        np.testing.assert_array_equal(rec["total_spikes"], resp_2.sum(axis=0))
        np.testing.assert_array_equal(rec["images_fired"], np.count_nonzero(resp_2, axis=0))
        assert int(rec["n_traverses"]) == 2


def test_run_with_an_extra_traverse_records_it_and_resume_checks_it(tmp_path: Path) -> None:
    ref, extra, other = tiny_images(4, seed=1), tiny_images(4, seed=8), tiny_images(4, seed=9)
    kw = {"members": 1, "seed": 5, "workers": 1, "progress": False}
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
    for mod in info["modules"]:
        rec = read_npz(tmp_path / "run" / "modules" / f"{mod['name']}.npz")
        n_places = len(mod["places"])
        assert int(rec["n_traverses"]) == 2 and int(rec["n_presentations"]) == 2 * (TINY.epochs * n_places + 4)
        assert rec["own_responses"].shape == (n_places, 10) and int(rec["images_fired"].max()) <= 8
    with pytest.raises(nv.ValidationError, match="extra reference traverse 1 has 3 images"):
        train_run(tmp_path / "bad", ref, TINY, extra_references=[tiny_images(3)], **kw)
    assert not (tmp_path / "bad").exists()
    # hyperactive activity is per training traverse: theta at 3/4 of the largest total ignores no neuron
    records = [read_npz(tmp_path / "run" / "modules" / f"{m['name']}.npz") for m in info["modules"]]
    info["hyperactive"]["thetas"] = [0.75 * max(int(r["total_spikes"].max()) for r in records)]
    counts = query_responses(tmp_path / "run", info, tiny_images(4, seed=2), progress=False)
    (sim,) = member_similarities(tmp_path / "run", info, counts)
    expected = fuse_modules(
        [
            module_similarity(counts[m["name"]], assign_neurons(r["own_responses"], r["places"]), 4)
            for m, r in zip(info["modules"], records, strict=True)
        ]
    )
    np.testing.assert_array_equal(sim, expected)


def _conditions_dataset(folder: Path, n: int, season: float, name: str) -> Path:
    from neurovpr.data.generic import write_generic
    from neurovpr.data.synthetic import AppearanceChange, synthetic_traverse

    change = AppearanceChange(season=season, illumination=0.8, contrast=0.9)
    return write_generic(synthetic_traverse(n, seed=2, reference=change), folder / name)


def _train_cli(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, dict, str]:
    """``neurovpr train --model modular ARGS``: exit code, JSON summary and error text."""
    if _entry_point_installed():
        from neurovpr.cli.main import main

        code = main(["train", "--model", "modular", "--json", *args])
        out = capsys.readouterr()
        return code, json.loads(out.out) if code == 0 else {}, out.err
    p = argparse.ArgumentParser()  # the entry point is not installed yet: drive the plugin the way the CLI does
    p.add_argument("--data", type=Path)
    p.add_argument("--out", type=Path)
    p.add_argument("--seed", type=int, default=0)
    MODEL.add_train_arguments(p)
    targs = p.parse_args(args)
    targs.__dict__.update(backend="reference", scheduler=None, resume=False)
    try:
        return 0, MODEL.train(targs), ""
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


@pytest.mark.slow
def test_demo_runs_end_to_end(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    if not _entry_point_installed():
        pytest.skip("the 'modular' entry point is not installed (pip install -e .)")
    from neurovpr.cli.main import main

    assert main(["demo", "--out", str(tmp_path / "demo"), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert set(summary["R@1"]) == {"Modular SNN", "Ensemble (3)", "SAD"}
    assert (tmp_path / "demo" / "summary.json").is_file()
    assert list((tmp_path / "demo").glob("*.png"))
