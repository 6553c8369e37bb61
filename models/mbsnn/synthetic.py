"""Synthetic PN spike trains of a route, for tests, demos and benchmarks without real data.

The route is a sequence of places. At each place the event camera sees its own
scene, which this generator reduces to what the mushroom body uses: a short sequence
of *volleys*, every few milliseconds a place-specific group of projection neurons
firing together, each PN at its own fixed latency of 0-2 ms within the volley (edges
sweeping over neighbouring mega-pixels in a fixed order); the sequence repeats while
the place is in view. Two traversals of the same route share
the places and volleys; each traversal has its own lost spikes, timing jitter and
background noise, and may be driven at another speed.
"""

from __future__ import annotations

import numpy as np

from neurovpr.data.events import PNSpikes
from neurovpr.errors import ValidationError

__all__ = ["synthetic_traversal"]


def synthetic_traversal(
    n_pn: int = 120,
    duration_ms: float = 2000.0,
    *,
    route_seed: int = 0,
    seed: int = 0,
    speed: float = 1.0,
    volley_ms: float = 1.0,
    group: float = 0.12,
    place_ms: float = 60.0,
    motif: int = 4,
    drop: float = 0.1,
    jitter: float = 0.2,
    noise_hz: float = 5.0,
) -> PNSpikes:
    """PN spikes (1-ms bins) of one traversal of a synthetic route.

    Parameters
    ----------
    n_pn
        Number of projection neurons.
    duration_ms
        Length of the traversal at ``speed = 1``.
    route_seed
        Draws the places: traversals with the same ``route_seed`` are of the same route.
    seed
        Draws this traversal's own randomness.
    speed
        Route covered per ms relative to 1; every time is divided by it.
    volley_ms
        Time between volleys at speed 1.
    group
        Share of the PNs in each volley.
    place_ms
        Length of one place at speed 1.
    motif
        Volleys in a place's sequence, which repeats while the place is in view.
    drop
        Share of the spikes this traversal loses.
    jitter
        Probability that a spike moves one bin earlier or later.
    noise_hz
        Random extra spikes of every PN.
    """
    if isinstance(n_pn, bool) or int(n_pn) != n_pn or n_pn < 2:
        raise ValidationError(f"synthetic_traversal: n_pn must be an integer >= 2, got {n_pn!r}.")
    checks = (duration_ms >= place_ms, speed > 0, 1.0 <= volley_ms <= place_ms, 0 < group <= 1, motif >= 1,
              0 <= drop < 1, 0 <= jitter <= 1, noise_hz >= 0)  # fmt: skip
    if not all(checks):
        raise ValidationError(
            "synthetic_traversal: need duration_ms >= place_ms, speed > 0, 1 <= volley_ms <= place_ms, "
            "0 < group <= 1, motif >= 1, 0 <= drop < 1, 0 <= jitter <= 1 and noise_hz >= 0."
        )
    n_pn = int(n_pn)
    route = np.random.default_rng(route_seed)
    rng = np.random.default_rng(seed)
    volley_times = np.arange(0.0, duration_ms, volley_ms)
    per_place = max(int(place_ms // volley_ms), 1)
    n_places = int(np.ceil(volley_times.size / per_place))
    # each place: a motif of volleys, each a group of PNs with fixed latencies, repeated
    size = max(round(group * n_pn), 1)
    members = np.stack([np.sort(route.permutation(n_pn)[:size]) for _ in range(n_places * motif)])
    latency = route.integers(0, 3, size=members.shape)
    k = np.arange(volley_times.size)
    which = (k // per_place) * motif + (k % per_place) % motif
    t = (volley_times[:, None] + latency[which]).ravel()
    idx = members[which].ravel()
    keep = rng.random(t.size) >= drop
    t, idx = t[keep], idx[keep]
    t = t + rng.choice([-1.0, 0.0, 1.0], size=t.size, p=[jitter / 2, 1 - jitter, jitter / 2])
    n_noise = rng.poisson(noise_hz * duration_ms / 1000.0 * n_pn)
    t = np.concatenate([t, rng.uniform(0.0, duration_ms, n_noise)])
    idx = np.concatenate([idx, rng.integers(0, n_pn, n_noise)])
    bins = np.floor(np.clip(t, 0.0, duration_ms - 1e-9) / speed)
    duration = float(np.floor(duration_ms / speed))
    inside = bins < duration
    key = np.unique(bins[inside].astype(np.int64) * n_pn + idx[inside])  # one spike per PN and bin
    times, neurons = np.divmod(key, n_pn)
    return PNSpikes(times_ms=times.astype(np.float64), idx=neurons, n_pn=n_pn, duration_ms=duration)
