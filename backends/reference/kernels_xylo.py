"""Xylo Audio 2's integer neuron, step by step (the loop :mod:`.xylo` runs).

The update follows XyloSim 0.1.3's C++ bit-accurate model (``src/v2/cpp/XyloIAFNeuron.cpp``
and ``XyloLayer.cpp``); per step, in this order:

1. the spikes arriving now are added to their synaptic current (16-bit, saturating:
   XyloSim's ``safe_add``);
2. each synaptic current decays by a bit shift, ``i -= decay(i, dash_syn)``, with
   ``decay(x, d) = x >> d``, or ``sign(x)`` when that is zero;
3. ``dv = safe_add(-decay(v, dash_mem), i_syn1 + i_syn2)``, then the bias, then
   ``v = safe_add(v, dv)``;
4. while ``v >= threshold`` and fewer than ``max_spikes`` (31 hidden, 1 output) spikes were
   emitted this step: one more spike and ``v -= threshold`` (reset by subtraction).

A neuron's spikes of step ``j`` (recorded at the end of the step, ``(j + 1) dt``) reach their
targets in step ``j + 1``, as XyloSim delivers the hidden neurons' spikes of one step at the
start of the next; a source spike at ``j dt`` reaches them in step ``j``, as XyloSim's input
raster row ``j`` does. One step's spikes onto a synapse are added as one sum (XyloSim adds
them one by one: the result differs only when the current saturates within the step).
"""

from __future__ import annotations

from collections.abc import Callable

from numba import njit

from .kernel_cache import source_stamp
from .kernel_layout import ST_NEURON_UPDATES, ST_STEPS
from .kernels_fixed import CACHE_UNIT as FIXED_UNIT
from .kernels_fixed import _emit, _sources

__all__ = ["X_ACTIVE", "X_DASH_MEM", "X_DASH_SYN1", "X_DASH_SYN2", "X_VTH", "X_BIAS", "X_MAX_SPIKES", "N_XYLO_COLS",
           "CACHE_UNIT", "run_xylo", "safe_add", "bitshift_decay"]

(X_ACTIVE, X_DASH_MEM, X_DASH_SYN1, X_DASH_SYN2, X_VTH, X_BIAS, X_MAX_SPIKES, N_XYLO_COLS) = range(8)

#: The files the Xylo loop's code comes from (its cache key, see :mod:`.kernel_cache`).
CACHE_UNIT = ("kernels_xylo", *FIXED_UNIT)


@njit
def safe_add(x: int, y: int, bits: int) -> int:
    """XyloSim's ``safe_add``: ``x + y``, or the bound on ``y``'s side when ``|bound - x| <= |y|``."""
    bound = (1 << (bits - 1)) - 1 if y >= 0 else -(1 << (bits - 1))
    if abs(bound - x) > abs(y):
        return x + y
    return bound


@njit
def bitshift_decay(x: int, dash: int) -> int:
    """XyloSim's ``decay``: ``x >> dash`` (floor), at least one step of ``x``'s sign."""
    d = x >> dash
    if d == 0:
        if x > 0:
            return 1
        if x < 0:
            return -1
    return d


def _xylo_loop(stamp: int) -> Callable[..., int]:
    """The Xylo step loop, cached under ``stamp`` (:func:`.kernel_cache.source_stamp` of ``CACHE_UNIT``)."""

    @njit(cache=True)
    def run_xylo(j0, j1, bits, params, v, isyn, counts, syn, acc, sources, record, headroom, var, stats):
        """Advance Xylo neurons from step ``j0`` to ``j1``; return the step reached.

        ``isyn`` is ``(N, 2)`` (synapse 1 and 2 of each neuron); the delay ring ``acc`` has one
        column per (neuron, synapse), ``2 * i + s``. ``syn``, ``sources``, ``record`` and
        ``var`` are a :class:`.kernels_fixed.FixedSynapses`, ``Sources``, ``SpikeRecord`` and
        ``VarRecord``; the recorded variable is ``v``.
        """
        stamp  # noqa: B018 - in numba's cache key (see .kernel_cache)
        rec_n, var_idx, var_out = record.n, var.idx, var.out
        n = v.size
        ring = acc.shape[0]
        cap = record.t.size
        for j in range(j0, j1):
            if rec_n[0] + headroom > cap:
                return j
            # a source spike of step j (stamp j) and a neuron spike of step j - 1 (stamp j) both sit at j + 1
            slot = (j + 1) % ring
            _sources(j, sources, counts, stats, record, syn, acc, 0)
            for i in range(n):
                for s in range(2):
                    x = acc[slot, 2 * i + s]
                    if x != 0:
                        isyn[i, s] = safe_add(isyn[i, s], x, bits)
                        acc[slot, 2 * i + s] = 0
            for i in range(n):
                p = params[i]
                if p[X_ACTIVE] == 0:
                    continue
                stats[ST_NEURON_UPDATES] += 1
                total = 0
                for s in range(2):
                    isyn[i, s] -= bitshift_decay(isyn[i, s], p[X_DASH_SYN1 + s])
                    total += isyn[i, s]
                dv = safe_add(-bitshift_decay(v[i], p[X_DASH_MEM]), total, bits)
                # XyloSim stores the sum in a 16-bit integer
                dv = ((dv + (1 << (bits - 1))) % (1 << bits)) - (1 << (bits - 1))
                if p[X_BIAS] != 0:
                    dv = safe_add(dv, p[X_BIAS], bits)
                vi = safe_add(v[i], dv, bits)
                spikes = 0
                while vi >= p[X_VTH] and spikes < p[X_MAX_SPIKES]:
                    spikes += 1
                    vi -= p[X_VTH]
                v[i] = vi
                for _ in range(spikes):
                    _emit(i, j + 1, counts, stats, record, syn, acc, 0)
            for r in range(var_idx.size):
                var_out[j - j0, r] = v[var_idx[r]]
            stats[ST_STEPS] += 1
        return j1

    return run_xylo


run_xylo = _xylo_loop(source_stamp(__file__, CACHE_UNIT))
