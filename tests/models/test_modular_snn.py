"""Modular SNN: graph, training, inference equations, plan, resume, Dask, command line."""

from __future__ import annotations

import dataclasses
import importlib.metadata
import json
from pathlib import Path

import numpy as np
import pytest
from modular_tiny import TINY, synthetic_dataset, tiny_images

import neurovpr as nv
from neurovpr.data.ground_truth import GroundTruth
from neurovpr.evaluation.metrics import distance_from_similarity
from neurovpr.ir.connectivity import expand
from neurovpr.models.modular_snn import (
    MODEL,
    ModuleParameters,
    TrainingSettings,
    assign_neurons,
    best_threshold,
    build_module,
    calibrate_epochs,
    calibrate_threshold,
    ensemble_similarity,
    fuse_modules,
    hyperactive_neurons,
    make_plan,
    member_similarities,
    module_similarity,
    presentation_order,
    query_responses,
    record_assignments,
    reference_activity,
    train_module,
    train_run,
)
from neurovpr.models.modular_snn.parallel import read_npz
from neurovpr.models.modular_snn.plan import (
    calibration_places,
    default_calibration_places,
    describe_plan,
    place_split,
    split_queries,
)


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
    assert (exc.v_thresh, exc.v_reset, exc.tau_refrac, exc.tau_lockout, exc.theta_init) == (-52.0, -65.0, 5.0, 50.0, 0.0)
    assert (inh.cm, inh.tau_m, inh.v_rest, inh.e_rev_E, inh.e_rev_I) == (10.0, 10.0, -60.0, 0.0, -85.0)
    assert (inh.tau_syn_E, inh.tau_syn_I, inh.v_thresh, inh.v_reset, inh.tau_refrac) == (1.0, 0.5, -40.0, -45.0, 2.0)
    projs = net.projections
    stdp = projs["pixels->exc"].synapse
    assert isinstance(stdp, nv.DiehlCookSTDP)
    # the authors' code's rule: potentiation at a presynaptic arrival, triplet term at a postsynaptic spike
    rule = (stdp.eta_pre, stdp.eta_post, stdp.w_max, stdp.mu, stdp.x_tar, stdp.tau_post2, stdp.pre_term)
    assert rule == (1e-4, 1e-2, 1.0, 0.0, 0.0, 40.0, "potentiate")
    assert (stdp.tau_pre, stdp.tau_post) == (20.0, 20.0)
    assert projs["exc->inh"].synapse.weight == 10.4 and isinstance(projs["exc->inh"].connector, nv.OneToOneConnector)
    lateral = projs["lateral"]
    assert lateral.synapse.weight == 17.0 and lateral.receptor_type == "inhibitory"
    sizes = {name: expand(net, p, dt=0.1, seed=1).pre.size for name, p in projs.items()}
    assert sizes == {"pixels->exc": 784 * 400, "exc->inh": 400, "lateral": 400 * 399}


def test_graph_builder_seeded_weights_delays_and_papers_rule() -> None:
    net = build_module(ModuleParameters(stdp="paper", lockout_e=0.0), seed=7)
    syn = net.projections["pixels->exc"].synapse
    assert (syn.mu, syn.tau_post2, syn.pre_term) == (1.0, None, "depress")
    assert net.populations["exc"].cell_type.tau_lockout == 0.0
    assert syn.weight.shape == (784, 400) and 0.003 <= syn.weight.min() and syn.weight.max() < 0.303
    assert syn.delay.shape == (784, 400) and 0.1 <= syn.delay.min() and syn.delay.max() < 10.0
    again = build_module(ModuleParameters(stdp="paper"), seed=7).projections["pixels->exc"].synapse
    np.testing.assert_array_equal(syn.weight, again.weight)
    with pytest.raises(nv.ValidationError, match="stdp"):
        ModuleParameters(stdp="other")


# -------------------------------------------------------------------------- training
def test_training_a_tiny_module_is_deterministic() -> None:
    images = tiny_images(5)
    runs = [train_module(images, np.array([0, 1, 2]), TINY, seed=s) for s in (3, 3, 4)]
    (net_a, own_a, resp_a, _), (net_b, own_b, resp_b, _), (net_c, _, _, _) = runs
    w = [n.projections["pixels->exc"].synapse.weight for n in (net_a, net_b, net_c)]
    np.testing.assert_array_equal(w[0], w[1])
    np.testing.assert_array_equal(resp_a, resp_b)
    np.testing.assert_array_equal(own_a, own_b)
    assert own_a.shape == (3, 10) and own_a.sum() > 0
    np.testing.assert_array_equal(net_a.populations["exc"].cell_type.theta_init, net_b.populations["exc"].cell_type.theta_init)
    assert resp_a.shape == (5, 10) and resp_a.sum() > 0
    assert not np.array_equal(w[0], w[2])
    assert net_a.populations["exc"].cell_type.theta_init.max() > 0  # thresholds adapted


def test_papers_rule_and_simulated_rest_variants_train() -> None:
    settings = dataclasses.replace(TINY, params=dataclasses.replace(TINY.params, stdp="paper"), simulate_rest=True, epochs=1)
    net = settings.network("m", seed=1)
    assert net.populations["exc"].v_init == -105.0 and net.populations["inh"].v_init == -100.0
    learned, _, responses, timing = train_module(tiny_images(3), np.array([0, 1]), settings, seed=2)
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


def test_assignment_ties_go_to_the_place_shown_first() -> None:
    # neuron 0 ties between places 10 and 12, neuron 1 between all three, neuron 2 does not tie
    responses = np.array([[2, 1, 0], [1, 1, 3], [2, 1, 0]])
    places = np.array([10, 11, 12])
    np.testing.assert_array_equal(assign_neurons(responses, places), [10, 10, 11])  # row order
    np.testing.assert_array_equal(assign_neurons(responses, places, order=np.array([2, 1, 0])), [12, 12, 11])
    np.testing.assert_array_equal(assign_neurons(responses, places, order=np.array([1, 2, 0])), [12, 11, 11])
    with pytest.raises(nv.ValidationError, match="permutation"):
        assign_neurons(responses, places, order=np.array([0, 0, 1]))
    # a module record: the order comes from its seed, as the module was trained
    seed = 4
    order = presentation_order(seed, 3)
    record = {"places": places, "own_responses": responses, "seed": np.int64(seed)}
    np.testing.assert_array_equal(record_assignments(record), assign_neurons(responses, places, order=order))
    assert record_assignments(record)[1] == places[order[0]]  # the three-way tie: the first shown


def test_training_shows_places_in_presentation_order() -> None:
    # only the very last training presentation is counted for the assignment: its place is
    # the last of presentation_order (seed 3: place 3, neither the first nor the last index)
    settings = dataclasses.replace(TINY, epochs=1, assignment_presentations=1)
    places = np.arange(6)
    _, own, _, _ = train_module(tiny_images(6), places, settings, seed=3)
    last = presentation_order(3, places.size)[-1]
    assert last == 3
    assert own[last].sum() > 0
    np.testing.assert_array_equal(np.flatnonzero(own.sum(axis=1)), [last])


def test_hyperactive_neurons_counted_in_reference_images() -> None:
    responses = np.array([[50, 0, 3], [30, 1, 0], [0, 1, 0]])
    np.testing.assert_array_equal(reference_activity(responses), [2, 2, 1])  # the code: images fired for
    np.testing.assert_array_equal(reference_activity(responses, measure="spikes"), [80, 2, 3])
    np.testing.assert_array_equal(hyperactive_neurons(np.array([80, 2, 3]), 40.0), [True, False, False])
    np.testing.assert_array_equal(hyperactive_neurons(np.array([80, 40, 3]), 40.0), [True, True, False])
    np.testing.assert_array_equal(hyperactive_neurons(np.array([80, 40, 3]), 0.0), [False, False, False])  # 0: none


def test_threshold_calibration_skips_a_threshold_that_silences_every_neuron() -> None:
    # neurons 0 and 2 fire for 10 reference images and answer the wrong query; 1 and 3 for 1 image
    counts = np.array([[1, 1, 5, 0], [5, 0, 0, 1]])
    module = (counts, np.array([0, 0, 1, 1]), np.array([10, 1, 10, 1]))
    truth = GroundTruth(matrix=np.eye(2, dtype=bool))
    best, recall = calibrate_threshold([module], 2, np.array([0, 1]), truth, thresholds=(0, 1, 5))
    assert best == 5 and recall == {0: 0.0, 5: 1.0}  # at 1 every neuron is hyperactive: no result, as in the code


def test_threshold_ties_go_to_the_stricter_threshold_and_zero_marks_none_last() -> None:
    # 0 marks no neuron hyperactive: the loosest setting, chosen on a tie only when nothing else was evaluated
    assert best_threshold({0.0: 0.24, 20.0: 0.04, 80.0: 0.24, 200.0: 0.24}) == 80.0
    assert best_threshold({0.0: 0.24, 80.0: 0.20}) == 0.0  # a better Recall@1 still wins
    assert best_threshold({0.0: 0.10}) == 0.0
    assert best_threshold({}) == 0.0
    assert calibrate_epochs({30: {0.0: 0.5, 120.0: 0.5, 60.0: 0.5}}) == (30, 60.0)
    # in a calibration: no neuron of the calibration module fires for 5 or more images, so 0 and 5 tie
    counts = np.array([[5, 0], [0, 5]])
    module = (counts, np.array([0, 1]), np.array([2, 3]))
    best, recall = calibrate_threshold(
        [module], 2, np.array([0, 1]), GroundTruth(matrix=np.eye(2, dtype=bool)), thresholds=(0, 5)
    )
    assert recall == {0: 1.0, 5: 1.0} and best == 5


def test_epoch_calibration_takes_the_best_count_and_its_threshold() -> None:
    calibration = {
        20: {0.0: 0.19, 60.0: 0.40, 100.0: 0.39},
        30: {0.0: 0.37, 20.0: 0.48, 40.0: 0.46},
        60: {0.0: 0.10, 100.0: 0.32},
    }
    assert calibrate_epochs(calibration) == (30, 20.0)
    # ties: fewer epochs first, then the smaller threshold
    assert calibrate_epochs({40: {10.0: 0.5}, 30: {20.0: 0.5, 5.0: 0.5}}) == (30, 5.0)
    # a count without any evaluated threshold scores 0 at threshold 0, as calibrate_threshold answers then
    assert calibrate_epochs({10: {}, 20: {0.0: 0.0}}) == (10, 0.0)
    assert calibrate_epochs({10: {}, 20: {40.0: 0.1}}) == (20, 40.0)
    with pytest.raises(nv.ValidationError, match="at least one epoch count"):
        calibrate_epochs({})
    with pytest.raises(nv.ValidationError, match="epoch count 0"):
        calibrate_epochs({0: {0.0: 0.5}})
    with pytest.raises(nv.ValidationError, match=r"30 epochs at threshold 20\.0 is nan"):
        calibrate_epochs({30: {20.0: float("nan")}})


def test_module_similarity_fusion_ensemble_and_distance() -> None:
    counts = np.array([[4, 1, 0, 9], [0, 2, 3, 9]])  # 2 queries x 4 neurons
    assignments = np.array([0, 2, 2, -1])
    s = module_similarity(counts, assignments, 4, score="sum")
    np.testing.assert_array_equal(s, [[4, 0], [0, 0], [1, 5], [0, 0]])  # Eq. 7: spikes summed per place
    standard = module_similarity(counts, assignments, 4)  # the code: spikes per assigned neuron
    np.testing.assert_array_equal(standard, [[4, 0], [0, 0], [0.5, 2.5], [0, 0]])
    ignored = module_similarity(counts, assignments, 4, ignore=np.array([False, True, False, False]))
    np.testing.assert_array_equal(ignored[2], [0, 1.5])  # a hyperactive neuron is zeroed but still counted
    np.testing.assert_array_equal(module_similarity(counts, assignments, 4, ignore=[0, 1, 0, 0], score="sum")[2], [0, 3])
    with pytest.raises(nv.ValidationError, match="place score"):
        module_similarity(counts, assignments, 4, score="mean")
    other = module_similarity(np.array([[1, 1], [0, 7]]), np.array([1, 3]), 4, score="sum")
    fused = fuse_modules([s, other])  # Eq. 9
    np.testing.assert_array_equal(fused, [[4, 0], [1, 0], [1, 5], [1, 7]])
    ens = ensemble_similarity([fused, fused, s])  # Eq. 10
    np.testing.assert_array_equal(ens, 2 * fused + s)
    np.testing.assert_array_equal(distance_from_similarity(fused), 7 - fused)  # Eq. 11-12


def test_plan_puts_the_remainder_in_a_last_smaller_module() -> None:
    plan = make_plan(110, 25, members=2, seed=0, place_order="route")
    sizes = [len(p.places) for p in plan if p.member == 0]
    assert sizes == [25, 25, 25, 25, 10]
    np.testing.assert_array_equal(np.concatenate([p.places for p in plan if p.member == 1]), np.arange(110))
    assert len({p.seed for p in plan}) == len(plan)
    assert "last, smaller module of 10" in describe_plan(110, 25)
    shuffled = make_plan(110, 25, members=2, seed=0)  # the default: a random split per member
    assert sorted(np.concatenate([p.places for p in shuffled if p.member == 0]).tolist()) == list(range(110))
    assert not np.array_equal(shuffled[0].places, shuffled[5].places)
    assert [len(p.places) for p in shuffled if p.member == 0] == [25, 25, 25, 25, 10]


def test_plan_sets_calibration_places_aside_as_the_authors_code_does() -> None:
    # VPRSNN's get_shuffled_indices(150, 50, seed=0) began with these places (its shuffled_indices_L150_S0.npy)
    cal, rest = place_split(150, 50, 0)
    np.testing.assert_array_equal(cal[:10], [45, 12, 110, 85, 118, 143, 4, 15, 26, 76])
    assert np.array_equal(np.sort(np.concatenate([cal, rest])), np.arange(150))
    np.testing.assert_array_equal(np.sort(cal), calibration_places(150, 50))  # the same set for every seed
    np.testing.assert_array_equal(np.sort(place_split(150, 50, 9)[0]), np.sort(cal))
    plan = make_plan(150, 25, members=2, seed=0, n_calibration=50)
    for m in (0, 1):
        mods = [p for p in plan if p.member == m]
        assert [p.calibration for p in mods] == [True, True, False, False, False, False]
        np.testing.assert_array_equal(np.sort(np.concatenate([p.places for p in mods[:2]])), calibration_places(150, 50))
    assert not np.array_equal(plan[2].places, plan[8].places)  # each member its own split of the reported places
    route = make_plan(150, 25, members=1, seed=0, place_order="route", n_calibration=50)
    np.testing.assert_array_equal(np.concatenate([p.places for p in route[2:]]), np.setdiff1d(np.arange(150), cal))
    expected = "100 places in 4 module(s) of 25, reported; 50 places in 2 module(s) of 25, for calibration"
    assert describe_plan(150, 25, 50) == expected
    cal_q, test_q = split_queries(GroundTruth.aligned(150), calibration_places(150, 50))
    np.testing.assert_array_equal(cal_q, calibration_places(150, 50))
    np.testing.assert_array_equal(test_q, np.setdiff1d(np.arange(150), cal_q))
    assert [default_calibration_places(n, 25) for n in (30, 74, 75, 150, 3300)] == [0, 0, 25, 25, 650]
    with pytest.raises(nv.ValidationError, match="calibration places"):
        make_plan(20, 5, members=1, seed=0, n_calibration=20)


# ------------------------------------------------------------------ runs and resume
def _outcome(run_dir: Path, query: np.ndarray) -> tuple[dict, list[np.ndarray], dict[str, dict[str, np.ndarray]]]:
    info = json.loads((run_dir / "run.json").read_text())
    assert info["dt_ms"] == info["settings"]["dt"]  # what `neurovpr check --run` reads
    counts = query_responses(run_dir, info, query, progress=False)
    sims = member_similarities(run_dir, info, counts, GroundTruth.aligned(len(query))).similarities
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
    gt = GroundTruth.aligned(4)
    sims = member_similarities(tmp_path / "part", info, query_responses(tmp_path / "part", info, query, progress=False), gt)
    full_info = full["run_info"]
    full_counts = query_responses(tmp_path / "full", full_info, query, progress=False)
    full_sims = member_similarities(tmp_path / "full", full_info, full_counts, gt, members=[1, 2]).similarities
    for x, y in zip(sims.similarities, full_sims, strict=True):
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
        plots = tmp_path / "activity"
        evaluate = ["eval", "--run", str(run_dir), "--seq-len", "2", "--json", "--no-progress"]
        assert main([*evaluate, "--activity-plots", str(plots)]) == 0
        result = json.loads(capsys.readouterr().out)
        # the raster and rates of the first reported module shown the first query image, learning off
        activity = json.loads((plots / "activity_summary.json").read_text())
        assert result["activity_plots"]["rates"] == str(plots / "rates.png") and (plots / "raster.png").is_file()
        assert activity["title"].startswith("Modular SNN module ") and activity["duration_ms"] == 350.0
        assert activity["populations"]["exc"]["neurons"] == 20 and activity["populations"]["pixels"]["spikes"] > 0
    else:  # the entry point is not installed yet: build the requests the way the CLI does
        from neurovpr.cli.train_cmd import train_request

        argv = ["--model", "modular", "--data", str(data), "--out", str(run_dir), "--seed", "3", *opts]
        summary = MODEL.train(train_request(MODEL, argv)[1])
        result = MODEL.evaluate(run=run_dir, seq_len=2, progress=False)
    assert summary["complete"] and "last, smaller module of 1" in summary["plan"]
    info = json.loads((run_dir / "run.json").read_text())
    assert info["model"] == "modular" and info["members"] == 2 and len(info["modules"]) == 6
    assert result["model"] == "modular" and result["seq_len"] == 2 and result["ensemble_size"] == 2
    assert {"R@1", "R@5", "P@100R", "AUC_PR"} <= set(result["metrics"]) and "SAD" in result["baselines"]
    # the concentration of best matches next to the metrics (sequence length 2: one query fewer than places)
    conc = result["concentration"]
    n_queries = result["reported"]["queries"] - 1
    assert conc["queries"] == n_queries and 1 <= conc["distinct_best_matches"] <= n_queries
    assert conc["top_places"] >= 1 and conc["top_places"] / n_queries <= conc["top_share"] <= 1.0
    assert set(result["baseline_concentration"]) == {"SAD", "Perfect Memory"}
    for key in ("json", "distance_matrix", "pr_curve", "recall_at_n"):
        path = Path(result["files"][key])
        assert path.is_file() and path.stat().st_size > 0
    assert json.loads(Path(result["files"]["json"]).read_text())["metrics"] == result["metrics"]
