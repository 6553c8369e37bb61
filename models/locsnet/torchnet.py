"""The trainable rate network of LoCS-Net in torch: SoftLIF, fake quantisation, the module.

Every layer is ``a' = amplitude * r(W * a + b)`` with ``r`` the smoothed LIF rate of
Hunsberger & Eliasmith (2015) (:func:`softlif`, spikes/ms). The place layer's output
for the loss is chosen by ``place_loss``:

- ``"current"`` (default): the logits are the place neurons' input currents ``J``. The
  place layer is still LIF; since its rate grows with ``J``, the most excited place
  neuron is the one that fires most. An auxiliary hinge (``level_weight`` in
  :class:`.training.TrainingSettings`) keeps the right place above threshold and the
  others below, and after training :func:`.calibration.calibrate_places` scales the
  place weights so the best place fires well above threshold.
- ``"rate"``: the logits are the place neurons' SoftLIF rates times a learned
  temperature (every layer trained through its rate, as written in the paper). On
  600 Nordland places it reached 11-14% training accuracy in 20 epochs where
  ``"current"`` reached 57-62%, because a place neuron far below threshold passes
  almost no gradient; it is kept as an option.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from neurovpr.errors import ValidationError

from .architecture import LAYER_NAMES, Architecture
from .quantise import WeightFormat
from .settings import PLACE_LOSSES

try:
    import torch
    from torch import nn
    from torch.nn import functional as F  # noqa: N812 - torch's convention
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError("LoCS-Net training needs torch: pip install torch==2.13.0 (the 'locsnet' extra).") from exc

__all__ = ["softlif", "fake_quantise", "LoCSNetTorch", "PLACE_LOSSES", "to_numpy_parameters", "load_state_dict_checked"]


class _SoftLIF(torch.autograd.Function):
    """The smoothed LIF rate with a hand-written derivative (few elementwise passes).

    With ``x = (j - 1) / sigma``, ``log p = log sigma + log softplus(x)`` (``x`` itself far
    below threshold) and ``r = amplitude / (tau_ref + tau_rc (log(1 + p) - log p))``:
    ``dr/dj = r**2 tau_rc / (amplitude sigma (1 + p)) * d log softplus(x) / dx``, which
    stays finite for any ``j`` and decays like ``1 / j**2`` far below threshold.
    """

    @staticmethod
    def forward(ctx: Any, j: torch.Tensor, tau_rc: float, tau_ref: float, sigma: float, amplitude: float) -> torch.Tensor:
        x = (j - 1.0) / sigma
        low = x < -30.0
        sp = F.softplus(torch.where(low, torch.zeros_like(x), x))
        log_sp = torch.where(low, x, torch.log(sp))
        log_p = log_sp + math.log(sigma)
        p = torch.exp(log_p)
        r = amplitude / (tau_ref + tau_rc * (torch.log1p(p) - log_p))
        dlog_sp = torch.where(low, torch.ones_like(x), torch.sigmoid(x) / sp)
        ctx.save_for_backward(r, p, dlog_sp)
        ctx.k = tau_rc / (amplitude * sigma)
        return r

    @staticmethod
    def backward(ctx: Any, grad: torch.Tensor) -> tuple[torch.Tensor | None, ...]:
        r, p, dlog_sp = ctx.saved_tensors
        return grad * (r * r) * dlog_sp * (ctx.k / (1.0 + p)), None, None, None, None


def softlif(j: torch.Tensor, tau_rc: float, tau_ref: float, sigma: float, amplitude: float) -> torch.Tensor:
    """``amplitude / (tau_ref + tau_rc log(1 + 1 / p))``, ``p = sigma softplus((j - 1) / sigma)`` (spikes/ms)."""
    return _SoftLIF.apply(j, tau_rc, tau_ref, sigma, amplitude)


class _RoundSTE(torch.autograd.Function):
    """Round in the forward pass, identity gradient (straight-through estimator)."""

    @staticmethod
    def forward(ctx: Any, x: torch.Tensor) -> torch.Tensor:
        return torch.round(x)

    @staticmethod
    def backward(ctx: Any, grad: torch.Tensor) -> torch.Tensor:
        return grad


def fake_quantise(w: torch.Tensor, fmt: WeightFormat) -> torch.Tensor:
    """Weights on ``fmt``'s grid (largest magnitude uses the full mantissa), straight-through gradient."""
    top = w.detach().abs().max().clamp_min(1e-12)
    step = top / fmt.levels
    return _RoundSTE.apply(w / step) * step


class LoCSNetTorch(nn.Module):
    """The trainable rate network of an :class:`Architecture`.

    Parameter names match :meth:`Architecture.parameter_shapes` (``conv1.weight``, ...,
    ``places.bias``) plus ``log_temperature``, so a state dict converts directly.
    """

    def __init__(self, arch: Architecture, weight_format: WeightFormat | None = None, place_loss: str = "current") -> None:
        super().__init__()
        if place_loss not in PLACE_LOSSES:
            raise ValidationError(f"place loss must be one of {', '.join(PLACE_LOSSES)}, got {place_loss!r}.")
        self.arch = arch
        self.weight_format = weight_format
        self.place_loss = place_loss
        in_ch = 1
        for name, conv in zip(LAYER_NAMES[:3], arch.convs, strict=True):
            self.add_module(name, nn.Conv2d(in_ch, conv.filters, conv.kernel, conv.stride, conv.padding,
                                            bias=arch.conv_bias))
            in_ch = conv.filters
        self.places = nn.Linear(arch.n_features, arch.n_places, bias=arch.dense_bias)
        self.log_temperature = nn.Parameter(torch.tensor(math.log(5.0)))
        n = arch.neuron
        self._rate = (float(n.tau_rc), float(n.tau_ref), float(n.sigma), float(n.amplitude))

    def layers(self) -> list[nn.Module]:
        """The four weighted layers, in order."""
        return [getattr(self, name) for name in LAYER_NAMES]

    def _weight(self, layer: nn.Module) -> torch.Tensor:
        w = layer.weight
        return fake_quantise(w, self.weight_format) if self.weight_format is not None else w

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, list[torch.Tensor]]:
        """Logits ``(N, n_places)`` and the activations of every layer for images ``(N, 1, H, W)``."""
        acts = []
        for layer in self.layers()[:3]:
            j = F.conv2d(x, self._weight(layer), layer.bias, layer.stride, layer.padding)
            x = softlif(j, *self._rate)
            acts.append(x)
        j = F.linear(x.flatten(1), self._weight(self.places), self.places.bias)
        out = softlif(j, *self._rate)
        acts.append(out)
        if self.place_loss == "current":
            return j, acts
        return out * self.log_temperature.exp(), acts

    @torch.no_grad()
    def place_currents(self, x: torch.Tensor, batch: int = 512) -> tuple[torch.Tensor, torch.Tensor]:
        """The place layer's input ``J`` (N, n_places) and the summed conv3 activation (N,) for images (N, 1, H, W)."""
        currents, sums = [], []
        for start in range(0, x.shape[0], batch):
            h = x[start : start + batch]
            for layer in self.layers()[:3]:
                h = softlif(F.conv2d(h, self._weight(layer), layer.bias, layer.stride, layer.padding), *self._rate)
            h = h.flatten(1)
            currents.append(F.linear(h, self._weight(self.places), self.places.bias))
            sums.append(h.sum(1))
        return torch.cat(currents), torch.cat(sums)

    @torch.no_grad()
    def initialise(self, images: torch.Tensor, mean: float, std: float) -> None:
        """Scale and shift each layer so its input ``J`` on ``images`` has this mean and std per channel."""
        x = images
        for layer in self.layers():
            dense = isinstance(layer, nn.Linear)
            inp = x.flatten(1) if dense else x
            j = F.linear(inp, layer.weight) if dense else F.conv2d(inp, layer.weight, None, layer.stride, layer.padding)
            dims = (0,) if dense else (0, 2, 3)
            layer.weight.mul_(std / j.std(dim=dims).clamp_min(1e-6).view(-1, *([1] * (layer.weight.dim() - 1))))
            j = F.linear(inp, layer.weight) if dense else F.conv2d(inp, layer.weight, None, layer.stride, layer.padding)
            shift = mean - j.mean(dim=dims)
            if layer.bias is not None:
                layer.bias.copy_(shift)
            else:
                ones = torch.ones_like(layer.weight[:1])
                drive = F.linear(inp, ones) if dense else F.conv2d(inp, ones, None, layer.stride, layer.padding)
                per_weight = shift / drive.mean().clamp_min(1e-6)
                layer.weight.add_(per_weight.view(-1, *([1] * (layer.weight.dim() - 1))))
            j = F.linear(inp, self._weight(layer), layer.bias) if dense else F.conv2d(
                inp, self._weight(layer), layer.bias, layer.stride, layer.padding)
            x = softlif(j, *self._rate)


def to_numpy_parameters(model: LoCSNetTorch, *, quantised: bool = True) -> dict[str, np.ndarray]:
    """The trained arrays by name (weights on the chip grid when the model trains quantised)."""
    out: dict[str, np.ndarray] = {}
    with torch.no_grad():
        for name, layer in zip(LAYER_NAMES, model.layers(), strict=True):
            w = model._weight(layer) if quantised else layer.weight
            out[f"{name}.weight"] = w.detach().cpu().double().numpy().copy()
            if layer.bias is not None:
                out[f"{name}.bias"] = layer.bias.detach().cpu().double().numpy().copy()
    return out


def load_state_dict_checked(model: LoCSNetTorch, state: dict[str, Any], *, where: str = "checkpoint") -> None:
    """Load a state dict after checking its names and shapes against the model (one clear error otherwise)."""
    expected = {k: tuple(v.shape) for k, v in model.state_dict().items()}
    if not isinstance(state, dict):
        raise ValidationError(f"{where} is not a state dict of tensors, got {type(state).__name__}.")
    missing = sorted(set(expected) - set(state))
    extra = sorted(set(state) - set(expected))
    if missing or extra:
        what = f"lacks {missing[0]!r}" if missing else f"has {extra[0]!r}, which this architecture does not use"
        raise ValidationError(f"{where} {what}; it was saved for a different architecture.")
    for key, shape in expected.items():
        got = tuple(getattr(state[key], "shape", ()))
        if got != shape:
            raise ValidationError(
                f"{where} tensor {key!r} has shape {got} but this architecture needs {shape}; "
                "it was saved for a different architecture."
            )
    model.load_state_dict(state)


