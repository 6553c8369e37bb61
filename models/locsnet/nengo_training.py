"""Training LoCS-Net with NengoDL, as the paper did: SoftLIF rate neurons, sparse categorical cross-entropy.

The rate network is a ``nengo.Network``: an input node (the image), three ensembles of
``nengo_dl.SoftLIFRate`` neurons fed through ``nengo.Convolution`` transforms and the
place layer's dense transform, all without synapses, simulated for one step by
NengoDL's Simulator and trained with Keras through ``Simulator.fit``. It is the same
network as the torch trainer's (:mod:`.torchnet`): the same architecture, SoftLIF with
the same ``tau_rc``, ``tau_ref``, smoothing and amplitude (Nengo counts time in seconds,
so the amplitude is divided by 1000 to keep an activation of 1 at 100 spikes/s), unit
gains and no biases. The hyper-parameters of :class:`.settings.TrainingSettings` apply as
in :func:`.training.train`:

- the loss is the sparse categorical cross-entropy on the place layer's input currents
  (``place_loss="current"``, with the auxiliary ``level_weight`` hinge) or on its SoftLIF
  rates (``place_loss="rate"``, without the torch model's learned temperature);
- ``weight_decay`` adds ``weight_decay * sum(w**2)`` over every trained weight,
  ``rate_penalty`` the mean squared activation of the three convolutional layers;
- Adam with the one-cycle learning-rate schedule of torch's ``OneCycleLR`` (15 % warm-up,
  cosine annealing, initial rate ``/25``, final ``/25e4``); torch also cycles Adam's
  ``beta_1`` between 0.85 and 0.95, which Keras's Adam does not (``beta_1`` stays 0.9);
- the same data-driven initialisation (in numpy: uniform ``+-1/sqrt(fan_in)`` weights,
  then each layer scaled and shifted so its input ``J`` has mean ``init_mean`` and
  standard deviation ``init_std`` per channel) and the same augmentation, drawn anew every
  epoch; an epoch shows every image once, plus random repeats up to a whole number of
  batches (NengoDL's minibatch size is fixed).

Quantisation-aware training, biases, padded convolutions and torch checkpoints are
the torch trainer's only: :func:`nengo_problems` names them. After training the place layer is
calibrated exactly as after torch training (:func:`.calibration.calibrate_places` on the
numpy rate model), and the arrays go through the same conversion.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from neurovpr.errors import BackendUnavailableError, ValidationError

from .architecture import LAYER_NAMES, Architecture
from .calibration import calibrate_places
from .inference import _conv2d, check_images, rate_forward, softlif_rate
from .settings import TrainingResult, TrainingSettings, check_labels

__all__ = [
    "TRAINER",
    "nengo_problems",
    "import_nengo_dl",
    "initial_parameters",
    "augment",
    "build_rate_network",
    "train_nengo_dl",
]

#: The name of this trainer (``--trainer``) and of the backend that provides NengoDL.
TRAINER = "nengo-dl"


def nengo_problems(arch: Architecture, settings: TrainingSettings, *, checkpoint: bool = False) -> list[str]:
    """What this trainer cannot do for ``arch`` and ``settings`` (each a phrase naming the option and value)."""
    problems = []
    if settings.quantise:
        problems.append(f"quantisation-aware training (--quantise {settings.quantise}), which only the torch trainer does")
    if arch.conv_bias or arch.dense_bias:
        problems.append("layer biases (--conv-bias), which only the torch trainer trains (NengoDL: one bias per neuron)")
    for name, conv in zip(LAYER_NAMES[:3], arch.convs, strict=True):
        if conv.padding:
            problems.append(f"{name} padding {conv.padding} (this trainer builds unpadded nengo.Convolution layers)")
    if checkpoint:
        problems.append("a torch checkpoint (--checkpoint), which NengoDL cannot start from")
    return problems


def import_nengo_dl(threads: int | None) -> Any:
    """NengoDL through the ``nengo-dl`` backend declaration (found by the registry), or a one-sentence refusal."""
    from neurovpr.runtime.registry import get_backend

    try:
        backend = get_backend(TRAINER)
        return backend.import_nengo_dl(threads)  # type: ignore[attr-defined]
    except (BackendUnavailableError, AttributeError) as exc:
        raise BackendUnavailableError(f"--trainer {TRAINER} needs NengoDL, which is not available here: {exc}") from None


# -- initialisation and augmentation (numpy, as the torch trainer's) --------------------------
def _layer_input(x: np.ndarray, w: np.ndarray, stride: int) -> np.ndarray:
    if w.ndim == 2:
        return x.reshape(x.shape[0], -1) @ w.T
    return _conv2d(x, w, stride, 0)


def initial_parameters(arch: Architecture, images: np.ndarray, settings: TrainingSettings, rng: np.random.Generator) -> dict:
    """Weights drawn uniformly in ``+-1/sqrt(fan_in)`` then scaled and shifted on ``images`` (N, 1, H, W)."""
    params: dict[str, np.ndarray] = {}
    for name, shape in arch.parameter_shapes().items():
        fan_in = int(np.prod(shape[1:]))
        params[name] = rng.uniform(-1.0, 1.0, shape) / math.sqrt(fan_in)
    x = images
    strides = [c.stride for c in arch.convs] + [1]
    for name, stride in zip(LAYER_NAMES, strides, strict=True):
        w = params[f"{name}.weight"]
        axes = (0,) if w.ndim == 2 else (0, 2, 3)
        shape = (-1,) + (1,) * (w.ndim - 1)
        w *= (settings.init_std / np.maximum(_layer_input(x, w, stride).std(axis=axes), 1e-6)).reshape(shape)
        shift = settings.init_mean - _layer_input(x, w, stride).mean(axis=axes)
        drive = _layer_input(x, np.ones_like(w[:1]), stride).mean()
        w += (shift / max(float(drive), 1e-6)).reshape(shape)
        j = _layer_input(x, w, stride)
        x = softlif_rate(j, arch.neuron)
    return params


def augment(x: np.ndarray, s: TrainingSettings, rng: np.random.Generator) -> np.ndarray:
    """Random shift (edges replicated), contrast, brightness and noise of images (N, H, W), clipped to [0, 1]."""
    n, h, w = x.shape
    if s.shift:
        p = s.shift
        padded = np.pad(x, ((0, 0), (p, p), (p, p)), mode="edge")
        dy = rng.integers(0, 2 * p + 1, n)
        dx = rng.integers(0, 2 * p + 1, n)
        rows = dy[:, None] + np.arange(h)[None, :]
        cols = dx[:, None] + np.arange(w)[None, :]
        x = padded[np.arange(n)[:, None, None], rows[:, :, None], cols[:, None, :]]
    if s.contrast or s.brightness:
        c = 1.0 + s.contrast * (2.0 * rng.random((n, 1, 1)) - 1.0)
        b = s.brightness * (2.0 * rng.random((n, 1, 1)) - 1.0)
        x = (x - 0.5) * c + 0.5 + b
    if s.noise:
        x = x + s.noise * rng.standard_normal(x.shape)
    return np.clip(x, 0.0, 1.0)


# -- the NengoDL network -----------------------------------------------------------------------
def build_rate_network(nengo_dl: Any, arch: Architecture, params: dict, settings: TrainingSettings) -> tuple[Any, dict, dict]:
    """The rate network of ``arch`` with weights ``params`` (torch layout), for one-step NengoDL simulation.

    Returns
    -------
    tuple
        The ``nengo.Network``; its objects by name (``"input"`` node, the neurons of
        ``"conv1"`` .. ``"conv3"``, and ``"places"``: a node receiving the place currents for
        ``place_loss="current"``, else the place neurons); the connection into each layer.
    """
    import nengo

    n = arch.neuron
    shapes = arch.layer_shapes()
    objs: dict[str, Any] = {}
    conns: dict[str, Any] = {}
    with nengo.Network(label="locsnet-rate", seed=settings.seed) as net:
        nengo_dl.configure_settings(trainable=None, stateful=False, keep_history=False)
        neuron = nengo_dl.SoftLIFRate(
            sigma=float(n.sigma),
            tau_rc=float(n.tau_rc) / 1000.0,
            tau_ref=float(n.tau_ref) / 1000.0,
            amplitude=float(n.amplitude) / 1000.0,
        )
        objs["input"] = prev = nengo.Node(np.zeros(int(np.prod(shapes["input"]))), label="input")
        prev_shape = shapes["input"]
        for name, conv in zip(LAYER_NAMES[:3], arch.convs, strict=True):
            size = int(np.prod(shapes[name]))
            ens = nengo.Ensemble(size, 1, neuron_type=neuron, gain=np.ones(size), bias=np.zeros(size), label=name)
            net.config[ens].trainable = False  # unit gains, no biases: only the weights train
            transform = nengo.Convolution(
                n_filters=conv.filters,
                input_shape=nengo.transforms.ChannelShape(prev_shape, channels_last=False),
                kernel_size=(conv.kernel, conv.kernel),
                strides=(conv.stride, conv.stride),
                padding="valid",
                channels_last=False,
                init=np.transpose(params[f"{name}.weight"], (2, 3, 1, 0)),
            )
            conns[name] = nengo.Connection(prev, ens.neurons, transform=transform, synapse=None)
            objs[name] = prev = ens.neurons
            prev_shape = shapes[name]
        if settings.place_loss == "current":
            target = objs["places"] = nengo.Node(size_in=arch.n_places, label="places")
        else:
            ens = nengo.Ensemble(
                arch.n_places, 1, neuron_type=neuron, gain=np.ones(arch.n_places), bias=np.zeros(arch.n_places), label="places"
            )
            net.config[ens].trainable = False
            target = objs["places"] = ens.neurons
        conns["places"] = nengo.Connection(prev, target, transform=params["places.weight"], synapse=None)
    return net, objs, conns


@contextmanager
def _quiet() -> Iterator[None]:
    """Silence NengoDL's and Nengo's warnings for this use of them.

    No GPU is wanted; NengoDL transposes the channels-first convolutions for TensorFlow's
    CPU kernels; unit gains set directly make Nengo's rate estimates divide by zero.
    """
    with warnings.catch_warnings(), np.errstate(divide="ignore", invalid="ignore"):
        warnings.filterwarnings("ignore", message=".*No GPU support detected.*")
        warnings.filterwarnings("ignore", message=".*channels_last=False on the CPU.*")
        warnings.filterwarnings("ignore", category=RuntimeWarning, module=r"nengo\..*")
        yield


class _OneCycle:
    """torch's ``OneCycleLR`` learning rate (cosine annealing, two phases) as a Keras schedule."""

    def __new__(cls, tf: Any, max_lr: float, total: int, pct_start: float = 0.15) -> Any:
        class Schedule(tf.keras.optimizers.schedules.LearningRateSchedule):
            def __call__(self, step: Any) -> Any:
                step = tf.cast(step, tf.float64)
                initial, final = max_lr / 25.0, max_lr / 25.0 / 1e4
                up_end = float(pct_start * total) - 1.0
                down_end = float(total) - 1.0

                def anneal(start: float, end: float, pct: Any) -> Any:
                    return end + (start - end) / 2.0 * (1.0 + tf.cos(math.pi * pct))

                up = anneal(initial, max_lr, tf.clip_by_value(step / max(up_end, 1e-9), 0.0, 1.0))
                down = anneal(max_lr, final, tf.clip_by_value((step - up_end) / max(down_end - up_end, 1e-9), 0.0, 1.0))
                return tf.cast(tf.where(step <= up_end, up, down), tf.float32)

            def get_config(self) -> dict:
                return {"max_lr": max_lr, "total": total, "pct_start": pct_start}

        return Schedule()


def _losses(tf: Any, settings: TrainingSettings, n_places: int) -> tuple[Any, Any]:
    """The place loss (cross-entropy, plus the level hinge for currents) and the metrics: cross-entropy, accuracy.

    The history records the cross-entropy as ``loss`` and the accuracy as ``train_accuracy``,
    as the torch trainer does, and the whole minimised loss as ``total_loss``.
    """
    level = settings.level_weight if settings.place_loss == "current" else 0.0

    def place_loss(y_true: Any, y_pred: Any) -> Any:
        logits = y_pred[:, -1]
        y = tf.cast(y_true[:, -1, 0], tf.int32)
        loss = tf.nn.sparse_softmax_cross_entropy_with_logits(labels=y, logits=logits)
        if level:
            onehot = tf.one_hot(y, n_places, dtype=logits.dtype)
            right = tf.reduce_sum(logits * onehot, axis=1)
            wrong = tf.reduce_sum(tf.nn.softplus(logits - 1.0) * (1.0 - onehot), axis=1) / max(n_places - 1, 1)
            loss = loss + level * (tf.nn.softplus(1.0 - right) + wrong)
        return loss

    def cross_entropy(y_true: Any, y_pred: Any) -> Any:
        y = tf.cast(y_true[:, -1, 0], tf.int32)
        return tf.nn.sparse_softmax_cross_entropy_with_logits(labels=y, logits=y_pred[:, -1])

    def accuracy(y_true: Any, y_pred: Any) -> Any:
        hit = tf.equal(tf.argmax(y_pred[:, -1], axis=-1, output_type=tf.int32), tf.cast(y_true[:, -1, 0], tf.int32))
        return tf.cast(hit, tf.float32)

    return place_loss, [cross_entropy, accuracy]


def train_nengo_dl(
    arch: Architecture,
    images: np.ndarray,
    labels: np.ndarray,
    settings: TrainingSettings | None = None,
    *,
    progress: bool = False,
) -> TrainingResult:
    """Train LoCS-Net with NengoDL on ``images`` (N, H, W) in [0, 1] with integer place ``labels`` (N,).

    Parameters and result as for :func:`.training.train` (``state_dict`` is ``None``).

    Raises
    ------
    BackendUnavailableError
        NengoDL is not installed (one sentence, with how to install it).
    UnsupportedFeatureError
        A torch-only option (:func:`nengo_problems`).
    """
    from neurovpr.errors import UnsupportedFeatureError

    s = settings or TrainingSettings()
    problems = nengo_problems(arch, s)
    if problems:
        raise UnsupportedFeatureError(f"--trainer {TRAINER} cannot train with {problems[0]}.")
    x_np = check_images(arch, images, what="training images")
    y_np = check_labels(arch, labels, x_np.shape[0])
    nengo_dl = import_nengo_dl(s.threads)
    import tensorflow as tf

    tf.random.set_seed(s.seed)
    rng = np.random.default_rng(s.seed)
    pick = rng.permutation(x_np.shape[0])[: min(512, x_np.shape[0])]
    params = initial_parameters(arch, x_np[pick][:, None], s, rng)
    net, objs, conns = build_rate_network(nengo_dl, arch, params, s)
    import nengo

    with net:
        probe = nengo.Probe(objs["places"], synapse=None, label="places_probe")
        rate_probes = [nengo.Probe(objs[name], synapse=None) for name in LAYER_NAMES[:3]] if s.rate_penalty else []
    batch = min(s.batch_size, x_np.shape[0])
    per_epoch = math.ceil(x_np.shape[0] / batch)
    place_loss, metrics = _losses(tf, s, arch.n_places)
    t0, c0 = time.perf_counter(), time.process_time()
    with _quiet():
        sim = nengo_dl.Simulator(net, minibatch_size=batch, seed=s.seed, device="/cpu:0", progress_bar=False)
        history: list[dict[str, float]] = []
        try:
            if s.weight_decay:
                weights = list(sim.keras_model.trainable_weights)
                sim.keras_model.add_loss(lambda: s.weight_decay * tf.add_n([tf.reduce_sum(tf.square(w)) for w in weights]))
            losses = {probe: place_loss, **{p: (lambda _y, a: tf.reduce_mean(tf.square(a), axis=[1, 2])) for p in rate_probes}}
            weights_of = {probe: 1.0, **{p: s.rate_penalty for p in rate_probes}}
            sim.compile(
                optimizer=tf.keras.optimizers.Adam(learning_rate=_OneCycle(tf, s.learning_rate, s.epochs * per_epoch)),
                loss=losses,
                loss_weights=weights_of,
                metrics={probe: metrics},
            )
            epochs: Any = range(s.epochs)
            if progress:
                from tqdm.auto import tqdm

                epochs = tqdm(epochs, desc="training LoCS-Net (NengoDL)", unit="epoch", leave=False)
            for epoch in epochs:
                order = np.concatenate(
                    [rng.permutation(x_np.shape[0]), rng.integers(0, x_np.shape[0], per_epoch * batch - x_np.shape[0])]
                )
                xs = augment(x_np[order], s, rng).reshape(order.size, 1, -1).astype(np.float32)
                ys = {probe: y_np[order].reshape(-1, 1, 1).astype(np.float32)}
                ys.update({p: np.zeros((order.size, 1, 1), np.float32) for p in rate_probes})
                fit = sim.fit({objs["input"]: xs}, ys, epochs=1, verbose=0, shuffle=False).history
                total = float(fit["loss"][-1])
                loss = float(next(v[-1] for k, v in fit.items() if k.endswith("cross_entropy")))
                acc = float(next(v[-1] for k, v in fit.items() if k.endswith("accuracy")))
                if not math.isfinite(total):
                    raise ValidationError(
                        f"training diverged at epoch {epoch + 1} (loss {total}); lower the learning rate ({s.learning_rate:g})."
                    )
                history.append({"epoch": epoch + 1, "loss": loss, "train_accuracy": acc, "total_loss": total})
                if progress:
                    epochs.set_postfix(loss=f"{loss:.3f}", acc=f"{acc:.3f}")
            trained = sim.data.get_params(*[(conns[name], "weights") for name in LAYER_NAMES])
        finally:
            sim.close()
    for name, got in zip(LAYER_NAMES, trained, strict=True):
        w = np.asarray(got, dtype=np.float64)  # kernels (kh, kw, in, out), the dense layer (places, features)
        params[f"{name}.weight"] = np.ascontiguousarray(np.transpose(w, (3, 2, 0, 1)) if w.ndim == 4 else w)
    seconds, cpu_seconds = time.perf_counter() - t0, time.process_time() - c0
    calibration: dict[str, float] = {}
    if s.place_loss == "current":
        acts = rate_forward(arch, params, x_np)["conv3"].reshape(x_np.shape[0], -1)
        params, calibration = calibrate_places(
            params, acts @ params["places.weight"].T, acts.sum(axis=1), drive=s.place_drive, active=s.active_places
        )
    return TrainingResult(
        parameters=params, state_dict=None, history=history, calibration=calibration, seconds=seconds, cpu_seconds=cpu_seconds
    )
