"""``neurovpr train/eval --model locsnet``: the command-line integration of LoCS-Net.

``train`` reads a traverse (the generic layout or a published one), labels the
reference frames with places, preprocesses them to the network input, trains the
rate network with torch or, with ``--trainer nengo-dl``, with NengoDL as the paper did
(:mod:`.nengo_training`), converts it to a spiking network, calibrates the place layer
on the spiking network and writes the run directory (:mod:`.runs`). ``eval`` runs
the query traverse through the spiking network on a backend, next to the rate model
and SAD on the same inputs, prints the metrics and writes plots and the per-inference
activity (for ``neurovpr energy``).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from neurovpr.apps.modelapi import ModelPlugin, SamplePresentation
from neurovpr.apps.options import option
from neurovpr.apps.requests import EvalRequest, TrainRequest, check_fields
from neurovpr.apps.rundir import RunDir
from neurovpr.errors import ValidationError

from .conversion import SpikingParameters
from .settings import DEFAULT_TRAINING

__all__ = ["LoCSNetPlugin", "LoCSNetTrainOptions", "LoCSNetEvalOptions", "MODEL"]

_PRESETS = ("paper", "small")
_TRAINING = DEFAULT_TRAINING
_SPIKING = SpikingParameters()


@dataclass(frozen=True, slots=True, kw_only=True)
class LoCSNetTrainOptions:
    """LoCS-Net's own ``train`` options (``neurovpr train --model locsnet --help`` says what each does).

    The training hyper-parameters take their defaults from :class:`.settings.TrainingSettings`
    and the spiking ones from :class:`.conversion.SpikingParameters`.
    """

    preset: Literal["paper", "small"] = option("paper", "layer sizes: paper (56x56, 8/16/32 filters) or small")
    trainer: Literal["torch", "nengo-dl"] = option(
        "torch", "train the rate network with torch, or with NengoDL (TensorFlow) as the paper did"
    )
    frames_per_place: int = option(1, "aligned traverses: consecutive frames per place")
    positions: Path | None = option(None, "CSV set,index,x,y (metres): label places by grid tiles")
    tile_size: float = option(25.0, "grid tile side in metres")
    min_tile_images: int = option(2, "drop tiles with fewer reference images")
    epochs: int = option(_TRAINING.epochs, "training epochs")
    batch_size: int = option(_TRAINING.batch_size, "batch size")
    learning_rate: float = option(_TRAINING.learning_rate, "peak learning rate of Adam")
    weight_decay: float = option(_TRAINING.weight_decay, "L2 weight regularisation")
    rate_penalty: float = option(_TRAINING.rate_penalty, "L2 penalty on hidden activations")
    quantise: str | None = option(_TRAINING.quantise, "quantisation-aware training to this hwspec's weights", metavar="HW")
    place_loss: Literal["current", "rate"] = option(_TRAINING.place_loss, "what the loss sees of the place layer")
    checkpoint: Path | None = option(None, "start from this model.pt (same architecture)")
    no_patch_norm: bool = option(False, "plain grayscale input instead of patch normalisation")
    conv_bias: bool = option(False, "keep biases in the conv layers (the paper removed them)")
    threads: int = option(_TRAINING.threads, "torch or TensorFlow threads (1: fastest on a shared 2-core machine)")
    presentation: float = option(_SPIKING.presentation, "presentation window per image, ms")
    input_coding: Literal["poisson", "regular"] = option(_SPIKING.input_coding, "input spikes")
    input_rate: float = option(_SPIKING.input_rate, "rate of a pixel of value 1, Hz")
    tau_syn: float = option(_SPIKING.tau_syn, "synaptic time constant, ms")
    dt: float = option(_SPIKING.dt, "time step, ms (1 is Loihi's)")
    feature_groups: int | None = option(
        None, "conv3 as this many populations, for Loihi's output-axon limit", default_text="8 for paper, 1 for small"
    )
    calibration_images: int = option(100, "training images to calibrate the place layer on")

    def __post_init__(self) -> None:
        check_fields(self)
        for name in ("frames_per_place", "min_tile_images") + (("feature_groups",) if self.feature_groups is not None else ()):
            if getattr(self, name) < 1:
                raise ValidationError(f"LoCSNetTrainOptions.{name} is {getattr(self, name)}; it must be >= 1.")


@dataclass(frozen=True, slots=True, kw_only=True)
class LoCSNetEvalOptions:
    """LoCS-Net's own ``eval`` options."""

    queries: int | None = option(None, "evaluate this many evenly spaced queries", default_text="all")
    hardware: str | None = option(None, "compile with this hwspec (backends that emulate it)", flag="--hw")
    eval_positions: Path | None = option(None, "CSV of positions for grid labels", default_text="training's")
    no_plots: bool = option(False, "do not write PNG plots")

    def __post_init__(self) -> None:
        check_fields(self)


class LoCSNetPlugin(ModelPlugin):
    """LoCS-Net (Akcal et al., Frontiers in Neurorobotics 2025)."""

    name = "locsnet"
    description = "LoCS-Net: convolutional spiking place classifier trained through SoftLIF (torch or NengoDL)"
    train_options = LoCSNetTrainOptions
    eval_options = LoCSNetEvalOptions

    # -- train ----------------------------------------------------------------------------
    def run_train(self, request: TrainRequest) -> dict[str, Any]:
        """Train into ``request.out``; see the module docstring."""
        o: LoCSNetTrainOptions = request.options
        from .architecture import paper_architecture, small_architecture
        from .conversion import SpikingParameters, layer_populations, to_spiking_network
        from .estimate import check_resources
        from .runs import write_run

        t_start = time.perf_counter()
        out = Path(request.out)
        if RunDir(out).finished:
            if request.resume:
                from .runs import load_run

                run = load_run(out)
                return {"model": "locsnet", "run": str(out), "resumed": True, "n_places": run.arch.n_places}
            raise ValidationError(f"run directory {out} already holds a finished run; use --resume or another --out.")
        if request.scheduler:
            raise ValidationError("LoCS-Net trains one network in one process; --scheduler is not supported for it.")
        settings = self._settings(o, request.seed)
        if o.trainer == "nengo-dl":
            from .nengo_training import import_nengo_dl

            import_nengo_dl(settings.threads)  # refuse before the data is read when NengoDL is missing
        groups = o.feature_groups if o.feature_groups is not None else (8 if o.preset == "paper" else 1)
        spiking = SpikingParameters(dt=o.dt, tau_syn=o.tau_syn, input_rate=o.input_rate,
                                    presentation=o.presentation, input_coding=o.input_coding,
                                    feature_groups=groups)
        make_arch = paper_architecture if o.preset == "paper" else small_architecture
        check_resources(make_arch(2), batch_size=settings.batch_size, spiking=spiking,
                        calibration_images=o.calibration_images)  # before the data is read: 2 places at least
        traverse, labels, positions_used = self._labels(o, request.data)
        arch = make_arch(labels.n_places)
        if o.conv_bias:
            arch = dataclasses.replace(arch, conv_bias=True)
        if o.trainer == "nengo-dl":
            from neurovpr.errors import UnsupportedFeatureError

            from .nengo_training import nengo_problems

            problems = nengo_problems(arch, settings, checkpoint=o.checkpoint is not None)
            if problems:
                raise UnsupportedFeatureError(f"--trainer nengo-dl cannot train with {problems[0]}.")
        size = arch.input_size
        layer_populations(arch, spiking)  # a bad grouping fails before training
        weight_format = None
        if settings.quantise:
            from .quantise import weight_format as hw_format

            weight_format = hw_format(settings.quantise)
        initial = None
        if o.checkpoint is not None:
            from .runs import load_checkpoint

            initial = load_checkpoint(o.checkpoint, arch, settings.place_loss)
        t0 = time.perf_counter()
        images, image_labels = _training_images(traverse, labels, size, not o.no_patch_norm)
        t_pre = time.perf_counter() - t0
        if o.trainer == "nengo-dl":
            from .nengo_training import train_nengo_dl

            result = train_nengo_dl(arch, images, image_labels, settings, progress=True)
        else:
            from .training import train

            result = train(arch, images, image_labels, settings, weight_format=weight_format, progress=True,
                           initial_state=initial)
        params, calibration = result.parameters, {"rate": result.calibration}
        t0 = time.perf_counter()
        if settings.place_loss == "current" and o.calibration_images > 0:
            from .calibration import calibrate_spiking

            pick = np.linspace(0, images.shape[0] - 1, min(o.calibration_images, images.shape[0])).astype(int)
            params, calibration["spiking"] = calibrate_spiking(
                arch, params, spiking, images[pick], drive=settings.place_drive, active=settings.active_places,
                seed=request.seed, progress=True)
        if weight_format is not None:  # the calibration moved the place weights off the chip's grid
            from .quantise import quantise_parameters

            params = quantise_parameters(params, weight_format)
        t_cal = time.perf_counter() - t0
        network = to_spiking_network(arch, params, spiking, name="locsnet")
        info = {
            "backend": request.backend,
            "trainer": o.trainer,
            "seed": request.seed,
            "data": str(Path(request.data).resolve()),
            "positions": str(positions_used) if positions_used else None,
            "n_places": arch.n_places,
            "n_training_images": int(images.shape[0]),
            "places": {"scheme": labels.scheme, "frames_per_place": labels.frames_per_place,
                       "tile_size": labels.tile_size},
            "preprocess": {"size": list(size), "patch_norm": not o.no_patch_norm},
            "architecture": arch.to_dict(),
            "spiking": spiking.to_dict(),
            "training": settings.to_dict(),
            "calibration": calibration,
            "history": result.history,
            "timing": {"preprocess_s": t_pre, "train_s": result.seconds, "train_cpu_s": result.cpu_seconds,
                       "calibration_s": t_cal, "total_s": time.perf_counter() - t_start},
        }
        write_run(out, info=info, arch=arch, spiking=spiking, network=network, labels=labels,
                  state_dict=result.state_dict)
        last = result.history[-1]
        return {"model": "locsnet", "run": str(out), "trainer": o.trainer, "n_places": arch.n_places,
                "architecture": arch.describe(),
                "epochs": len(result.history), "train_accuracy": last["train_accuracy"], "loss": last["loss"],
                "train_seconds": round(result.seconds, 2), "train_cpu_seconds": round(result.cpu_seconds, 2),
                "total_seconds": round(time.perf_counter() - t_start, 2)}

    @staticmethod
    def _settings(o: LoCSNetTrainOptions, seed: int) -> Any:
        from .settings import TrainingSettings

        return TrainingSettings(epochs=o.epochs, batch_size=o.batch_size, learning_rate=o.learning_rate,
                                weight_decay=o.weight_decay, rate_penalty=o.rate_penalty, quantise=o.quantise,
                                place_loss=o.place_loss, seed=seed, threads=o.threads)

    @staticmethod
    def _labels(o: LoCSNetTrainOptions, data: Path) -> tuple[Any, Any, Path | None]:
        from neurovpr.data import open_traverse

        from .places import frame_labels, grid_labels, read_positions_csv

        traverse = open_traverse(data)
        if o.positions is not None:
            ref_xy, _ = read_positions_csv(o.positions, traverse.n_reference, traverse.n_query)
            return traverse, grid_labels(ref_xy, o.tile_size, o.min_tile_images), Path(o.positions).resolve()
        return traverse, frame_labels(traverse.n_reference, o.frames_per_place), None

    # -- eval -----------------------------------------------------------------------------
    def run_evaluate(self, request: EvalRequest, run_info: dict[str, Any]) -> dict[str, Any]:
        """Evaluate the run in ``request.run``; returns the JSON object ``eval --json`` prints."""
        o: LoCSNetEvalOptions = request.options
        from neurovpr.data import open_traverse

        from .inference import SpikingClassifier, rate_forward
        from .places import distance_confusion, place_ground_truth, query_tiles, read_positions_csv
        from .preprocess import preprocess
        from .report import sad_place_distances, score, similarity_distances, write_activity, write_plots
        from .runs import load_run

        run = load_run(request.run)
        backend = request.backend or run.info.get("backend", "reference")
        data = Path(request.data) if request.data is not None else Path(run.info["data"])
        traverse = open_traverse(data)
        if traverse.n_reference != run.labels.labels.size:
            raise ValidationError(
                f"dataset {data} has {traverse.n_reference} reference images but the run was trained on "
                f"{run.labels.labels.size}; evaluate on the same reference traverse."
            )
        pre = run.info.get("preprocess", {})
        size = tuple(pre.get("size", run.arch.input_size))
        patch_norm = bool(pre.get("patch_norm", True))
        positions = o.eval_positions or (Path(run.info["positions"]) if run.info.get("positions") else None)
        query_xy = None
        if run.labels.scheme == "grid":
            if positions is None:
                raise ValidationError("this run labels places by grid tiles; give the query positions with --eval-positions.")
            _, query_xy = read_positions_csv(positions, traverse.n_reference, traverse.n_query)
            tiles = query_tiles(run.labels, query_xy)
            gt = np.zeros((run.arch.n_places, traverse.n_query), dtype=bool)
            gt[tiles[tiles >= 0], np.flatnonzero(tiles >= 0)] = True
        else:
            gt = place_ground_truth(traverse.ground_truth, run.labels)
        q_idx = np.arange(traverse.n_query)
        if o.queries is not None and o.queries < traverse.n_query:
            q_idx = np.unique(np.linspace(0, traverse.n_query - 1, o.queries).astype(int))
        queries = preprocess(traverse.query.subset(q_idx).images(progress=True), size, patch_norm=patch_norm)
        gt = gt[:, q_idx]
        results: dict[str, Any] = {}
        curves, recalls = {}, {}
        # spiking network on the backend
        clf = SpikingClassifier(run.network, run.arch, run.spiking, backend=backend, seed=int(run.info.get("seed", 0)),
                                hardware=o.hardware, **request.backend_options)
        spikes = clf.run(queries, progress=True)
        metrics, curves["LoCS-Net spiking"], recalls["LoCS-Net spiking"] = score(similarity_distances(spikes.counts), gt)
        # rate model and SAD on the same inputs
        rates = rate_forward(run.arch, run.params, queries)["places"].T
        rate_metrics, curves["rate model (SoftLIF)"], recalls["rate model (SoftLIF)"] = score(similarity_distances(rates), gt)
        reference = preprocess(traverse.reference.images(progress=True), size, patch_norm=patch_norm)
        sad_metrics, curves["SAD"], recalls["SAD"] = score(sad_place_distances(reference, queries, run.labels), gt)
        results = {
            "model": "locsnet",
            "backend": backend,
            "metrics": metrics,
            "rate_model": rate_metrics,
            "baselines": {"SAD": sad_metrics},
            "queries": int(q_idx.size),
            "places": run.arch.n_places,
            "seconds_per_query": float(np.median(spikes.seconds)),
            "compile_seconds": clf.compile_seconds,
            "layer_spikes_per_query": spikes.layer_spikes,
        }
        if query_xy is not None:
            predicted = np.argmax(spikes.counts, axis=0)
            results["distance"] = distance_confusion(run.labels, predicted, query_xy[q_idx])
        if spikes.totals is not None:
            results["activity"] = write_activity(request.run, spikes, run.spiking.dt)
        if not o.no_plots:
            folder = Path(request.run) / "eval" / backend
            results["plots"] = write_plots(folder, curves, recalls,
                                           title=f"{run.arch.n_places} places, {backend}")
        return results

    # -- infer (neurovpr compare) -----------------------------------------------------------
    def infer(self, run_dir: Path, data: Path | None, backend: str, *, seed: int = 0) -> dict[str, Any]:
        """Run the converted spiking network of ``run_dir`` on ``backend`` over every query of ``data``.

        The trained weights of ``network.h5`` run unchanged (they never learn on-line);
        a backend that cannot run the network but runs its integrate-and-fire form (a chip
        without leak, :mod:`.deployment`) runs that form and the result's ``notes`` say so;
        one that runs neither refuses it when compiling, before any query, with
        :class:`~neurovpr.errors.UnsupportedFeatureError`. Metrics are those of ``eval``
        (precision at 100% recall, PR AUC, Recall@N over places); the prediction of a
        query is the place neuron with the most spikes, the output counts are the place
        layer's spike counts ``(queries, places)``.
        """
        from neurovpr.data import open_traverse

        from .deployment import deployed_classifier
        from .places import place_ground_truth, query_tiles, read_positions_csv
        from .preprocess import preprocess
        from .report import score, similarity_distances
        from .runs import load_run

        run = load_run(run_dir)
        data = Path(data) if data is not None else Path(run.info["data"])
        traverse = open_traverse(data)
        if traverse.n_reference != run.labels.labels.size:
            raise ValidationError(
                f"dataset {data} has {traverse.n_reference} reference images but the run was trained on "
                f"{run.labels.labels.size}; compare on the same reference traverse."
            )
        if run.labels.scheme == "grid":
            if not run.info.get("positions"):
                raise ValidationError(f"run {run_dir} labels places by grid tiles but names no positions file.")
            _, query_xy = read_positions_csv(Path(run.info["positions"]), traverse.n_reference, traverse.n_query)
            tiles = query_tiles(run.labels, query_xy)
            gt = np.zeros((run.arch.n_places, traverse.n_query), dtype=bool)
            gt[tiles[tiles >= 0], np.flatnonzero(tiles >= 0)] = True
        else:
            gt = place_ground_truth(traverse.ground_truth, run.labels)
        pre = run.info.get("preprocess", {})
        size = tuple(pre.get("size", run.arch.input_size))
        queries = preprocess(traverse.query.images(progress=True), size, patch_norm=bool(pre.get("patch_norm", True)))
        clf, notes = deployed_classifier(run, backend, seed=int(seed))
        try:
            spikes = clf.run(queries, progress=True, desc="compare")
        finally:
            clf.sim.close()  # Lava's runtime processes, Nengo's simulator
        metrics, _, _ = score(similarity_distances(spikes.counts), gt)
        activity = None
        if spikes.activity is not None:
            activity = {**spikes.activity, "dt_ms": run.spiking.dt, "population_spikes": dict(spikes.layer_spikes)}
        return {
            "metrics": metrics,
            "predictions": np.argmax(spikes.counts, axis=0).astype(np.int64),
            "output_counts": spikes.counts.T,
            "seconds_per_query": float(np.mean(spikes.seconds)),
            "activity": activity,
            "compile_seconds": clf.compile_seconds,
            "notes": notes,
            "network": clf.sim.network if notes else None,  # the form deployed there, for its own partition
        }

    # -- sample presentation (neurovpr eval --activity-plots) ---------------------------------
    def sample_presentation(self, run_dir: Path, data: Path | None) -> SamplePresentation:
        """The converted spiking network of ``run_dir`` shown the first query image of ``data`` (default: the run's)."""
        from neurovpr.data import open_traverse

        from .inference import presentation_inputs
        from .preprocess import preprocess
        from .runs import load_run

        run = load_run(run_dir)
        data = Path(data) if data is not None else Path(run.info["data"])
        traverse = open_traverse(data)
        if traverse.n_query < 1:
            raise ValidationError(f"dataset {data} has no query image to show.")
        pre = run.info.get("preprocess", {})
        size = tuple(pre.get("size", run.arch.input_size))
        image = preprocess(traverse.query.subset([0]).images(), size, patch_norm=bool(pre.get("patch_norm", True)))[0]
        return SamplePresentation(
            network=run.network, inputs=presentation_inputs(run.spiking, image), duration_ms=run.spiking.presentation,
            dt=run.spiking.dt, title="LoCS-Net, query image 0",
        )  # fmt: skip


def _training_images(traverse: Any, labels: Any, size: tuple[int, int], patch_norm: bool) -> tuple[np.ndarray, np.ndarray]:
    """Preprocessed images of every reference traverse with their place labels (dropped frames left out)."""
    from .preprocess import preprocess

    keep, y = labels.training_set()
    stacks, ys = [], []
    for ref in traverse.references:
        stacks.append(preprocess(ref.subset(keep).images(progress=True), size, patch_norm=patch_norm))
        ys.append(y)
    return np.concatenate(stacks), np.concatenate(ys)


#: The entry point object (``[project.entry-points."neurovpr.models"] locsnet``).
MODEL = LoCSNetPlugin()
