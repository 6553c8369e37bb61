"""The Modular SNN authors' own code (QVPR/VPRSNN) run as an oracle on nordland64.

Nothing of that code is copied here: :func:`run_authors` runs the scripts of a
checkout the user names (``--authors PATH``), unmodified, with the Python of an
environment that has what they import (Brian2, OpenCV, seaborn, scikit-learn, matplotlib;
``--authors-python``), in a work folder of its own (their outputs are written relative to
the working directory). Two things are adapted, both about data:

- the image lists: VPRSNN reads its traverses from text files of image paths
  (``tools/data_utils.py``: ``get_train_test_imagenames_path`` names the files per
  dataset, ``processImageDataset`` loads every path in them); the lists written here hold
  the absolute paths of the chosen nordland64 places, summer (reference) and winter
  (query), one image per place, read with ``--skip 1``;
- which lists a run reads: a launcher (:data:`LAUNCHER`, written into the work folder)
  replaces ``get_train_test_imagenames_path`` by a function that returns those two lists
  (one reference traverse; its ``record`` mode reads the reference, as the original does)
  and then runs the named script as ``__main__`` with the given arguments.

The steps are those of the authors' README for one modular SNN (one member, ``--seed``):
for every module (``--offset_after_skip`` 0, 25, ...) ``modular_snn/one_snn_module_processing.py
--process_mode train`` (train, record the responses to every reference image, and for the
calibration modules run the calibration queries); ``--process_mode test`` for the test
modules; then the merged evaluation of ``modular_snn/modular_snn_config_evaluation.py``
(its ``process``) over the hyperactive thresholds of ``modular_snn/modular_snn_evaluation.py``,
first on the calibration modules and queries, then on the test modules and queries with the
threshold that gave the best calibration Recall@1 (ties: the stricter threshold, the model's
``best_threshold``), or, given a fixed threshold (``theta``), only on the test modules and
queries with it. Its
``main`` is not used because, in calibrate mode, it also searches epochs 10, 20, ... which
needs a training run per epoch count; the oracle trains one epoch count.

:func:`collect_facts` reads the plain numeric arrays those steps write (``allow_pickle``
off) and the Recall@1 the code prints, and returns the figures the comparison uses.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import spearmanr

from neurovpr.evaluation.concentration import match_concentration
from neurovpr.models.modular_snn import best_threshold

__all__ = [
    "LAUNCHER", "THRESHOLDS", "OracleSettings", "write_lists", "run_authors", "collect_facts", "route_order_rates",
    "ensemble_facts", "concentration_facts", "neurons_vs_breadth", "by_size",
]  # fmt: skip

#: The hyperactive thresholds (reference images fired for) VPRSNN's modular evaluation tries.
THRESHOLDS = (0, 5, 10, 20, 40, 60, 80, 100, 120, 140, 160, 180, 200)

#: Runs one of the authors' scripts with the image lists of this comparison (see the module docstring).
LAUNCHER = '''"""Run a QVPR/VPRSNN script with the nordland64 image lists of neurovpr's comparison (data loading only)."""
import os
import runpy
import sys

root, reference_list, query_list, script, *argv = sys.argv[1:]
sys.path.insert(0, root)
import tools.data_utils as data_utils  # noqa: E402


def image_lists(dataset, folder_id, process_mode=""):
    train = [reference_list]
    return train, ([train[0]] if process_mode == "record" else [query_list])


data_utils.get_train_test_imagenames_path = image_lists
if script.endswith(".py"):
    sys.argv = [script, *argv]
    runpy.run_path(os.path.join(root, script), run_name="__main__")
else:  # the merged evaluation: modular_snn_config_evaluation.process for one threshold
    import argparse
    from modular_snn.modular_snn_config_evaluation import process

    keys = argv[0::2]
    values = argv[1::2]
    args = argparse.Namespace(**{k: (int(v) if v.lstrip("-").isdigit() else v) for k, v in zip(keys, values)})
    args.use_weighted_assignments = False
    args.shuffled = True
    process(args)
'''


class OracleSettings:
    """One comparison: which places, module size, epochs, seed, neurons, update interval."""

    def __init__(self, *, n_test: int, n_cal: int, module_size: int, epochs: int, seed: int, n_e: int, update_interval: int):
        self.n_test, self.n_cal, self.module_size = int(n_test), int(n_cal), int(module_size)
        self.epochs, self.seed, self.n_e, self.update_interval = int(epochs), int(seed), int(n_e), int(update_interval)

    @property
    def n_places(self) -> int:
        """Every reference place the code sees: calibration and test."""
        return self.n_cal + self.n_test

    def common(self) -> list[str]:
        """The arguments every step passes (the authors' names)."""
        return [
            "--dataset", "nordland64", "--folder_id", "NRD64_SW", "--num_labels", str(self.module_size),
            "--num_cal_labels", str(self.n_cal), "--num_test_labels", str(self.n_test),
            "--num_query_imgs", str(self.n_places), "--skip", "1", "--update_interval", str(self.update_interval),
            "--n_e", str(self.n_e), "--epochs", str(self.epochs), "--seed", str(self.seed),
        ]  # fmt: skip

    def with_seed(self, seed: int) -> OracleSettings:
        """The same comparison for another member seed."""
        return OracleSettings(
            n_test=self.n_test, n_cal=self.n_cal, module_size=self.module_size, epochs=self.epochs, seed=seed,
            n_e=self.n_e, update_interval=self.update_interval,
        )  # fmt: skip

    def as_dict(self) -> dict[str, int]:
        """JSON-ready form."""
        return {
            "test_places": self.n_test,
            "calibration_places": self.n_cal,
            "module_size": self.module_size,
            "epochs": self.epochs,
            "seed": self.seed,
            "neurons": self.n_e,
            "update_interval": self.update_interval,
        }


def write_lists(workdir: Path, reference: list[Path], query: list[Path]) -> tuple[Path, Path]:
    """The two image lists (absolute paths, one place per line, route order) in ``workdir``."""
    workdir.mkdir(parents=True, exist_ok=True)
    ref, qry = workdir / "reference_images.txt", workdir / "query_images.txt"
    ref.write_text("".join(f"{p.resolve()}\n" for p in reference))
    qry.write_text("".join(f"{p.resolve()}\n" for p in query))
    (workdir / "launch_vprsnn.py").write_text(LAUNCHER)
    return ref, qry


def _run(
    python: str,
    authors: Path,
    workdir: Path,
    lists: tuple[Path, Path],
    script: str,
    argv: list[str],
    log: Path,
    cache: Path | None = None,
) -> float:
    """One launcher call in ``workdir``; its output goes to ``log``; returns the wall seconds.

    ``cache`` is Brian2's code cache (the code sets it to ``$TMPDIR``, not safe to share between
    processes that run at once: each concurrent step gets its own).
    """
    cache = workdir / "brian2_cache" if cache is None else cache
    cache.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, TMPDIR=str(cache), MPLBACKEND="Agg")
    cmd = [python, str(workdir / "launch_vprsnn.py"), str(authors.resolve()), str(lists[0]), str(lists[1]), script, *argv]
    start = time.perf_counter()
    with log.open("a") as out:
        out.write(f"\n$ {' '.join(cmd)}\n")
        out.flush()
        done = subprocess.run(cmd, cwd=workdir, env=env, stdout=out, stderr=subprocess.STDOUT, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"the authors' {script} failed (exit {done.returncode}); see {log}")
    return time.perf_counter() - start


def _merged_args(s: OracleSettings, mode: str, threshold: int) -> list[str]:
    n_test = s.n_cal if mode == "calibrate" else s.n_test
    offset = 0 if mode == "calibrate" else s.n_cal
    values = {
        "dataset": "nordland64", "folder_id": "NRD64_SW", "num_labels": s.module_size, "num_cal_labels": s.n_cal,
        "num_test_labels": n_test, "num_query_imgs": s.n_places, "skip": 1, "offset_after_skip": offset,
        "epochs": s.epochs, "n_e": s.n_e, "threshold_i": threshold, "seed": s.seed, "process_mode": mode,
        "ad_path": "_offset{}", "multi_path": f"epoch{s.epochs}_T{s.n_places}_T{threshold}",
    }  # fmt: skip
    return [str(x) for kv in values.items() for x in kv]


def run_authors(
    authors: Path,
    python: str,
    workdir: Path,
    s: OracleSettings,
    lists: tuple[Path, Path],
    *,
    progress: bool = True,
    workers: int = 1,
    theta: int | None = None,
) -> dict[str, Any]:
    """Run every step (see the module docstring); return the wall time of each and the chosen threshold.

    ``workers`` module steps run at once (each its own process, log and Brian2 cache); the
    evaluations after them run one at a time. ``theta``: evaluate the test modules at this
    hyperactive threshold (reference images) instead of calibrating one (no calibration runs).
    """
    if not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"the authors' code: workers is {workers!r}, expected an integer >= 1.")
    if theta is not None and not (isinstance(theta, int) and not isinstance(theta, bool) and theta >= 0):
        raise ValueError(f"the authors' code: theta is {theta!r}, expected a whole number of reference images >= 0.")
    log = workdir / "vprsnn.log"
    offsets = list(range(0, s.n_places, s.module_size))
    timing: dict[str, Any] = {"train_record_calibrate_seconds": {}, "test_seconds": {}}
    step = "modular_snn/one_snn_module_processing.py"

    def module_step(mode: str, offset: int, label: str) -> tuple[int, float]:
        if progress:
            print(f"[authors' code] module offset {offset}: {label}", flush=True)
        argv = [*s.common(), "--process_mode", mode, "--offset_after_skip", str(offset), "--ad_path", f"_offset{offset}"]
        own_log = log if workers == 1 else workdir / f"vprsnn_offset{offset}.log"
        cache = None if workers == 1 else workdir / "brian2_cache" / f"offset{offset}"
        seconds = _run(python, authors, workdir, lists, step, argv, own_log, cache)
        if progress:  # printed as each step ends, so a run stopped early still tells what a step costs
            print(f"[authors' code] module offset {offset}: {label} took {seconds:.0f} s", flush=True)
        return offset, seconds

    # a module's steps touch only its own folders (outputs, weights, random connections: ``--ad_path``)
    train = [o for o in offsets if not _module_output(workdir, s, o, s.n_cal if o < s.n_cal else None).is_file()]
    test = [o for o in offsets if o >= s.n_cal and not _module_output(workdir, s, o, s.n_test).is_file()]
    with ThreadPoolExecutor(max_workers=workers) as pool:  # finished steps (resume) are not rerun
        for offset, seconds in pool.map(lambda o: module_step("train", o, "train, record, calibrate"), train):
            timing["train_record_calibrate_seconds"][offset] = seconds
        for offset, seconds in pool.map(lambda o: module_step("test", o, "test"), test):
            timing["test_seconds"][offset] = seconds
    calibration: dict[int, float | None] = {}
    for threshold in THRESHOLDS if theta is None else ():
        _run(python, authors, workdir, lists, "process", _merged_args(s, "calibrate", threshold), log)
        calibration[threshold] = _printed_recall(_merged_dir(workdir, s, "calibrate", threshold), missing_ok=True)
    # a threshold at which every neuron is hyperactive gives no result in the authors' evaluation (it exits)
    best = int(best_threshold({t: r for t, r in calibration.items() if r is not None})) if theta is None else theta
    _run(python, authors, workdir, lists, "process", _merged_args(s, "test", best), log)
    return {"timing": timing, "calibration_R@1": calibration, "threshold": best}


def _module_output(workdir: Path, s: OracleSettings, offset: int, queries: int | None) -> Path:
    """The last file a module's step writes: its query responses (``queries``), else its record of the reference."""
    folder = workdir / "outputs" / f"outputs_ne{s.n_e}_L{s.module_size}_offset{offset}"
    if queries is None:
        return folder / f"resultPopVecs{s.n_places}_record_E{s.epochs}.npy"
    return folder / f"resultPopVecs{queries}_test_E{s.epochs}.npy"


def _merged_dir(workdir: Path, s: OracleSettings, mode: str, threshold: int) -> Path:
    """Where the merged evaluation of ``mode`` writes (the authors' folder naming)."""
    n_mod = (s.n_cal if mode == "calibrate" else s.n_test + s.module_size - 1) // s.module_size
    last = (0 if mode == "calibrate" else s.n_cal) + (n_mod - 1) * s.module_size
    name = f"outputs_ne{s.n_e * n_mod}_L{s.module_size * n_mod}_offset{last}_M2"
    return workdir / "outputs" / name / "standard" / f"epoch{s.epochs}_T{s.n_places}_T{threshold}"


_RECALL = re.compile(r"Recall@1: ([0-9.]+)")


def _printed_recall(folder: Path, *, missing_ok: bool = False) -> float | None:
    """The Recall@1 the authors' evaluation printed into its log in ``folder`` (``None``: it printed none)."""
    text = (folder / "logfile_evaluation_merged.log").read_text()
    found = _RECALL.findall(text)
    if not found:
        if missing_ok and "All neurons are categorised as hyperactive" in text:
            return None
        raise RuntimeError(f"no Recall@1 in {folder / 'logfile_evaluation_merged.log'}")
    return float(found[-1])


def _load(path: Path) -> np.ndarray:
    return np.load(path, allow_pickle=False)


def collect_facts(workdir: Path, s: OracleSettings, run: dict[str, Any]) -> dict[str, Any]:
    """The figures of the comparison, from the arrays the authors' code wrote (see the module docstring)."""
    folder = _merged_dir(workdir, s, "test", run["threshold"])
    timed = run["timing"]["train_record_calibrate_seconds"]
    reference = _load(folder / "validation_result_monitor.npy")  # (all reference images, test neurons)
    query = _load(folder / "testing_result_monitor_all.npy")  # (test queries, test neurons)
    assignments = _load(folder / "assignments.npy").astype(np.int64)  # label (shuffled position) per neuron
    summed = _load(folder / "summed_rates.npy")  # (labels, test queries), shuffled positions
    n_mod = assignments.size // s.n_e
    fired = np.count_nonzero(reference, axis=0)
    hyper = fired >= run["threshold"] if run["threshold"] else np.zeros(fired.size, bool)
    per_place = []
    share = []
    for k in range(n_mod):
        a = assignments[k * s.n_e : (k + 1) * s.n_e]
        counts = np.bincount(a[a >= 0], minlength=s.n_cal + s.n_test)
        counts = counts[counts > 0] if counts.any() else counts
        per_place.append(counts)
        share.append(float(counts.max() / s.n_e))
    per_place_all = np.concatenate(per_place)
    labels = np.unique(assignments)
    winners = np.argmax(summed, axis=0)
    return {
        "R@1": _printed_recall(folder),
        "R@1_argmax_of_summed_rates": float(np.mean(labels[winners] == np.arange(s.n_cal, s.n_cal + s.n_test))),
        "queries": int(query.shape[0]),
        "hyperactive_threshold_images": int(run["threshold"]),
        "calibration_R@1_by_threshold": {str(k): v for k, v in run["calibration_R@1"].items()},
        "hyperactive_neurons": int(hyper.sum()),
        "hyperactive_fraction": float(hyper.mean()),
        "spikes_per_neuron_per_query_image": float(query.mean()),
        "spikes_per_neuron_per_reference_image": float(reference.mean()),
        "silent_neuron_fraction_per_query_image": float(np.mean(query == 0)),
        "reference_images_fired_for_per_neuron_mean": float(fired.mean()),
        "unassigned_neurons": int(np.count_nonzero(assignments < 0)),
        "places_with_neurons": int(labels[labels >= 0].size),
        "neurons_per_assigned_place_mean": float(per_place_all.mean()),
        "neurons_per_assigned_place_max": int(per_place_all.max()),
        "largest_share_of_a_module_on_one_place": float(max(share)),
        "neurons_vs_breadth_rank_correlation": neurons_vs_breadth(assignments, fired),
        # rows: the reported places (as the code orders them), columns: their queries; more spikes = more alike
        **concentration_facts(-np.asarray(summed, dtype=float)),
        # None when the module steps ran in an earlier, resumed call
        "train_record_seconds_per_module_wall": float(np.mean(steps)) if (steps := list(timed.values())) else None,
        "python": sys.version.split()[0],
    }


def neurons_vs_breadth(assignments: np.ndarray, fired: np.ndarray) -> float | None:
    """Rank correlation, over places with neurons, of a place's neuron count with how broadly they fire.

    ``assignments``: the place (any label) of each neuron, -1 for none; ``fired``: the
    reference images each neuron fired for. Breadth is the mean of ``fired`` over a
    place's neurons. Broadly firing neurons gather on the place shown last in training
    (the last image a module learns before its weights freeze), and assignment ties go
    to the place shown first; where ties go decides whether this is positive (both sides
    use it). None when every place holds as many neurons, or their breadths are all equal.
    """
    a = np.asarray(assignments, dtype=np.int64)
    fired = np.asarray(fired, dtype=float)
    labels, inverse, counts = np.unique(a[a >= 0], return_inverse=True, return_counts=True)
    breadth = np.bincount(inverse, weights=fired[a >= 0], minlength=labels.size) / counts
    if np.ptp(counts) == 0 or np.ptp(breadth) == 0:
        return None
    return float(spearmanr(counts, breadth).statistic)


def route_order_rates(workdir: Path, s: OracleSettings, threshold: int) -> np.ndarray:
    """The code's ``summed_rates`` of the reported places, rows (places) and columns (queries) in route order.

    The code saves them in its shuffled order and puts them back in route order before it
    scores them (``get_unshuffled_results`` in ``non_modular_snn/snn_model_evaluation.py``,
    used by ``ens_seq/process_ensembles.py`` before it sums the members): place ``i`` of the
    reported places is row ``i`` and its query column ``i``.
    """
    summed = _load(_merged_dir(workdir, s, "test", threshold) / "summed_rates.npy")
    if summed.shape != (s.n_test, s.n_test):
        raise RuntimeError(f"the authors' summed_rates has shape {summed.shape}, expected ({s.n_test}, {s.n_test})")
    shuffled = _load(workdir / f"shuffled_indices_L{s.n_places}_S{s.seed}.npy")
    order = np.argsort(shuffled[s.n_cal :])
    return summed[order][:, order]


def ensemble_facts(rates: list[np.ndarray]) -> dict[str, Any]:
    """Recall@1 and match concentration of the sum of route-ordered ``summed_rates`` (the code's ensemble).

    Ground truth: query ``i`` is place ``i`` (zero tolerance, as the code scores Nordland).
    """
    summed = np.sum(np.asarray(rates, dtype=float), axis=0)
    return {
        "members": len(rates),
        "R@1": float(np.mean(np.argmax(summed, axis=0) == np.arange(summed.shape[1]))),
        **concentration_facts(-summed),
    }


def concentration_facts(distances: np.ndarray) -> dict[str, Any]:
    """The comparison's concentration figures of a ``[reference, query]`` distance matrix (both sides use it)."""
    c = match_concentration(distances)
    return {
        "distinct_best_matches": c["distinct_best_matches"],
        "most_chosen_places": c["top_places"],
        "most_chosen_share": c["top_share"],
    }


def by_size(members: list[dict[str, Any]], ensembles: dict[str, dict[str, Any]]) -> dict[int, dict[str, float]]:
    """Means over the members (size 1) and over every ensemble of each size 2, 3, ...

    For each size: ``count`` (how many), the means of ``R@1``, ``distinct_best_matches`` and
    ``most_chosen_share``, and ``spread``: the share of those ensembles whose most-chosen places
    win less than the mean of their members' most-chosen places (0 for the members themselves).
    """
    groups: dict[int, list[tuple[dict[str, Any], float | None]]] = {1: [(m, None) for m in members]}
    for label, facts in ensembles.items():
        chosen = [int(k) for k in label.split("+")]
        own = float(np.mean([members[k]["most_chosen_share"] for k in chosen]))
        groups.setdefault(len(chosen), []).append((facts, own))
    return {
        n: {
            "count": len(g),
            **{key: float(np.mean([f[key] for f, _ in g])) for key in ("R@1", "distinct_best_matches", "most_chosen_share")},
            "spread": 0.0 if n == 1 else float(np.mean([f["most_chosen_share"] < own for f, own in g])),
        }
        for n, g in sorted(groups.items())
    }
