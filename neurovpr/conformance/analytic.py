"""Analytic answers the conformance cases compare against.

Everything here follows from ``docs/semantics.md`` and the model equations alone:
closed forms where the dynamics have one, a high-precision ODE solution where
they do not. Discrete-time answers evaluate the exact continuous solution at the
grid points where the semantics test the threshold (the end of each step) and
refuse parameters that put a threshold crossing within round-off of a grid point,
so that an answer never depends on floating-point luck.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.integrate import solve_ivp

__all__ = [
    "GRID_MARGIN",
    "lif_isi_closed_form",
    "lif_steps_to_threshold",
    "lif_grid_spike_times",
    "lif_grid_trace",
    "current_psp",
    "conductance_psp",
    "decaying_sum",
    "ca2_grid_spike_times",
    "theta_grid_spike_times",
    "euler_grid_spike_times",
    "euler_conductance_psp",
    "pair_stdp_weight",
    "diehl_cook_pair_weight",
]

#: Smallest distance (in steps, or mV) a threshold crossing must keep from a grid point.
GRID_MARGIN = 1e-6


def lif_isi_closed_form(
    *, tau_m: float, cm: float, v_rest: float, v_reset: float, v_thresh: float, tau_refrac: float, i_offset: float
) -> float:
    """Continuous-time inter-spike interval of a LIF neuron under constant current.

    ``T = tau_refrac + tau_m ln((R I - (v_reset - v_rest)) / (R I - (v_thresh - v_rest)))``
    with ``R = tau_m / cm``; ``inf`` at or below the rheobase ``R I <= v_thresh - v_rest``.
    """
    drive = tau_m / cm * i_offset
    if drive <= v_thresh - v_rest:
        return math.inf
    return tau_refrac + tau_m * math.log((drive - (v_reset - v_rest)) / (drive - (v_thresh - v_rest)))


def lif_steps_to_threshold(*, tau_m: float, dt: float, v_start: float, v_inf: float, v_thresh: float) -> int | None:
    """Steps a LIF neuron needs from ``v_start`` to reach ``v_thresh`` at a step's end.

    Between spikes ``v(k dt) = v_inf - (v_inf - v_start) exp(-k dt / tau_m)``, so the
    first ``k`` with ``v(k dt) >= v_thresh`` is
    ``ceil(tau_m / dt * ln((v_inf - v_start) / (v_inf - v_thresh)))`` (at least 1).
    ``None`` when the threshold is never reached.
    """
    if v_inf <= v_thresh:
        return None
    x = tau_m / dt * math.log((v_inf - v_start) / (v_inf - v_thresh))
    if abs(x - round(x)) < GRID_MARGIN:
        raise ValueError(f"threshold crossing {x!r} steps lies on the grid; choose other parameters")
    return max(1, math.ceil(x))


def lif_grid_spike_times(
    *,
    dt: float,
    t_stop: float,
    tau_m: float,
    cm: float,
    v_rest: float,
    v_reset: float,
    v_thresh: float,
    tau_refrac: float,
    i_offset: float,
    v_init: float | None = None,
    tau_lockout: float = 0.0,
) -> np.ndarray:
    """Spike times of a LIF neuron under constant current, on the simulation grid.

    The first spike comes ``k0`` steps after the start (from ``v_init``), every later
    one ``R + k`` steps after the previous (``R = round(tau_refrac / dt)`` steps held at
    ``v_reset``, then ``k`` steps to threshold, see :func:`lif_steps_to_threshold`). A
    spike lockout (``tau_lockout``) lets no spike come before ``L = max(R,
    round(tau_lockout / dt))`` steps while the membrane integrates freely after the
    ``R`` held steps, so every interval is ``max(L, R + k)`` steps.
    """
    v_inf = v_rest + tau_m / cm * i_offset
    v0 = v_rest if v_init is None else v_init
    k0 = lif_steps_to_threshold(tau_m=tau_m, dt=dt, v_start=v0, v_inf=v_inf, v_thresh=v_thresh)
    k = lif_steps_to_threshold(tau_m=tau_m, dt=dt, v_start=v_reset, v_inf=v_inf, v_thresh=v_thresh)
    n_steps = round(t_stop / dt)
    if k0 is None or k is None or k0 > n_steps:
        return np.zeros(0)
    n_ref = round(tau_refrac / dt)
    isi = max(n_ref, round(tau_lockout / dt), n_ref + k)
    steps = np.arange(k0, n_steps + 1, isi)
    return steps * dt


def lif_grid_trace(
    t: np.ndarray,
    spikes: np.ndarray,
    *,
    dt: float,
    tau_m: float,
    cm: float,
    v_rest: float,
    v_reset: float,
    tau_refrac: float,
    i_offset: float,
    v_init: float | None = None,
) -> np.ndarray:
    """Membrane potential of a LIF neuron under constant current at the recorded times ``t``.

    Recordings are taken after threshold and reset, so ``v = v_reset`` at a spike and
    for the ``round(tau_refrac / dt)`` refractory steps after it; in between, from the
    segment start ``t0`` and ``v0`` (``v_init`` at 0, ``v_reset`` after a refractory
    period), ``v(t) = v_inf - (v_inf - v0) exp(-(t - t0) / tau_m)``.
    """
    t = np.asarray(t, dtype=float)
    v_inf = v_rest + tau_m / cm * i_offset
    held = round(tau_refrac / dt) * dt
    t0 = np.zeros_like(t)
    v0 = np.full_like(t, v_rest if v_init is None else v_init)
    out = np.full_like(t, np.nan)
    for s in np.asarray(spikes, dtype=float):
        after = t >= s - 1e-9
        t0[after] = s + held
        v0[after] = v_reset
        out[after & (t <= s + held + 1e-9)] = v_reset
    free = np.isnan(out)
    out[free] = v_inf - (v_inf - v0[free]) * np.exp(-(t[free] - t0[free]) / tau_m)
    return out


def current_psp(s: np.ndarray, *, weight: float, tau_m: float, tau_syn: float, cm: float) -> np.ndarray:
    """Exact PSP ``v - v_rest`` of a current-based LIF, ``s`` ms after a current jump ``weight``.

    ``cm du/ds = -cm u / tau_m + w exp(-s / tau_syn)`` with ``u(0) = 0`` gives
    ``u = w R tau_syn / (tau_m - tau_syn) (exp(-s / tau_m) - exp(-s / tau_syn))``
    (``R = tau_m / cm``) and, for ``tau_syn == tau_m``, ``u = (w / cm) s exp(-s / tau_m)``.
    Zero for ``s < 0``.
    """
    s = np.asarray(s, dtype=float)
    pos = np.clip(s, 0.0, None)
    if tau_syn == tau_m:
        u = weight / cm * pos * np.exp(-pos / tau_m)
    else:
        u = weight * (tau_m / cm) * tau_syn / (tau_m - tau_syn) * (np.exp(-pos / tau_m) - np.exp(-pos / tau_syn))
    return np.where(s >= 0, u, 0.0)


def conductance_psp(
    s: np.ndarray,
    *,
    weight: float,
    tau_m: float,
    tau_syn: float,
    cm: float,
    v_rest: float,
    e_rev: float,
) -> np.ndarray:
    """Membrane potential of a conductance-based LIF ``s`` ms after a conductance jump ``weight``.

    Solves ``cm dv/ds = cm (v_rest - v) / tau_m + g (e_rev - v)``, ``dg/ds = -g / tau_syn``,
    ``v(0) = v_rest``, ``g(0) = weight`` with DOP853 at ``rtol = 1e-12``; ``v_rest`` for ``s < 0``.
    """
    s = np.asarray(s, dtype=float)

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        v, g = y
        return [(v_rest - v) / tau_m + g * (e_rev - v) / cm, -g / tau_syn]

    t_end = float(max(s.max(), 0.0)) + 1.0
    sol = solve_ivp(rhs, (0.0, t_end), [v_rest, weight], method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True)
    assert sol.success, sol.message
    return np.where(s >= 0, sol.sol(np.clip(s, 0.0, None))[0], v_rest)


def decaying_sum(t: np.ndarray, events: np.ndarray, *, jump: float, tau: float, initial: float = 0.0) -> np.ndarray:
    """``initial exp(-t / tau) + sum over events e <= t of jump exp(-(t - e) / tau)``.

    The value of a variable that decays with ``tau`` and jumps by ``jump`` at each
    event, sampled after the jumps at the same instant (as recordings are).
    """
    t = np.asarray(t, dtype=float)[:, None]
    e = np.asarray(events, dtype=float)[None, :]
    lag = t - e
    hit = lag >= -1e-9
    terms = np.where(hit, jump * np.exp(-np.clip(lag, 0.0, None) / tau), 0.0)
    return initial * np.exp(-t[:, 0] / tau) + terms.sum(axis=1)


def _first_crossing(values: np.ndarray, level: np.ndarray | float) -> int | None:
    """Index of the first ``values >= level``, refusing near-ties."""
    gap = values - level
    if np.any(np.abs(gap) < GRID_MARGIN):
        raise ValueError("a threshold crossing lies on the grid; choose other parameters")
    hits = np.flatnonzero(gap >= 0)
    return int(hits[0]) if hits.size else None


def _spikes_with_decaying_state(
    membrane: Callable[[np.ndarray, float, float], tuple[np.ndarray, np.ndarray | float]],
    *,
    dt: float,
    t_stop: float,
    tau_refrac: float,
    v_start: float,
    v_reset: float,
    state: float,
    decay: Callable[[int], float],
    jump: float,
) -> np.ndarray:
    """Spike times on the step grid of a neuron with one state variable that decays and jumps at each spike.

    ``membrane(s, v0, state)`` gives, at the times ``s`` (ms) after the membrane is free
    again from ``v0`` with the state at ``state``, the membrane and the level it fires
    at; a spike is the first step end where the membrane reaches its level. The state
    falls by the factor ``decay(n)`` over ``n`` steps throughout and grows by ``jump`` at
    each spike; after a spike the membrane is held at ``v_reset`` for ``tau_refrac``.
    """
    n_steps = round(t_stop / dt)
    n_ref = round(tau_refrac / dt)
    start, v0 = 0, v_start
    times: list[float] = []
    while start < n_steps:
        s = np.arange(1, n_steps - start + 1) * dt
        k = _first_crossing(*membrane(s, v0, state))
        if k is None:
            break
        spike = start + k + 1
        times.append(spike * dt)
        state = state * decay(k + 1) + jump
        state *= decay(n_ref)
        start, v0 = spike + n_ref, v_reset
    return np.asarray(times)


def ca2_grid_spike_times(
    *,
    dt: float,
    t_stop: float,
    tau_m: float,
    cm: float,
    v_rest: float,
    v_reset: float,
    v_thresh: float,
    tau_refrac: float,
    i_offset: float,
    tau_ca2: float,
    i_alpha: float,
    i_ca2: float = 0.0,
) -> np.ndarray:
    """Spike times of ``IF_curr_exp_ca2_adaptive`` under constant current.

    Between spikes (after the refractory period, from ``v_reset`` and calcium
    current ``c``) the exact membrane is
    ``u(s) = (v0 - v_rest) e^{-s/tau_m} + R I (1 - e^{-s/tau_m}) - c K(s)`` where
    ``K`` is :func:`current_psp` with unit weight and ``tau_syn = tau_ca2``; it is
    tested against ``v_thresh`` at every step end. ``I_ca2`` decays with
    ``tau_ca2`` throughout and jumps by ``i_alpha`` at each spike.
    """

    def membrane(s: np.ndarray, v0: float, ca: float) -> tuple[np.ndarray, float]:
        u = (v0 - v_rest) * np.exp(-s / tau_m) + tau_m / cm * i_offset * (1 - np.exp(-s / tau_m))
        u -= ca * current_psp(s, weight=1.0, tau_m=tau_m, tau_syn=tau_ca2, cm=cm)
        return v_rest + u, v_thresh

    return _spikes_with_decaying_state(
        membrane, dt=dt, t_stop=t_stop, tau_refrac=tau_refrac, v_start=v_rest, v_reset=v_reset,
        state=i_ca2, decay=lambda n: math.exp(-n * dt / tau_ca2), jump=i_alpha,
    )  # fmt: skip


def theta_grid_spike_times(
    *,
    dt: float,
    t_stop: float,
    tau_m: float,
    cm: float,
    v_rest: float,
    v_reset: float,
    v_thresh: float,
    tau_refrac: float,
    i_offset: float,
    theta_plus: float,
    tau_theta: float,
    theta_init: float = 0.0,
) -> np.ndarray:
    """Spike times of ``IF_cond_exp_adaptive`` under constant current and no synaptic input.

    Without conductances the neuron is a LIF, ``v(s) = v_inf - (v_inf - v0) e^{-s/tau_m}``;
    it spikes at the first step end where ``v >= v_thresh + theta``, with ``theta``
    decaying with ``tau_theta`` and growing by ``theta_plus`` at each spike.
    """
    v_inf = v_rest + tau_m / cm * i_offset

    def membrane(s: np.ndarray, v0: float, theta: float) -> tuple[np.ndarray, np.ndarray]:
        return v_inf - (v_inf - v0) * np.exp(-s / tau_m), v_thresh + theta * np.exp(-s / tau_theta)

    return _spikes_with_decaying_state(
        membrane, dt=dt, t_stop=t_stop, tau_refrac=tau_refrac, v_start=v_rest, v_reset=v_reset,
        state=theta_init, decay=lambda n: math.exp(-n * dt / tau_theta), jump=theta_plus,
    )  # fmt: skip


def euler_grid_spike_times(
    *,
    dt: float,
    t_stop: float,
    tau_m: float,
    cm: float,
    v_rest: float,
    v_reset: float,
    v_thresh: float,
    tau_refrac: float,
    i_offset: float,
    theta_plus: float = 0.0,
    tau_theta: float = math.inf,
    theta_init: float = 0.0,
) -> np.ndarray:
    """Spike times of a conductance-based cell with ``integration="euler"`` under constant current, no synaptic input.

    The forward-Euler step ``v += dt / tau_m (v_rest - v) + dt / cm i_offset`` has the
    closed form ``v_k = v_inf - (v_inf - v0) a^k`` with ``a = 1 - dt / tau_m`` and the
    same ``v_inf = v_rest + tau_m / cm i_offset`` as the exact solution; ``theta`` falls
    by ``b = 1 - dt / tau_theta`` per step (``b = 1`` without ``tau_theta``) and grows by
    ``theta_plus`` at each spike. A spike is the first step end where ``v_k >= v_thresh
    + theta_k``; then ``v`` is held at ``v_reset`` for ``round(tau_refrac / dt)`` steps.
    """
    v_inf = v_rest + tau_m / cm * i_offset
    a = 1.0 - dt / tau_m
    b = 1.0 if math.isinf(tau_theta) else 1.0 - dt / tau_theta

    def membrane(s: np.ndarray, v0: float, theta: float) -> tuple[np.ndarray, np.ndarray]:
        k = np.rint(s / dt)  # steps since the membrane was free
        return v_inf - (v_inf - v0) * a**k, v_thresh + theta * b**k

    return _spikes_with_decaying_state(
        membrane, dt=dt, t_stop=t_stop, tau_refrac=tau_refrac, v_start=v_rest, v_reset=v_reset,
        state=theta_init, decay=lambda n: b**n, jump=theta_plus,
    )  # fmt: skip


def euler_conductance_psp(
    n: int, *, dt: float, weight: float, tau_m: float, tau_syn: float, cm: float, v_rest: float, e_rev: float
) -> tuple[np.ndarray, np.ndarray]:
    """Membrane and conductance at the ``n`` step ends after a conductance jump ``weight``, forward Euler.

    ``v_{k+1} = v_k + dt / cm (cm / tau_m (v_rest - v_k) + g_k (e_rev - v_k))``,
    ``g_{k+1} = g_k (1 - dt / tau_syn)``, from ``v_0 = v_rest`` and ``g_0 = weight`` at the
    arrival: the difference equations of the step themselves (they have no simpler form).
    """
    v, g = v_rest, weight
    vs, gs = np.empty(n), np.empty(n)
    for k in range(n):
        v, g = v + dt / cm * (cm / tau_m * (v_rest - v) + g * (e_rev - v)), g * (1.0 - dt / tau_syn)
        vs[k], gs[k] = v, g
    return vs, gs


def pair_stdp_weight(
    *, w0: float, dt_pair: float, tau_plus: float, tau_minus: float, A_plus: float, A_minus: float,
    w_min: float, w_max: float, multiplicative: bool,
) -> float:
    """Weight after one pre/post pair under ``STDPMechanism(SpikePairRule, ...)``.

    ``dt_pair = t_post - (t_pre + delay)``. For ``dt_pair > 0``:
    ``w0 + A_plus F+(w0) exp(-dt_pair / tau_plus)``; otherwise
    ``w0 - A_minus F-(w0) exp(dt_pair / tau_minus)``; additive ``F+ = F- = w_max``,
    multiplicative ``F+ = w_max - w0``, ``F- = w0 - w_min``; clipped to ``[w_min, w_max]``.
    """
    if dt_pair > 0:
        f = (w_max - w0) if multiplicative else w_max
        w = w0 + A_plus * f * math.exp(-dt_pair / tau_plus)
    else:
        f = (w0 - w_min) if multiplicative else w_max
        w = w0 - A_minus * f * math.exp(dt_pair / tau_minus)
    return min(max(w, w_min), w_max)


def diehl_cook_pair_weight(
    *, w0: float, dt_pair: float, eta_pre: float, eta_post: float, x_tar: float, w_max: float, mu: float,
    tau_pre: float, tau_post: float,
) -> float:
    """Weight after one pre/post pair under ``DiehlCookSTDP`` (pair form, ``tau_post2=None``).

    Pre arrives first (``dt_pair > 0``): nothing at the arrival (``x_post = 0``), then at
    the post spike ``w0 + eta_post (exp(-dt_pair / tau_pre) - x_tar) (w_max - w0)^mu``.
    Post first (``dt_pair <= 0``): at the post spike ``w1 = w0 - eta_post x_tar (w_max - w0)^mu``
    (``x_pre = 0``), then at the arrival ``w1 - eta_pre exp(dt_pair / tau_post)``.
    Weights are clipped to ``[0, w_max]`` after each update.
    """
    def clip(w: float) -> float:
        return min(max(w, 0.0), w_max)

    if dt_pair > 0:
        return clip(w0 + eta_post * (math.exp(-dt_pair / tau_pre) - x_tar) * (w_max - w0) ** mu)
    w1 = clip(w0 + eta_post * (0.0 - x_tar) * (w_max - w0) ** mu)
    return clip(w1 - eta_pre * math.exp(dt_pair / tau_post))
