"""Poisson rate coding of preprocessed images, as in Diehl & Cook (2015) and the Modular SNN.

Intensity-to-rate mapping and timing
------------------------------------
Diehl & Cook (2015, Front. Comput. Neurosci. 9:99) present each image as Poisson spike
trains, one input neuron per pixel, with a rate proportional to the pixel intensity:
``rate = intensity / 4`` Hz, so the brightest pixel (255) fires at 63.75 Hz. Each
image is shown for 350 ms, followed by 150 ms without input so that the membrane
potentials and conductances decay back towards rest before the next image (the
adaptive thresholds do not reset). If the excitatory layer fired fewer than five
spikes, they raised the maximum rate by 32 Hz and showed the image again.

The Modular SNN code (QVPR/VPRSNN, ``non_modular_snn/snn_model.py``, used by every
module) keeps this coding: ``rates = pixels / intensity`` with ``--intensity 4``
(so 0..63.75 Hz for the 0..255 patch-normalised image), ``single_example_time =
0.35 s``, ``resting_time = 0.15 s``, and a first rest of ``0.5 s`` before the first
image. It does not re-present silent images: its ``repeat_no_spikes`` switch is
``False`` (and when switched on it would add 1 to the divisor, lowering the rates,
not raise them). Input neurons are Brian2 ``PoissonGroup`` neurons: in every time
step of length ``dt`` each fires with probability ``rate * dt``.

Why these numbers: 63.75 Hz over 350 ms gives about 22 input spikes for a white
pixel, enough drive for the 784-input layer to make a few excitatory spikes per
image against the adaptive threshold and lateral inhibition, yet few enough for
STDP's traces to separate causal from random pairs. The 150 ms rest is long
compared with the synaptic time constants (1 ms and 0.5 ms) and 1.5 excitatory
membrane time constants (100 ms), so little activity carries over between images.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neurovpr.errors import ValidationError

__all__ = ["RateCoding", "poisson_spike_trains"]


@dataclass(frozen=True, slots=True, kw_only=True)
class RateCoding:
    """Rate coding and presentation schedule (defaults: Diehl & Cook 2015 and VPRSNN).

    Attributes
    ----------
    intensity_divisor
        ``rate_hz = pixel / intensity_divisor``; 4 gives 63.75 Hz for a 255 pixel.
    presentation_ms
        How long each image is shown (350 ms).
    rest_ms
        Input-free time after each image (150 ms).
    initial_rest_ms
        Input-free time before the first image (500 ms in VPRSNN).
    """

    intensity_divisor: float = 4.0
    presentation_ms: float = 350.0
    rest_ms: float = 150.0
    initial_rest_ms: float = 500.0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.intensity_divisor) and self.intensity_divisor > 0):
            raise ValidationError(f"RateCoding.intensity_divisor must be > 0, got {self.intensity_divisor!r}.")
        for name in ("presentation_ms", "rest_ms", "initial_rest_ms"):
            value = getattr(self, name)
            low_ok = value > 0 if name == "presentation_ms" else value >= 0
            if not (np.isfinite(value) and low_ok):
                bound = "> 0" if name == "presentation_ms" else ">= 0"
                raise ValidationError(f"RateCoding.{name} must be {bound} ms, got {value!r}.")

    @property
    def max_rate_hz(self) -> float:
        """Rate of a 255 pixel."""
        return 255.0 / self.intensity_divisor

    def rates(self, image: np.ndarray) -> np.ndarray:
        """Per-pixel Poisson rates in Hz (flattened, one per input neuron) of a preprocessed 0..255 image."""
        arr = np.asarray(image)
        if arr.size == 0:
            raise ValidationError("RateCoding.rates got an empty image, expected a preprocessed 0..255 image.")
        if not np.isfinite(arr).all():
            raise ValidationError("RateCoding.rates got NaN or infinite pixel values, expected 0..255.")
        if arr.min() < 0 or arr.max() > 255:
            raise ValidationError(
                f"RateCoding.rates got pixel values in [{arr.min()}, {arr.max()}], expected the preprocessed range 0..255."
            )
        return arr.reshape(-1).astype(np.float64) / self.intensity_divisor

    def schedule(self, n_images: int) -> np.ndarray:
        """Start times (ms) of the presentations of ``n_images`` consecutive images."""
        period = self.presentation_ms + self.rest_ms
        return self.initial_rest_ms + period * np.arange(int(n_images), dtype=np.float64)


def poisson_spike_trains(
    rates_hz: np.ndarray, duration_ms: float, dt_ms: float, rng: np.random.Generator, t_start_ms: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Bernoulli-per-step Poisson spikes, like Brian2's ``PoissonGroup``.

    In each step of ``dt_ms`` a neuron with rate ``r`` fires with probability
    ``r * dt`` (``dt`` in seconds). Returns ``(times_ms, neuron_indices)`` sorted by
    time, with times on the step grid starting at ``t_start_ms``.
    """
    rates = np.asarray(rates_hz, dtype=np.float64).reshape(-1)
    if not np.isfinite(rates).all() or (rates < 0).any():
        raise ValidationError("poisson_spike_trains needs finite rates >= 0 Hz.")
    if not (dt_ms > 0 and duration_ms >= 0):
        raise ValidationError(f"poisson_spike_trains needs dt_ms > 0 and duration_ms >= 0, got {dt_ms}, {duration_ms}.")
    p = rates * dt_ms * 1e-3
    if (p > 1).any():
        raise ValidationError(
            f"poisson_spike_trains rate {rates.max()} Hz is above 1/dt = {1e3 / dt_ms} Hz, so a step cannot hold it."
        )
    n_steps = round(duration_ms / dt_ms)
    fired = rng.random((n_steps, rates.size)) < p
    steps, idx = np.nonzero(fired)
    return t_start_ms + steps * dt_ms, idx.astype(np.int64)
