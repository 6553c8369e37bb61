"""How neurovpr's IR and NIR correspond: one table, its units and its formulas.

Units and conventions
---------------------
* Time: NIR time constants and delays are in seconds, neurovpr's in ms (x 1000).
* Voltage: 1 NIR voltage unit = 1 mV. Current: 1 NIR current unit = 1 nA at the IR
  synapse; NIR ``r`` is then in MOhm (mV per nA), and ``w_in`` absorbs the gauge.
* Spikes: NIR does not say how much charge one spike carries. Here a spike arriving
  through an edge of weight ``W`` is an impulse of area ``W * h``, where ``h`` (the
  ``dt`` argument, default 0.1 ms = 1e-4 s) is the time step of the framework that
  trained the graph: a spike is "1 for one step", as snnTorch feeds it.
* Weights: the NIR weight array *is* the IR weight (nA), bit for bit, in both
  directions; every unit conversion goes into the neuron's ``cm``, ``r`` and ``w_in``.
* ``integration="exact"`` (default) reads NIR's equations as the continuous-time
  ODE they are; neurovpr integrates it exactly. ``integration="euler"`` reads the
  parameters as the forward-Euler coefficients of a simulation at step ``h``
  (snnTorch: ``beta = 1 - h / tau``), so that neurovpr at ``dt = h`` reproduces
  that simulation's per-step map exactly.
* Threshold: NIR (and snnTorch) spike when ``v > v_threshold``, neurovpr when
  ``v >= v_thresh``: they differ only when ``v`` lands exactly on the threshold.
* Initial state: NIR defines none; neurovpr takes ``v = 0`` and ``I = 0`` (where
  snnTorch starts), so an imported population with ``v_leak != 0`` gets ``v_init = 0``,
  and export notes a population whose initial ``v`` is not 0.
* Latency: NIR edges are instantaneous; an IR projection delivers a spike one step
  ``dt`` after it (the IR's minimum delay), and spikes are stamped at the end of the
  step, so in a feed-forward graph layer ``L`` spikes ``2 L`` steps after a
  zero-latency peer (the same spikes, shifted). Around a recurrent loop the extra
  step changes the dynamics; import says so. A NIR ``Delay`` of ``d >= dt`` is the
  IR delay ``d``.

The table (``h`` = NIR step in ms, ``T`` = 1000 tau, ``delta`` = 1e-6 ms)
-------------------------------------------------------------------------
=====================  ====================================================  ===========================
NIR                    neurovpr IR                                           exact?
=====================  ====================================================  ===========================
Input(shape)           SpikeSourceArray population of prod(shape), C order   yes (spike times, Poisson
                       (export: any source; its data go to metadata only)    rates: metadata only)
Output                 the population feeding it (returned by import)        yes
CubaLIF                IF_curr_exp: tau_syn_E = tau_syn_I = T_syn,           yes
                       tau_m = T_mem, v_rest = v_leak, v_thresh, v_reset,
                       tau_refrac = 0, cm = T_mem T_syn / (r w_in h);
                       export: r = tau_mem / h, w_in = T_syn / cm,
                       v_leak = v_rest + (tau_m / cm) i_offset
LIF                    IF_curr_exp with a delta synapse: tau_syn = delta,    yes at step ends, for any
                       cm = T / (r h (1/delta - 1/T))                        dt >= 1e-3 ms
IF                     as LIF with tau_m = 1e30 ms (no leak),                yes
                       cm = 1 / (r h_s (1/delta - 1/tau_m))
CubaLI, LI, I          as CubaLIF, LIF, IF with v_thresh = +inf              yes (read v with record)
Affine, Linear         AllToAllConnector with weight W.T (all entries        yes, weights bit-identical
                       non-zero) or FromListConnector of the non-zeros;
                       inhibitory projections export as -weight
Affine/Conv2d bias     i_offset of the target population:                    LIF, IF: yes; CubaLIF: the
                       CubaLIF T_syn b / h, LIF r b cm / T, IF r b cm / 1000  IR skips the synaptic rise
                                                                             (error ~ b e^(-t/tau_syn))
Conv2d                 ConvolutionConnector (groups 1, dilation 1,           yes, kernel bit-identical
                       symmetric padding); others FromListConnector
SumPool2d, AvgPool2d   ConvolutionConnector with a ones (1/(kh kw)) kernel   yes (AvgPool divides by
                       for one channel, FromListConnector for several        kh kw, padding included)
Scale                  OneToOneConnector with per-neuron weights             yes
Flatten                nothing: populations are flat in C order              yes
Delay                  synaptic delays (per pre- or per post-neuron)         yes (zero -> one step)
several linear nodes   composed into one FromListConnector                   to float64 rounding
nested NIRGraph        flattened into the parent graph                       yes
loop through neurons   recurrent projection                                  no: +1 step per projection
=====================  ====================================================  ===========================

``integration="euler"`` replaces ``T`` by ``-h / ln(1 - h / tau)`` and the gains by
the Euler ones (``r h / tau``, ``w_in h / tau_syn``); see :func:`cell_from_node`.

What NIR cannot express
-----------------------
Export refuses, naming the population or projection and the feature:
``IF_cond_exp`` and ``IF_cond_exp_adaptive`` (conductance synapses, adaptive
threshold), ``IF_curr_exp_ca2_adaptive`` (Ca2+ adaptation), ``SoftLIF`` (rate
model), plastic synapses (``STDPMechanism``, ``DiehlCookSTDP``), an inhibitory
projection onto a population whose ``tau_syn_I`` differs from ``tau_syn_E``
(CubaLIF has one synaptic time constant), ``tau_refrac > 0`` (unless
``allow_refractory``), delays that vary with both the pre- and the postsynaptic
neuron, a dense projection onto a convolutional ``(C, H, W)`` map (NIR has no
reshape), a leak-free neuron with ``i_offset`` (NIR's IF has no bias).

Import refuses, naming the node: node types with no IR equivalent (``Threshold``,
``Conv1d``, ...), an ``Output`` fed through weights rather than by a neuron node, a
cycle of linear nodes with no neuron in it, a ``Delay`` between two weight nodes,
and, with ``integration="euler"``, a time constant not longer than the step.

Carried in the graph's metadata, and restored exactly by neurovpr only when the
graph still matches it bit for bit: the whole IR network (``nv.save`` format),
hence source types with their spike times or Poisson rates, receptor types,
connector types (random ones are expanded with the export seed), ``v_init``, an
unused ``tau_syn_I``, names and, with ``allow_refractory``, refractory periods
(peers simulate without them).
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np

from neurovpr.backendkit.params import per_neuron
from neurovpr.errors import ValidationError
from neurovpr.ir.cells import NO_LEAK, IF_curr_exp

__all__ = [
    "DEFAULT_DT_MS",
    "INTEGRATIONS",
    "TAU_DELTA_MS",
    "TAU_NO_LEAK_MS",
    "Integration",
    "NEURON_NODES",
    "check_options",
    "psc_gain",
    "cell_from_node",
    "node_fields_from_cell",
]

Integration = Literal["exact", "euler"]
#: The two readings of a NIR graph's time constants.
INTEGRATIONS: tuple[str, ...] = ("exact", "euler")
#: Default NIR step ``h`` (ms): snnTorch writes its graphs for 1e-4 s.
DEFAULT_DT_MS = 0.1
#: Synaptic time constant (ms) that stands for NIR's instantaneous (delta) synapse:
#: ``exp(-dt / TAU_DELTA_MS)`` is exactly 0.0 in float64 for every ``dt >= 1e-3`` ms.
TAU_DELTA_MS = 1e-6
#: Membrane time constant (ms) that stands for "no leak" (:data:`neurovpr.NO_LEAK`):
#: ``exp(-dt / TAU_NO_LEAK_MS)`` rounds to exactly 1.0 for every ``dt <= 1e10`` ms.
TAU_NO_LEAK_MS = NO_LEAK
#: NIR neuron node types: (has a synaptic current, has a leak, spikes).
NEURON_NODES: dict[str, tuple[bool, bool, bool]] = {
    "CubaLIF": (True, True, True),
    "CubaLI": (True, True, False),
    "LIF": (False, True, True),
    "LI": (False, True, False),
    "IF": (False, False, True),
    "I": (False, False, False),
}


def check_options(dt: float, integration: str) -> tuple[float, str]:
    """Validate the NIR step ``dt`` (ms) and the integration reading."""
    if isinstance(dt, bool) or not isinstance(dt, (int, float, np.integer, np.floating)) or not (
        math.isfinite(dt) and dt > 0
    ):
        raise ValidationError(f"NIR step dt must be a finite number of ms > 0, got {dt!r}.")
    if integration not in INTEGRATIONS:
        raise ValidationError(f"NIR integration must be 'exact' or 'euler', got {integration!r}.")
    return float(dt), str(integration)


def psc_gain(dt: float, tau_s: np.ndarray, tau_m: np.ndarray) -> np.ndarray:
    """Membrane change (mV x nF) after one step ``dt`` caused by a 1 nA exponential current.

    Divided by ``cm`` this is the exact propagator every current-based backend uses
    (NEST's and the reference backend's ``P21``), written here for unit conversion.
    """
    tau_s = np.asarray(tau_s, dtype=np.float64)
    tau_m = np.asarray(tau_m, dtype=np.float64)
    a = 1.0 / tau_m - 1.0 / tau_s
    out = np.empty(np.broadcast(tau_s, tau_m).shape)
    a = np.broadcast_to(a, out.shape)
    tm = np.broadcast_to(tau_m, out.shape)
    small = np.abs(a * dt) < 1e-8
    out[small] = dt * np.exp(-dt / tm[small])
    big = ~small
    out[big] = np.exp(-dt / tm[big]) * np.expm1(dt * a[big]) / a[big]
    return out


def _field(node: Any, name: str, n: int, where: str, default: float | None = None) -> np.ndarray:
    """One NIR parameter as ``n`` float64 values (broadcast from a scalar or flattened)."""
    value = getattr(node, name, None)
    if value is None:
        if default is None:
            raise ValidationError(f"{where} lacks the parameter {name!r}.")
        value = default
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValidationError(f"{where}: parameter {name!r} is not numeric.") from None
    if arr.size == n:
        arr = arr.reshape(n)
    elif arr.size == 1:
        arr = np.full(n, float(arr.reshape(-1)[0]))
    else:
        raise ValidationError(f"{where}: parameter {name!r} has {arr.size} values for {n} neurons.")
    if np.any(np.isnan(arr)):
        raise ValidationError(f"{where}: parameter {name!r} contains NaN.")
    return arr


def _positive(where: str, name: str, arr: np.ndarray) -> None:
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        bad = arr[~(np.isfinite(arr) & (arr > 0))][0]
        raise ValidationError(f"{where}: {name} must be finite and > 0, got {bad!r}.")


def _compact(arr: np.ndarray) -> float | np.ndarray:
    """One number when all values are equal, else the array."""
    return float(arr[0]) if arr.size and np.all(arr == arr[0]) else arr


def _euler_tau(where: str, name: str, tau_s: np.ndarray, h_s: float) -> tuple[np.ndarray, np.ndarray]:
    """``(decay per step, equivalent exact tau in ms)`` of a forward-Euler time constant."""
    decay = 1.0 - h_s / tau_s
    if np.any(decay <= 0.0):
        bad = tau_s[decay <= 0.0][0]
        raise ValidationError(
            f"{where}: {name} = {bad!r} s is not longer than the Euler step {h_s!r} s, "
            "so no decaying neuron reproduces it."
        )
    tau_ms = np.where(decay < 1.0, -1000.0 * h_s / np.log(np.minimum(decay, 1.0 - 1e-300)), TAU_NO_LEAK_MS)
    return decay, tau_ms


def cell_from_node(
    node: Any, kind: str, n: int, *, dt: float, integration: str, where: str
) -> tuple[IF_curr_exp, np.ndarray, bool]:
    """The IR cell for a NIR neuron node of ``n`` neurons.

    Returns
    -------
    cell
        An ``IF_curr_exp`` with ``i_offset = 0``.
    bias_gain
        ``i_offset = bias_gain * b`` turns a NIR bias ``b`` reaching this node into nA.
    bias_exact
        False for nodes with a synaptic current (the bias rises with ``tau_syn`` in NIR).
    """
    synaptic, leaky, spiking = NEURON_NODES[kind]
    h_s = dt / 1000.0
    r = _field(node, "r", n, where)
    _positive(where, "r", r)
    v_leak = _field(node, "v_leak", n, where, 0.0) if leaky else np.zeros(n)
    if spiking:
        v_thresh = _field(node, "v_threshold", n, where)
        v_reset = _field(node, "v_reset", n, where, 0.0)
    else:
        v_thresh, v_reset = np.full(n, math.inf), v_leak.copy()
    if synaptic:
        tau_syn, tau_mem = _field(node, "tau_syn", n, where), _field(node, "tau_mem", n, where)
        w_in = _field(node, "w_in", n, where, 1.0)
        _positive(where, "tau_syn", tau_syn)
        _positive(where, "tau_mem", tau_mem)
        _positive(where, "w_in", w_in)
        if integration == "exact":
            t_syn, t_mem = 1000.0 * tau_syn, 1000.0 * tau_mem
            cm = t_mem * t_syn / (r * w_in * dt)
            gain = t_syn / dt
        else:
            alpha, t_syn = _euler_tau(where, "tau_syn", tau_syn, h_s)
            beta, t_mem = _euler_tau(where, "tau_mem", tau_mem, h_s)
            c_in, c_m = w_in * h_s / tau_syn, r * h_s / tau_mem
            cm = psc_gain(dt, t_syn, t_mem) / (c_in * c_m)
            gain = cm * c_m * c_in / (t_mem * (1.0 - alpha) * np.where(beta < 1.0, 1.0 - beta, h_s / tau_mem))
    else:
        t_syn = np.full(n, TAU_DELTA_MS)
        if leaky:
            tau = _field(node, "tau", n, where)
            _positive(where, "tau", tau)
            if integration == "exact":
                t_mem = 1000.0 * tau
                cm = t_mem / (r * dt * (1.0 / TAU_DELTA_MS - 1.0 / t_mem))
                gain = r * cm / t_mem
            else:
                beta, t_mem = _euler_tau(where, "tau", tau, h_s)
                c = r * h_s / tau
                cm = np.exp(-dt / t_mem) / (c * (1.0 / TAU_DELTA_MS - 1.0 / t_mem))
                gain = c * cm / (t_mem * -np.expm1(-dt / t_mem))
        else:
            t_mem = np.full(n, TAU_NO_LEAK_MS)
            cm = 1.0 / (r * h_s * (1.0 / TAU_DELTA_MS - 1.0 / t_mem))
            gain = r * cm / 1000.0
    if not np.all(np.isfinite(cm)) or np.any(cm <= 0):
        raise ValidationError(f"{where}: its parameters give no positive, finite membrane capacitance.")
    try:
        cell = IF_curr_exp(
            cm=_compact(cm),
            tau_m=_compact(t_mem),
            tau_refrac=0.0,
            tau_syn_E=_compact(t_syn),
            tau_syn_I=_compact(t_syn),
            v_rest=_compact(v_leak),
            v_reset=_compact(v_reset),
            v_thresh=_compact(v_thresh),
            i_offset=0.0,
        )
    except ValidationError as exc:
        raise ValidationError(f"{where} maps to an invalid neuron: {exc}") from None
    return cell, np.asarray(gain, dtype=np.float64) * np.ones(n), not synaptic


def _cell_arrays(cell: IF_curr_exp, n: int) -> dict[str, np.ndarray]:
    names = ("cm", "tau_m", "tau_syn_E", "tau_syn_I", "v_rest", "v_reset", "v_thresh", "i_offset", "tau_refrac")
    return {k: per_neuron(getattr(cell, k), n) for k in names}


def node_fields_from_cell(
    cell: IF_curr_exp, n: int, *, receptors: set[str], dt: float, integration: str, where: str
) -> tuple[str, dict[str, np.ndarray]]:
    """The NIR node type and its parameters (flat arrays of ``n``) for an ``IF_curr_exp``.

    ``receptors`` are the receptor types of the projections onto the population.
    """
    p = _cell_arrays(cell, n)
    if receptors == {"inhibitory"}:
        t_syn = p["tau_syn_I"]
    else:
        t_syn = p["tau_syn_E"]
        if "inhibitory" in receptors and not np.array_equal(p["tau_syn_I"], p["tau_syn_E"]):
            raise ValidationError(
                f"{where} receives inhibitory input with tau_syn_I != tau_syn_E, and NIR's CubaLIF has one "
                "synaptic time constant (make them equal)."
            )
    delta = t_syn <= TAU_DELTA_MS
    no_leak = p["tau_m"] >= TAU_NO_LEAK_MS
    silent = np.isposinf(p["v_thresh"])
    for flags, what in ((delta, "delta and exponential synapses"), (no_leak, "leaky and leak-free neurons"),
                        (silent, "spiking and non-spiking neurons")):  # fmt: skip
        if flags.any() and not flags.all():
            raise ValidationError(f"{where} mixes {what}; NIR gives one neuron type per node.")
    delta, no_leak, silent = bool(delta[0]), bool(no_leak[0]), bool(silent[0])
    cm, t_mem, h_s = p["cm"], p["tau_m"], dt / 1000.0
    v_leak = p["v_rest"] + (t_mem / cm) * p["i_offset"] if not no_leak else p["v_rest"]
    out: dict[str, np.ndarray] = {}
    if delta and no_leak:
        if np.any(p["i_offset"] != 0):
            raise ValidationError(f"{where} is leak-free with i_offset != 0, and NIR's IF has no bias input.")
        kind = "I" if silent else "IF"
        out["r"] = 1.0 / (cm * h_s * (1.0 / t_syn - 1.0 / t_mem))
    elif delta:
        kind = "LI" if silent else "LIF"
        if integration == "exact":
            out["tau"] = t_mem / 1000.0
            out["r"] = t_mem / (cm * dt * (1.0 / t_syn - 1.0 / t_mem))
        else:
            decay = np.exp(-dt / t_mem)
            out["tau"] = h_s / (1.0 - decay)
            out["r"] = decay / (cm * (1.0 / t_syn - 1.0 / t_mem)) * out["tau"] / h_s
        out["v_leak"] = v_leak
    else:
        kind = "CubaLI" if silent else "CubaLIF"
        if integration == "exact":
            out["tau_syn"], out["tau_mem"] = t_syn / 1000.0, t_mem / 1000.0
            out["r"] = out["tau_mem"] / h_s
            out["w_in"] = t_syn / cm
        else:
            out["tau_syn"] = h_s / -np.expm1(-dt / t_syn)
            one_minus_beta = -np.expm1(-dt / t_mem)
            out["tau_mem"] = np.where(one_minus_beta > 0, h_s / np.where(one_minus_beta > 0, one_minus_beta, 1.0),
                                      TAU_NO_LEAK_MS / 1000.0)  # fmt: skip
            out["r"] = out["tau_mem"] / h_s
            out["w_in"] = psc_gain(dt, t_syn, t_mem) / cm * out["tau_syn"] / h_s
        out["v_leak"] = v_leak
    if not silent:
        out["v_threshold"] = p["v_thresh"]
        out["v_reset"] = p["v_reset"]
    return kind, out
