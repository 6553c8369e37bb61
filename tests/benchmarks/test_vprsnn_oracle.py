"""The figures read from the authors' code's outputs (``benchmarks/vprsnn_oracle.py``).

The arrays are written in the layout and names the authors' merged evaluation writes
(``modular_snn_config_evaluation.process``), with made-up contents whose figures are known;
running the authors' code itself needs its own environment and is the benchmark's job
(``python benchmarks/modular_snn_vs_authors.py --authors ...``).
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def _benchmark(name: str):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        spec = importlib.util.spec_from_file_location(name, ROOT / "benchmarks" / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    return module


def _oracle():
    return _benchmark("vprsnn_oracle")


def _write_outputs(oracle, workdir: Path, s, threshold: int, summed: np.ndarray) -> None:
    folder = oracle._merged_dir(workdir, s, "test", threshold)
    folder.mkdir(parents=True)
    n_neurons = s.n_e * (s.n_test // s.module_size)
    rng = np.random.default_rng(0)
    reference = rng.integers(0, 3, size=(s.n_places, n_neurons))
    np.save(folder / "validation_result_monitor.npy", reference)
    np.save(folder / "testing_result_monitor_all.npy", rng.integers(0, 2, size=(s.n_test, n_neurons)))
    # every test place owns n_e * modules / n_test neurons; labels are positions n_cal .. n_cal + n_test - 1
    labels = np.repeat(np.arange(s.n_cal, s.n_places), n_neurons // s.n_test)
    np.save(folder / "assignments.npy", labels)
    np.save(folder / "summed_rates.npy", summed)
    (folder / "logfile_evaluation_merged.log").write_text("Recall@1: 0.25\n")


def test_collect_facts_reports_the_concentration_of_the_authors_best_matches(tmp_path: Path) -> None:
    oracle = _oracle()
    s = oracle.OracleSettings(n_test=50, n_cal=25, module_size=25, epochs=5, seed=0, n_e=50, update_interval=25)
    # 50 reported places x 50 queries: queries 0-9 match themselves, the other 40 all pick place 7
    summed = np.zeros((50, 50))
    summed[np.arange(10), np.arange(10)] = 5.0
    summed[7, 10:] = 3.0
    _write_outputs(oracle, tmp_path, s, 40, summed)
    run = {"threshold": 40, "timing": {"train_record_calibrate_seconds": {}}, "calibration_R@1": {40: 0.3}}
    facts = oracle.collect_facts(tmp_path, s, run)
    assert facts["R@1"] == pytest.approx(0.25)  # as the code printed it
    assert facts["R@1_argmax_of_summed_rates"] == pytest.approx(10 / 50)
    assert facts["distinct_best_matches"] == 10
    assert facts["most_chosen_places"] == 1  # ceil(2 % of 50)
    assert facts["most_chosen_share"] == pytest.approx(41 / 50)  # place 7: its own query and the 40 others


def test_run_authors_refuses_a_worker_count_below_one(tmp_path: Path) -> None:
    oracle = _oracle()
    s = oracle.OracleSettings(n_test=50, n_cal=25, module_size=25, epochs=5, seed=0, n_e=50, update_interval=25)
    with pytest.raises(ValueError, match="workers is 0"):
        oracle.run_authors(tmp_path, sys.executable, tmp_path, s, (tmp_path / "r", tmp_path / "q"), workers=0)


def test_run_authors_with_a_fixed_threshold_evaluates_only_the_test_modules_at_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    oracle = _oracle()
    s = oracle.OracleSettings(n_test=50, n_cal=25, module_size=25, epochs=5, seed=0, n_e=50, update_interval=25)
    for offset in range(0, s.n_places, s.module_size):  # every module step finished (a resumed run)
        for queries in (s.n_cal if offset < s.n_cal else None, s.n_test):
            path = oracle._module_output(tmp_path, s, offset, queries)
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(b"")
    calls: list[list[str]] = []

    def run(python, authors, workdir, lists, step, argv, log, cache=None):
        calls.append([step, *argv])
        return 0.0

    monkeypatch.setattr(oracle, "_run", run)
    monkeypatch.setattr(oracle, "_printed_recall", lambda folder, missing_ok=False: 0.2 if "T100" in str(folder) else 0.1)
    lists = (tmp_path / "r", tmp_path / "q")
    fixed = oracle.run_authors(tmp_path, sys.executable, tmp_path, s, lists, progress=False, theta=80)
    assert fixed["threshold"] == 80 and fixed["calibration_R@1"] == {}
    assert calls == [["process", *oracle._merged_args(s, "test", 80)]]  # no module step, no calibration
    calls.clear()
    calibrated = oracle.run_authors(tmp_path, sys.executable, tmp_path, s, lists, progress=False)
    assert calibrated["threshold"] == 100 and len(calibrated["calibration_R@1"]) == len(oracle.THRESHOLDS)
    assert len(calls) == len(oracle.THRESHOLDS) + 1 and calls[-1] == ["process", *oracle._merged_args(s, "test", 100)]
    for bad in (-1, True, 2.5):
        with pytest.raises(ValueError, match="theta is"):
            oracle.run_authors(tmp_path, sys.executable, tmp_path, s, lists, progress=False, theta=bad)


def test_run_authors_prints_what_each_module_step_cost_as_it_ends(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    oracle = _oracle()
    s = oracle.OracleSettings(n_test=25, n_cal=25, module_size=25, epochs=5, seed=0, n_e=50, update_interval=25)
    seconds = {("train", "0"): 41.0, ("train", "25"): 42.0, ("test", "25"): 13.0}

    def run(python, authors, workdir, lists, step, argv, log, cache=None):
        if step == "process":
            return 0.0
        return seconds[(argv[argv.index("--process_mode") + 1], argv[argv.index("--offset_after_skip") + 1])]

    monkeypatch.setattr(oracle, "_run", run)
    done = oracle.run_authors(tmp_path, sys.executable, tmp_path, s, (tmp_path / "r", tmp_path / "q"), theta=40)
    printed = capsys.readouterr().out
    assert "module offset 0: train, record, calibrate took 41 s" in printed
    assert "module offset 25: train, record, calibrate took 42 s" in printed
    assert "module offset 25: test took 13 s" in printed
    assert done["timing"] == {"train_record_calibrate_seconds": {0: 41.0, 25: 42.0}, "test_seconds": {25: 13.0}}


def test_route_order_rates_undo_the_codes_shuffle(tmp_path: Path) -> None:
    oracle = _oracle()
    s = oracle.OracleSettings(n_test=4, n_cal=2, module_size=2, epochs=5, seed=3, n_e=4, update_interval=25)
    # the code's order: calibration places 5, 0, then reported places 3, 1, 4, 2 (route positions 2, 0, 3, 1 of 1..4)
    np.save(tmp_path / "shuffled_indices_L6_S3.npy", np.array([5, 0, 3, 1, 4, 2]))
    folder = oracle._merged_dir(tmp_path, s, "test", 20)
    folder.mkdir(parents=True)
    shuffled = np.array([[3, 1, 4, 2]]) * 10 + np.array([[3], [1], [4], [2]])  # row place * 1 + column place * 10
    np.save(folder / "summed_rates.npy", shuffled)
    rates = oracle.route_order_rates(tmp_path, s, 20)
    places = np.array([1, 2, 3, 4])
    np.testing.assert_array_equal(rates, places[:, None] + 10 * places[None, :])
    np.save(folder / "summed_rates.npy", shuffled[:3])  # a place without neurons: not a square matrix
    with pytest.raises(RuntimeError, match=r"shape \(3, 4\)"):
        oracle.route_order_rates(tmp_path, s, 20)


def test_ensemble_facts_score_the_sum_of_the_members() -> None:
    oracle = _oracle()
    # alone, member a is right on queries 0-1 and member b on 2-3; the sum is right on all four
    a = np.array([[5, 0, 0, 0], [0, 5, 0, 0], [1, 1, 1, 1], [0, 0, 0, 0]], dtype=float)
    b = np.array([[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 4, 0], [0, 0, 0, 4]], dtype=float)
    facts = oracle.ensemble_facts([a, b])
    assert facts["members"] == 2
    assert facts["R@1"] == pytest.approx(1.0)
    assert facts["distinct_best_matches"] == 4
    assert facts["most_chosen_places"] == 1
    assert facts["most_chosen_share"] == pytest.approx(0.25)
    alone = oracle.ensemble_facts([a])
    assert alone["R@1"] == pytest.approx(0.75)  # queries 0, 1 and 2 (place 2 answers every query with 1)
    assert alone["most_chosen_share"] == pytest.approx(0.5)


def test_by_size_means_members_and_every_ensemble_of_a_size() -> None:
    oracle = _oracle()
    members = [
        {"R@1": 0.1, "distinct_best_matches": 50, "most_chosen_share": 0.20},
        {"R@1": 0.2, "distinct_best_matches": 60, "most_chosen_share": 0.30},
        {"R@1": 0.3, "distinct_best_matches": 70, "most_chosen_share": 0.10},
    ]
    ensembles = {
        "0+1": {"R@1": 0.3, "distinct_best_matches": 55, "most_chosen_share": 0.24},  # members' mean 0.25: spread
        "0+2": {"R@1": 0.4, "distinct_best_matches": 65, "most_chosen_share": 0.16},  # mean 0.15: not
        "1+2": {"R@1": 0.5, "distinct_best_matches": 75, "most_chosen_share": 0.20},  # mean 0.20: not (equal)
        "0+1+2": {"R@1": 0.6, "distinct_best_matches": 80, "most_chosen_share": 0.10},  # mean 0.20: spread
    }
    sizes = oracle.by_size(members, ensembles)
    assert list(sizes) == [1, 2, 3]
    assert sizes[1] == pytest.approx({"count": 3, "R@1": 0.2, "distinct_best_matches": 60, "most_chosen_share": 0.2, "spread": 0})
    assert sizes[2] == pytest.approx(
        {"count": 3, "R@1": 0.4, "distinct_best_matches": 65, "most_chosen_share": 0.2, "spread": 1 / 3}
    )
    assert sizes[3] == pytest.approx({"count": 1, "R@1": 0.6, "distinct_best_matches": 80, "most_chosen_share": 0.1, "spread": 1})


def test_neurons_vs_breadth_ranks_places_by_neuron_count_and_breadth() -> None:
    oracle = _oracle()
    # places 7, 3, 5 hold 3, 2 and 1 neurons firing for 20, 5 and 1 images on average; -1 is skipped
    assignments = np.array([7, 7, 7, 3, 3, 5, -1])
    fired = np.array([10, 20, 30, 4, 6, 1, 99])
    assert oracle.neurons_vs_breadth(assignments, fired) == pytest.approx(1.0)
    assert oracle.neurons_vs_breadth(assignments, np.array([1, 1, 1, 5, 5, 20, 0])) == pytest.approx(-1.0)
    assert oracle.neurons_vs_breadth(np.array([7, 3]), np.array([4, 6])) is None  # one neuron each


def test_the_comparison_refuses_a_fixture_made_at_another_threshold(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    comparison = _benchmark("modular_snn_vs_authors")
    s = comparison._settings(comparison._args([]))
    fixture = tmp_path / "fixture.json"
    fixture.write_text(json.dumps({"settings": s.as_dict(), "theta": 80, "facts": {}}))
    assert comparison.main(["--fixture", str(fixture), "--out", str(tmp_path / "out")]) == 2
    assert "made with --theta 80, not calibrated thresholds" in capsys.readouterr().err
    assert comparison.main(["--fixture", str(fixture), "--theta", "60", "--out", str(tmp_path / "out")]) == 2
    assert "made with --theta 80, not --theta 60" in capsys.readouterr().err
    assert comparison.main(["--fixture", str(fixture), "--theta", "-1", "--out", str(tmp_path / "out")]) == 2
    assert not (tmp_path / "out").exists()


def test_the_comparison_refuses_a_negative_first_member(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    comparison = _benchmark("modular_snn_vs_authors")
    assert comparison.main(["--first-member", "-1", "--out", str(tmp_path / "out")]) == 2
    assert "--first-member is -1" in capsys.readouterr().err and not (tmp_path / "out").exists()
