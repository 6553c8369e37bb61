"""Training LoCS-Net with torch through the SoftLIF rate approximation.

The network (:class:`.torchnet.LoCSNetTorch`) is trained with a sparse categorical
cross-entropy, one class per place, Adam with a one-cycle learning-rate schedule.
Options that prepare the weights for a chip:

- ``weight_decay``: an L2 penalty on the weights, keeping them small and evenly spread
  so an 8-bit grid loses little (the paper's weight regularisation);
- ``quantise``: quantisation-aware training to a hwspec's weight format
  (:mod:`.quantise`): the forward pass uses weights rounded to the chip's grid, the
  gradient passes straight through to the float weights;
- ``rate_penalty``: an L2 penalty on the hidden layers' activations, fewer spikes per
  inference (fewer synaptic events, less energy).

Initialisation is data-driven: before training, each layer's weights are scaled and
shifted on a batch of training images so its input ``J`` has mean ``init_mean`` and
standard deviation ``init_std`` per channel (threshold at 1), which keeps the smoothed
rate in its sensitive range even without biases.

Augmentation (every epoch shows each training image once, transformed): a random
shift of up to ``shift`` pixels (edges replicated), a random contrast and brightness
change and Gaussian pixel noise, clipped to [0, 1].

With ``place_loss="current"`` the place layer is calibrated after training
(:func:`calibrate_places`): its weights are scaled and shifted (the order of the places
for each image is unchanged) so that, on the training images, the best place receives
``J = place_drive`` on average and about ``active_places`` places are above threshold.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from neurovpr.errors import ValidationError

from .architecture import Architecture
from .calibration import calibrate_places
from .quantise import WeightFormat
from .settings import TrainingResult, TrainingSettings, check_labels
from .torchnet import LoCSNetTorch, load_state_dict_checked, to_numpy_parameters

try:
    import torch
    from torch.nn import functional as F  # noqa: N812 - torch's convention
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError("LoCS-Net training needs torch: pip install torch==2.13.0 (the 'locsnet' extra).") from exc

__all__ = ["TrainingSettings", "TrainingResult", "train", "check_labels"]


def _shift(padded: torch.Tensor, dy: torch.Tensor, dx: torch.Tensor, h: int, w: int) -> torch.Tensor:
    """Crop an ``h x w`` window at offsets ``(dy, dx)`` from each padded image."""
    n, wp = padded.shape[0], padded.shape[-1]
    rows = (dy.view(n, 1, 1, 1) + torch.arange(h).view(1, 1, h, 1)).expand(n, 1, h, wp)
    cols = (dx.view(n, 1, 1, 1) + torch.arange(w).view(1, 1, 1, w)).expand(n, 1, h, w)
    return torch.gather(torch.gather(padded, 2, rows), 3, cols)


def _augment(x: torch.Tensor, s: TrainingSettings, gen: torch.Generator) -> torch.Tensor:
    n, _, h, w = x.shape
    if s.shift:
        p = s.shift
        padded = F.pad(x, (p, p, p, p), mode="replicate")
        dy = torch.randint(0, 2 * p + 1, (n,), generator=gen)
        dx = torch.randint(0, 2 * p + 1, (n,), generator=gen)
        x = _shift(padded, dy, dx, h, w)
    if s.contrast or s.brightness:
        c = 1.0 + s.contrast * (2.0 * torch.rand(n, 1, 1, 1, generator=gen) - 1.0)
        b = s.brightness * (2.0 * torch.rand(n, 1, 1, 1, generator=gen) - 1.0)
        x = (x - 0.5) * c + 0.5 + b
    if s.noise:
        x = x + s.noise * torch.randn(x.shape, generator=gen)
    return x.clamp(0.0, 1.0)


def train(
    arch: Architecture,
    images: np.ndarray,
    labels: np.ndarray,
    settings: TrainingSettings | None = None,
    *,
    weight_format: WeightFormat | None = None,
    progress: bool = False,
    initial_state: dict[str, Any] | None = None,
) -> TrainingResult:
    """Train LoCS-Net on ``images`` (N, H, W) in [0, 1] with integer place ``labels`` (N,).

    Parameters
    ----------
    arch
        The architecture; ``labels`` must lie in ``0 .. arch.n_places - 1`` and every
        place must have at least one image (checked before anything is trained).
    settings
        Hyper-parameters (defaults: :class:`TrainingSettings`).
    weight_format
        The chip's weight format for quantisation-aware training.
    progress
        Show a progress bar over epochs.
    initial_state
        A state dict to start from (checked against ``arch``; skips the initialisation).
    """
    from .inference import check_images

    s = settings or TrainingSettings()
    x_np = check_images(arch, images, what="training images")
    y_np = check_labels(arch, labels, x_np.shape[0])
    if s.threads is not None:
        torch.set_num_threads(s.threads)
    torch.manual_seed(s.seed)
    gen = torch.Generator().manual_seed(s.seed)
    x = torch.from_numpy(x_np.astype(np.float32))[:, None]
    y = torch.from_numpy(y_np)
    model = LoCSNetTorch(arch, weight_format, place_loss=s.place_loss)
    if initial_state is not None:
        load_state_dict_checked(model, initial_state)
    else:
        pick = torch.randperm(x.shape[0], generator=gen)[: min(512, x.shape[0])]
        model.initialise(x[pick], s.init_mean, s.init_std)
    weights = [layer.weight for layer in model.layers()]
    opt = torch.optim.Adam(model.parameters(), lr=s.learning_rate)
    steps = s.epochs * math.ceil(x.shape[0] / s.batch_size)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=s.learning_rate, total_steps=steps, pct_start=0.15)
    epochs: Any = range(s.epochs)
    if progress:
        from tqdm.auto import tqdm

        epochs = tqdm(epochs, desc="training LoCS-Net", unit="epoch", leave=False)
    history = []
    t0, c0 = time.perf_counter(), time.process_time()
    model.train()
    for epoch in epochs:
        order = torch.randperm(x.shape[0], generator=gen)
        total = correct = 0.0
        for start in range(0, x.shape[0], s.batch_size):
            idx = order[start : start + s.batch_size]
            logits, acts = model(_augment(x[idx], s, gen))
            loss = F.cross_entropy(logits, y[idx])
            total += float(loss.detach()) * idx.numel()
            correct += float((logits.detach().argmax(1) == y[idx]).sum())
            if s.weight_decay:
                loss = loss + s.weight_decay * sum((w * w).sum() for w in weights)
            if s.place_loss == "current" and s.level_weight:
                wrong = torch.ones_like(logits, dtype=torch.bool).scatter_(1, y[idx].view(-1, 1), False)
                level = F.softplus(1.0 - logits.gather(1, y[idx].view(-1, 1))).mean() + F.softplus(logits[wrong] - 1.0).mean()
                loss = loss + s.level_weight * level
            if s.rate_penalty:
                loss = loss + s.rate_penalty * sum((a * a).mean() for a in acts[:3])
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            sched.step()
        record = {"epoch": epoch + 1, "loss": total / x.shape[0], "train_accuracy": correct / x.shape[0]}
        if not math.isfinite(record["loss"]):
            raise ValidationError(
                f"training diverged at epoch {epoch + 1} (loss {record['loss']}); lower the learning rate "
                f"({s.learning_rate:g})."
            )
        history.append(record)
        if progress:
            epochs.set_postfix(loss=f"{record['loss']:.3f}", acc=f"{record['train_accuracy']:.3f}")
    model.eval()
    params = to_numpy_parameters(model)
    calibration: dict[str, float] = {}
    if s.place_loss == "current":
        currents, sums = model.place_currents(x)
        params, calibration = calibrate_places(params, currents.double().numpy(), sums.double().numpy(),
                                               drive=s.place_drive, active=s.active_places)
    return TrainingResult(
        parameters=params,
        state_dict={k: v.detach().clone() for k, v in model.state_dict().items()},
        history=history,
        calibration=calibration,
        seconds=time.perf_counter() - t0,
        cpu_seconds=time.process_time() - c0,
    )
