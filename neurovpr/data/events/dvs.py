"""A DVS emulator: turn an aligned sequence of intensity frames into events.

The model is the standard one of event-camera simulators (ESIM, Rebecq et al. 2018;
v2e, Hu et al. 2021): each pixel holds the log intensity at its last event (its
reference level); the log intensity is interpolated linearly in time between frames,
and every time it moves one contrast threshold above (below) the reference level the
pixel emits an ON (OFF) event at the interpolated crossing time and its reference level
moves by one threshold. Options:

* per-pixel threshold mismatch (a normal spread of the thresholds, fixed per pixel);
* a refractory period: a crossing less than ``refractory_us`` after the pixel's last
  emitted event is not emitted (the reference level still moves, as in v2e);
* background-activity noise: Poisson events at ``noise_rate_hz`` per pixel, random
  polarity, uniformly spread in time (they do not move the reference level).

Everything random comes from one ``numpy.random.Generator`` seeded by ``seed``.
"""

from __future__ import annotations

import numpy as np
from tqdm import tqdm

from neurovpr.data.events.stream import EventStream
from neurovpr.errors import ValidationError

__all__ = ["emulate_dvs"]


def _check_inputs(frames: np.ndarray, times_us: np.ndarray) -> None:
    if frames.ndim != 3:
        raise ValidationError(
            f"emulate_dvs: frames must be an (n_frames, height, width) grayscale array, got shape {frames.shape}."
        )
    if frames.shape[0] < 2:
        raise ValidationError(f"emulate_dvs: at least 2 frames are needed, got {frames.shape[0]}.")
    if not np.all(np.isfinite(frames)) or frames.min() < 0:
        raise ValidationError("emulate_dvs: frame intensities must be finite and >= 0.")
    if times_us.shape != (frames.shape[0],):
        raise ValidationError(
            f"emulate_dvs: times_us must hold one time per frame ({frames.shape[0]}), got shape {times_us.shape}."
        )
    if times_us[0] < 0 or np.any(np.diff(times_us) <= 0):
        raise ValidationError("emulate_dvs: times_us must be >= 0 and strictly increasing.")


def emulate_dvs(
    frames: np.ndarray,
    times_us: np.ndarray,
    *,
    threshold_on: float = 0.2,
    threshold_off: float = 0.2,
    threshold_sigma: float = 0.0,
    refractory_us: int = 0,
    noise_rate_hz: float = 0.0,
    log_eps: float | None = None,
    seed: int = 0,
    progress: bool = False,
) -> EventStream:
    """Emulate a DVS watching ``frames``.

    Parameters
    ----------
    frames
        ``(n_frames, height, width)`` intensities (any linear unit, >= 0).
    times_us
        Time of each frame in integer microseconds, strictly increasing.
    threshold_on, threshold_off
        Contrast thresholds: the change of natural-log intensity that makes one ON / OFF
        event (0.2 is typical of DAVIS sensors).
    threshold_sigma
        Standard deviation of the per-pixel threshold mismatch (same unit); thresholds
        are clipped at 0.01.
    refractory_us
        Minimum time between two emitted events of one pixel.
    noise_rate_hz
        Rate of background-activity noise events per pixel.
    log_eps
        Added to intensities before the log; default 1e-3 of the brightest frame value.
    seed
        Seed of the generator used for threshold mismatch and noise.
    progress
        Show a tqdm progress bar over the frames.

    Returns
    -------
    EventStream
        Events sorted by time (then row, then column); the sensor is ``width x height``.
    """
    frames = np.asarray(frames, dtype=np.float64)
    times_us = np.asarray(times_us)
    if not np.issubdtype(times_us.dtype, np.integer):
        if not np.all(np.isfinite(times_us)) or np.any(times_us != np.round(times_us)):
            raise ValidationError("emulate_dvs: times_us must be integer microseconds.")
    times_us = times_us.astype(np.int64)
    _check_inputs(frames, times_us)
    for name, value in (("threshold_on", threshold_on), ("threshold_off", threshold_off)):
        if not value > 0:
            raise ValidationError(f"emulate_dvs: {name} must be > 0, got {value!r}.")
    if threshold_sigma < 0 or refractory_us < 0 or noise_rate_hz < 0:
        raise ValidationError("emulate_dvs: threshold_sigma, refractory_us and noise_rate_hz must be >= 0.")
    n_frames, height, width = frames.shape
    n_pix = height * width
    rng = np.random.default_rng(seed)
    eps = float(log_eps) if log_eps is not None else 1e-3 * max(float(frames.max()), 1e-12)
    if not eps > 0:
        raise ValidationError(f"emulate_dvs: log_eps must be > 0, got {log_eps!r}.")
    c_on = np.full(n_pix, float(threshold_on))
    c_off = np.full(n_pix, float(threshold_off))
    if threshold_sigma > 0:
        c_on = np.maximum(c_on + rng.normal(0.0, threshold_sigma, n_pix), 0.01)
        c_off = np.maximum(c_off + rng.normal(0.0, threshold_sigma, n_pix), 0.01)
    log_frames = np.log(frames.reshape(n_frames, n_pix) + eps)
    ref = log_frames[0].copy()
    last_t = np.full(n_pix, -np.inf)
    out_pix: list[np.ndarray] = []
    out_t: list[np.ndarray] = []
    out_p: list[np.ndarray] = []
    for k in tqdm(range(1, n_frames), desc="DVS emulation", unit="frame", disable=not progress):
        l0, l1 = log_frames[k - 1], log_frames[k]
        t0, dt = float(times_us[k - 1]), float(times_us[k] - times_us[k - 1])
        delta = l1 - ref
        rising = delta > 0
        step = np.where(rising, c_on, -c_off)
        n_cross = np.floor(delta / step).astype(np.int64)  # >= 0 on both sides
        slope = l1 - l0
        for j in range(1, int(n_cross.max(initial=0)) + 1):
            pix = np.flatnonzero(n_cross >= j)
            level = ref[pix] + j * step[pix]
            with np.errstate(divide="ignore", invalid="ignore"):
                frac = np.where(slope[pix] != 0, (level - l0[pix]) / slope[pix], 1.0)
            t_ev = np.rint(t0 + np.clip(frac, 0.0, 1.0) * dt)
            emit = t_ev - last_t[pix] >= refractory_us
            pix, t_ev = pix[emit], t_ev[emit]
            last_t[pix] = t_ev
            out_pix.append(pix)
            out_t.append(t_ev)
            out_p.append(rising[pix].astype(np.int8))
        ref += n_cross * step
        if noise_rate_hz > 0:
            n_noise = rng.poisson(noise_rate_hz * dt * 1e-6 * n_pix)
            out_pix.append(rng.integers(0, n_pix, n_noise))
            out_t.append(np.floor(t0 + rng.random(n_noise) * dt))
            out_p.append(rng.integers(0, 2, n_noise).astype(np.int8))
    pix = np.concatenate(out_pix) if out_pix else np.zeros(0, dtype=np.int64)
    if pix.size == 0:
        raise ValidationError(
            f"emulate_dvs: no pixel's log intensity changed by a contrast threshold "
            f"({threshold_on} ON / {threshold_off} OFF), so there are no events."
        )
    t = np.concatenate(out_t).astype(np.int64)
    p = np.concatenate(out_p)
    y, x = np.divmod(pix, width)
    order = np.lexsort((x, y, t))
    return EventStream(width=width, height=height, x=x[order], y=y[order], t=t[order], p=p[order])
