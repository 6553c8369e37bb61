"""The mushroom-body SNN: wiring, learning, test phase, speed changes, bad input, CLI integration."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import scipy.io

import neurovpr as nv
from neurovpr.apps.requests import TrainRequest
from neurovpr.data.events import EventStream, PNSpikes, stretch_time, write_events
from neurovpr.errors import ValidationError
from neurovpr.evaluation.metrics import auc_roc
from neurovpr.models.mbsnn import (
    KC_KC,
    MODEL,
    MBSNNParameters,
    build_network,
    compile_mbsnn,
    familiarity,
    naive_weights,
    paper_neuron_count,
    present,
    segment_labels,
    training,
)
from neurovpr.models.mbsnn.plugin import MBSNNEvalOptions, MBSNNTrainOptions
from neurovpr.models.mbsnn.synthetic import synthetic_traversal

N_PN = 120
SEGMENT = (0.4, 0.6)
#: 4 subgroups of 50 KCs, each KC onto 25 others
WIRING = MBSNNParameters(n_kc=200)
#: one subgroup, so that each KC has as many partners (100) as the small network allows
SMALL = MBSNNParameters(n_kc=200, kc_groups=1)


def _route(seed: int, duration_ms: float = 2000.0) -> PNSpikes:
    return synthetic_traversal(N_PN, duration_ms, route_seed=12, seed=seed)


@pytest.fixture(scope="module")
def learned():
    """A 200-KC mushroom body that learned 40-60 % of one synthetic traversal."""
    net = build_network(N_PN, SMALL, seed=3)
    sim = compile_mbsnn(net, dt=SMALL.dt, seed=3)
    first = _route(seed=1)
    response = present(sim, first.segment(*SEGMENT), learn=True)
    return sim, response


# -- wiring -----------------------------------------------------------------------------
def test_wiring_follows_the_paper():
    net = build_network(N_PN, WIRING, seed=0)
    assert list(net.populations) == ["input", "pn", "kc1", "kc2", "mbon"]
    assert type(net.populations["pn"].cell_type).__name__ == "IF_curr_exp_ca2_adaptive"
    assert net.populations["pn"].cell_type.i_alpha == 0.2 and net.populations["pn"].cell_type.i_offset == 0.02
    sim = nv.compile(net, dt=0.1, seed=5)
    # both compartments share the PN input, connection for connection, weight for weight
    pre1, post1 = sim.connections("pn->kc1")
    pre2, post2 = sim.connections("pn->kc2")
    assert np.array_equal(pre1, pre2) and np.array_equal(post1, post2)
    assert np.array_equal(sim.weights("pn->kc1", format="list"), sim.weights("pn->kc2", format="list"))
    degree = np.bincount(post1, minlength=WIRING.n_kc)
    assert degree.min() >= 1 and abs(degree.mean() - 5.0) < 0.25 and 0.6 < degree.std() < 1.4
    assert all(np.unique(pre1[post1 == j]).size == degree[j] for j in range(WIRING.n_kc))
    w = sim.weights("pn->kc1", format="list")
    assert w.min() >= 0 and abs(w.mean() - 0.3) < 0.02 and 0.07 < w.std() < 0.13
    # KC -> KC: 4 subgroups of 50, each KC onto 25 others of its own subgroup, all weights 0, plastic, inhibitory
    proj = net.projections[KC_KC]
    assert proj.receptor_type == "inhibitory" and proj.plastic
    rule = proj.synapse.timing_dependence
    assert (rule.tau_plus, rule.tau_minus, rule.A_plus, rule.A_minus) == (1.25, 0.1, 0.3, 0.15)
    assert proj.synapse.weight_bounds == (0.0, 0.5)
    pre, post = sim.connections(KC_KC)
    assert np.all(np.bincount(pre, minlength=WIRING.n_kc) == 25)
    assert np.all(pre // 50 == post // 50) and not np.any(pre == post)
    assert np.unique(pre * WIRING.n_kc + post).size == pre.size
    assert np.all(sim.weights(KC_KC, format="list") == 0.0)
    # only the second compartment excites the MBON
    assert {(p.pre, p.post) for p in net.projections.values() if p.post == "mbon"} == {("kc2", "mbon")}
    # the paper's 0.01 nA at 4000 KCs, scaled to keep the MBON's input at other sizes
    assert net.projections["kc2->mbon"].synapse.weight == pytest.approx(0.01 * 4000 / 200)
    assert MBSNNParameters().mbon_weight == 0.01


@pytest.fixture(scope="module")
def paper_network():
    """The paper's size: 840 PNs, 4000 two-compartment KCs, 1 MBON."""
    return build_network(840, MBSNNParameters(), seed=0)


def test_paper_size_and_neuron_count(paper_network):
    params = MBSNNParameters()
    assert (params.n_kc, params.group_size, params.targets_per_kc) == (4000, 1000, 500)
    assert paper_network.projections[KC_KC].connector.conn_list.shape == (4000 * 500, 2)
    counts = paper_neuron_count(paper_network)
    assert counts == {"graph_units": 840 + 840 + 8000 + 1, "simulated_neurons": 840 + 8000 + 1, "paper_count": 4841}


def test_bad_parameters_are_refused():
    with pytest.raises(ValidationError, match="n_kc=202 is not divisible into kc_groups=4"):
        MBSNNParameters(n_kc=202)
    with pytest.raises(ValidationError, match=r"kc_targets must be an integer in 1\.\.49"):
        MBSNNParameters(n_kc=200, kc_targets=50)
    with pytest.raises(ValidationError, match=r"dt must be <= 1\.0"):
        MBSNNParameters(dt=2.0)


# -- learning and testing --------------------------------------------------------------
def test_learning_makes_the_learned_segment_familiar(learned):
    sim, response = learned
    weights = sim.weights(KC_KC, format="list")
    assert response.counts["kc1"] > 0 and 0 < np.mean(weights > 0) < 1 and weights.max() <= 0.5
    second = _route(seed=2)
    after = present(sim, second, learn=False)
    assert np.array_equal(sim.weights(KC_KC, format="list"), weights), "plasticity must be off at test"
    trained = sim.weights(KC_KC, format="list")
    sim.set_weights(KC_KC, naive_weights(sim))
    before = present(sim, second, learn=False)
    sim.set_weights(KC_KC, trained)
    assert after.counts["kc1"] == before.counts["kc1"]  # the first compartment has no plastic input
    assert after.counts["kc2"] < before.counts["kc2"]
    windows = 20
    fam = familiarity(before.rates(windows), after.rates(windows))
    labels = segment_labels(windows, *SEGMENT)
    assert fam[labels].mean() > fam[~labels].mean() + 0.05, (fam[labels].mean(), fam[~labels].mean())
    assert auc_roc(labels, fam) > 0.75


def test_plasticity_changes_weights_only_when_learning():
    net = build_network(N_PN, SMALL, seed=4)
    sim = compile_mbsnn(net, dt=SMALL.dt, seed=4)
    spikes = _route(seed=5, duration_ms=400.0)
    present(sim, spikes, learn=False)
    assert np.all(sim.weights(KC_KC, format="list") == 0.0) and not sim.plasticity_enabled
    present(sim, spikes, learn=True)
    assert np.any(sim.weights(KC_KC, format="list") > 0.0)


def test_time_stretching_is_a_speed_change(learned):
    sim, _ = learned
    second = _route(seed=2)
    slow = stretch_time(second, 1.25)  # the route driven at 80 % of the speed
    assert slow.duration_ms == pytest.approx(1.25 * second.duration_ms) and np.array_equal(slow.idx, second.idx)
    response = present(sim, slow, learn=False)
    assert response.duration_ms == pytest.approx(slow.duration_ms)
    assert response.rates(20).shape == (20,) and response.v.size == round(slow.duration_ms / sim.dt)


def test_familiarity_and_windows():
    assert np.allclose(familiarity([10.0, 0.0, 4.0], [5.0, 0.0, 6.0]), [0.5, 0.0, -0.5])
    assert segment_labels(10, 0.4, 0.6).tolist() == [False] * 4 + [True] * 2 + [False] * 4
    with pytest.raises(ValidationError, match="familiarity: rates before"):
        familiarity([1.0], [1.0, 2.0])



def test_learned_segment_file_and_grids(tmp_path):
    spikes = _route(seed=3, duration_ms=200.0)
    training.save_spikes(spikes, tmp_path / "seg.npz")
    back = training.load_spikes(tmp_path / "seg.npz")
    assert np.array_equal(back.times_ms, spikes.times_ms) and np.array_equal(back.idx, spikes.idx)
    assert (back.n_pn, back.duration_ms) == (spikes.n_pn, spikes.duration_ms)
    assert training.pn_grid(210) == ((10, 21), 5) and training.pn_grid(840) == ((20, 42), 10)
    assert training.parse_segment("0.25:0.5") == (0.25, 0.5)

# -- bad input -------------------------------------------------------------------------
def test_empty_stream_is_refused_before_the_network_is_built(tmp_path, monkeypatch):
    def no_build(*args, **kwargs):
        raise AssertionError("the network was built for an empty stream")

    monkeypatch.setattr(training, "build_network", no_build)
    # events that all fall in the cropped-away sky: no PN spike at all
    events = tmp_path / "sky.npz"
    write_events(EventStream(width=346, height=260, x=[10, 20, 30], y=[5, 6, 7], t=[0, 500, 1000], p=[1, 0, 1]), events)
    with pytest.raises(ValidationError, match="holds no projection-neuron spikes"):
        training.train(events, tmp_path / "run", learn=(0.4, 0.6))
    # a recording whose learned segment is silent
    quiet = tmp_path / "quiet.mat"
    scipy.io.savemat(quiet, {"t": np.r_[np.arange(0.0, 150.0, 3.0), 299.0], "idx": np.arange(51) % N_PN})
    with pytest.raises(ValidationError, match=r"learned segment 0\.5:0\.9 .* holds no projection-neuron spikes"):
        training.train(quiet, tmp_path / "run", learn=(0.5, 0.9), trim=False, n_pn=N_PN)
    assert not (tmp_path / "run" / "run.json").exists()
    with pytest.raises(ValidationError, match=r"--learn '0.6:0.2' must satisfy 0 <= START < END <= 1"):
        training.parse_segment("0.6:0.2")


# -- command line ----------------------------------------------------------------------
def _save_mat(path, spikes: PNSpikes) -> None:
    scipy.io.savemat(path, {"t": spikes.times_ms, "idx": spikes.idx.astype(float)})


def test_train_and_eval_through_the_plugin(tmp_path):
    first, second = tmp_path / "first.mat", tmp_path / "second.mat"
    _save_mat(first, _route(seed=1))
    _save_mat(second, _route(seed=2))
    out = tmp_path / "run"
    options = MBSNNTrainOptions(learn="0.4:0.6", n_kc=200, kc_groups=1, timestep=0.1, n_pn=N_PN, keep_still=True)
    train_request = TrainRequest(data=first, out=out, progress=False, options=options)
    summary = MODEL.train(train_request)
    info = json.loads((out / "run.json").read_text())
    assert info["model"] == "mbsnn" and info["learn"] == [0.4, 0.6] and summary["n_pn"] == N_PN
    assert info["dt_ms"] == info["parameters"]["dt_ms"]  # what `neurovpr check --run` reads
    assert (out / "network.h5").is_file() and info["neurons"]["paper_count"] == N_PN + 200 + 1
    loaded = nv.load(out / "network.h5")
    assert np.any(loaded.projections[KC_KC].synapse.weight > 0), "learned weights are saved"
    result = MODEL.evaluate(run=out, data=second, windows=20, progress=False)
    json.dumps(result)
    assert result["model"] == "mbsnn" and result["backend"] == "reference"
    assert set(result["baselines"]) == {"SeqSLAM", "PerfectMemory"}
    assert 0.0 <= result["metrics"]["AUC_ROC"] <= 1.0 and result["metrics"]["AUC_ROC"] > 0.7
    for name in ("mbon", "roc", "familiarity"):
        path = out / "eval" / "second_reference" / f"{name}.png"
        assert path.is_file() and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert json.loads((out / "eval" / "second_reference" / "result.json").read_text())["metrics"] == result["metrics"]
    # NeuroBench block of `eval --json`: per window of the trained pass
    from neurovpr.evaluation.neurobench import neurobench_block

    block = neurobench_block(out)
    assert "reason" not in block and block["synaptic_operations"]["Effective_ACs"] > 0
    assert 0.0 < block["activation_sparsity"] < 1.0 and block["steps_per_sample"] > 0
    # resume returns the finished run without training again
    resumed = MODEL.train(dataclasses.replace(train_request, resume=True))
    assert resumed["learning"] == info["learning"]


def test_options_are_checked_on_construction(tmp_path):
    with pytest.raises(nv.ValidationError, match="--timestep must be in"):
        MBSNNTrainOptions(timestep=2.0)
    with pytest.raises(nv.ValidationError, match="--learn"):
        MODEL.train_request(data=tmp_path, out=tmp_path / "run", learn="0.6:0.4")
    with pytest.raises(nv.ValidationError, match="windows"):
        MBSNNEvalOptions(windows=0)
    with pytest.raises(nv.ValidationError, match="'epochs' is not an option of model 'mbsnn'"):
        MODEL.train(data=tmp_path, out=tmp_path / "run", epochs=3)
    with pytest.raises(nv.ValidationError, match="takes options of type MBSNNTrainOptions"):
        MODEL.train(TrainRequest(data=tmp_path, out=tmp_path / "run", options=MBSNNEvalOptions()))
    assert not (tmp_path / "run").exists()



def test_command_line_train_and_eval(tmp_path, capsys, monkeypatch):
    from neurovpr.apps.modelapi import model_names
    from neurovpr.cli.main import main

    if "mbsnn" not in model_names():
        # not installed yet: declare the same entry point in a distribution on sys.path
        dist = tmp_path / "site" / "neurovpr_mbsnn-0.dist-info"
        dist.mkdir(parents=True)
        (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: neurovpr-mbsnn\nVersion: 0\n")
        (dist / "entry_points.txt").write_text("[neurovpr.models]\nmbsnn = neurovpr.models.mbsnn:MODEL\n")
        monkeypatch.syspath_prepend(str(tmp_path / "site"))
        assert "mbsnn" in model_names()
    first, second = tmp_path / "first.mat", tmp_path / "second.mat"
    _save_mat(first, _route(seed=1, duration_ms=1000.0))
    _save_mat(second, _route(seed=2, duration_ms=1000.0))
    out = tmp_path / "run"
    common = ["--n-kc", "200", "--kc-groups", "1", "--n-pn", str(N_PN), "--keep-still"]
    assert main(["train", "--model", "mbsnn", "--data", str(first), "--out", str(out), "--learn", "0.4:0.6", *common]) == 0
    capsys.readouterr()
    plots = tmp_path / "activity"
    evaluate = ["eval", "--run", str(out), "--data", str(second), "--windows", "20", "--json"]
    assert main([*evaluate, "--activity-plots", str(plots)]) == 0
    result = json.loads(capsys.readouterr().out)
    activity = json.loads((plots / "activity_summary.json").read_text())  # the first 500 ms of the second recording
    assert result["activity_plots"]["raster"] == str(plots / "raster.png") and (plots / "rates.png").is_file()
    assert activity["title"] == "MBSNN, first 500 ms of second on reference, 500 ms"
    assert activity["duration_ms"] == pytest.approx(500.0)
    assert activity["populations"]["kc2"]["neurons"] == 200 and activity["populations"]["pn"]["spikes"] > 0
    assert result["model"] == "mbsnn" and "AUC_ROC" in result["metrics"]
    assert set(result["baselines"]) == {"SeqSLAM", "PerfectMemory"}
    assert main(["train", "--model", "mbsnn", "--data", str(first), "--out", str(out), "--learn", "0.7:0.2"]) == 2
    assert "--learn '0.7:0.2' must satisfy" in capsys.readouterr().err

# -- other backends --------------------------------------------------------------------
def test_brian2_learns_the_same_as_the_reference_backend():
    pytest.importorskip("brian2")
    net = build_network(N_PN, SMALL, seed=1)
    spikes = _route(seed=1, duration_ms=60.0)
    results = {}
    for backend in ("reference", "brian2"):
        sim = compile_mbsnn(net, dt=SMALL.dt, backend=backend, seed=1)
        response = present(sim, spikes, learn=True)
        results[backend] = (response, sim.weights(KC_KC, format="list"))
    (ref, w_ref), (b2, w_b2) = results["reference"], results["brian2"]
    assert ref.counts == b2.counts and ref.counts["kc1"] > 0 and np.any(w_ref > 0)
    assert np.allclose(ref.spike_times, b2.spike_times)
    assert np.allclose(w_ref, w_b2, atol=1e-9)


def test_spinnaker_mapping_agrees_with_the_fit_check(paper_network):
    """sPyNNaker's own mapping on a virtual SpiNN-5 board, and the checker at the paper's size."""
    pytest.importorskip("spynnaker")
    from neurovpr.backends.spinnaker.mapping import map_network
    from neurovpr.hardware.check import check_network
    from neurovpr.models.mbsnn.network import with_input

    small = with_input(build_network(N_PN, MBSNNParameters(n_kc=400), seed=0), _route(seed=1, duration_ms=100.0))
    mapped = map_network(small, dt=1.0, seed=0)
    report = check_network(small, "spinn5").as_dict()
    assert report["fits"] and (mapped["chips"], mapped["cores"]) == (report["chips"], report["cores"])
    per_population = {p["name"]: p["cores"] for p in report["populations"]}
    for name, cores in per_population.items():
        assert sum(1 for row in mapped["placements"] if row["population"] == name) == cores, name
    # the paper's size: 840 PNs, 4000 two-compartment KCs, 1 MBON on one board
    full = check_network(paper_network, "spinn5").as_dict()
    assert full["fits"] and full["chips"] <= 48 and not full["violations"]
    assert {p["name"]: p["cores"] for p in full["populations"]} == {
        "input": 1, "pn": 4, "kc1": 16, "kc2": 16, "mbon": 1,
    }  # fmt: skip


# -- real recordings -------------------------------------------------------------------
@pytest.mark.slow
def test_real_repeat_of_the_route(shared_data, tmp_path):
    """Learn 40-60 % of NB3's moving part, find it along NB4 (the cleanest repeat pair)."""
    files = {run: next((shared_data / "mbsnn_routes").glob(f"{run}_*.mat")) for run in ("NB3", "NB4")}
    out = tmp_path / "run"
    info = training.train(files["NB3"], out, learn=SEGMENT, params=MBSNNParameters(n_kc=1000), n_pn=210, seed=1,
                          progress=False)  # fmt: skip
    from neurovpr.models.mbsnn.evaluation import evaluate

    result = evaluate(out, info, data=files["NB4"], progress=False)
    mbsnn = result["metrics"]
    assert mbsnn["AUC_ROC"] > 0.8 and mbsnn["mean_in_segment"] > mbsnn["mean_outside"]
    assert result["baselines"]["PerfectMemory"]["AUC_ROC"] > 0.85
