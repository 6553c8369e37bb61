"""Speck's integer IAF layers, step by step (the loop :mod:`.speck` runs).

The update is that of Sinabs's ``IAFSqueeze`` with its defaults (``MultiSpike``, reset by
``MembraneSubtract``), as Sinabs simulates the discretised layers of ``DynapcnnNetwork``;
per step ``j``:

1. the spike sources of step ``j`` emit (their synapses' integers go to the slot of step ``j``);
2. neurons are updated layer after layer, in the order spikes take (``order``): ``v += input
   + bias``; when ``v >= threshold`` the neuron emits ``n = v // threshold`` spikes and ``v -=
   n threshold``; then ``v = max(v, min_v_mem)``. Its ``n`` spikes are stamped ``j + 1`` and add
   ``n`` times their integers to the inputs of step ``j``, which later layers read in the same
   step (Speck has no synaptic delays; Sinabs evaluates a time bin layer after layer).

All integers, no saturation (Sinabs's float32 state holds these integers exactly below 2**24).
"""

from __future__ import annotations

from collections.abc import Callable

from numba import njit

from .kernel_cache import source_stamp
from .kernel_layout import ST_NEURON_UPDATES, ST_SPIKES, ST_STEPS, ST_SYN_EVENTS
from .kernels_fixed import CACHE_UNIT as FIXED_UNIT
from .kernels_fixed import _sources

__all__ = ["SP_VTH", "SP_VMIN", "SP_BIAS", "N_SPECK_COLS", "CACHE_UNIT", "run_speck"]

(SP_VTH, SP_VMIN, SP_BIAS, N_SPECK_COLS) = range(4)

#: The files the Speck loop's code comes from (its cache key, see :mod:`.kernel_cache`).
CACHE_UNIT = ("kernels_speck", *FIXED_UNIT)


def _speck_loop(stamp: int) -> Callable[..., tuple[int, int, int, int]]:
    """The Speck step loop, cached under ``stamp`` (:func:`.kernel_cache.source_stamp` of ``CACHE_UNIT``)."""

    @njit(cache=True)
    def run_speck(j0, pos0, j1, params, order, v, counts, syn, acc, sources, record, headroom, var, stats):
        """Advance from position ``pos0`` of ``order`` in step ``j0`` to step ``j1``.

        Returns ``(step, position, neuron, spikes)``: where it stopped, and, when it stopped
        because the spike record is full, the neuron whose ``spikes`` spikes (stamped
        ``step + 1``) are still to be recorded (``-1`` otherwise). ``syn``, ``sources``,
        ``record`` and ``var`` are a :class:`.kernels_fixed.FixedSynapses`, ``Sources``,
        ``SpikeRecord`` and ``VarRecord`` (rows from step ``j0``); the ring ``acc`` has one
        column per neuron; ``params`` the ``SP_*`` columns.
        """
        stamp  # noqa: B018 - in numba's cache key (see .kernel_cache)
        s_ptr, s_gp, s_val, _ = syn
        rec_n, var_idx, var_out = record.n, var.idx, var.out
        ring = acc.shape[0]
        cap = record.t.size
        j, pos = j0, pos0
        while j < j1:
            slot = (j + 1) % ring  # a source spike stamped j with its one-step delay sits here
            if pos == 0:
                if rec_n[0] + headroom > cap:
                    return j, 0, -1, 0
                _sources(j, sources, counts, stats, record, syn, acc, 0)
            while pos < order.size:
                i = order[pos]
                pos += 1
                p = params[i]
                stats[ST_NEURON_UPDATES] += 1
                vi = v[i] + acc[slot, i] + p[SP_BIAS]
                acc[slot, i] = 0
                n = 0
                if vi >= p[SP_VTH]:
                    n = vi // p[SP_VTH]
                    vi -= n * p[SP_VTH]
                if vi < p[SP_VMIN]:
                    vi = p[SP_VMIN]
                v[i] = vi
                if n == 0:
                    continue
                counts[i] += n
                stats[ST_SPIKES] += n
                for k in range(s_ptr[i], s_ptr[i + 1]):
                    acc[slot, s_gp[k]] += n * s_val[k]
                stats[ST_SYN_EVENTS] += n * (s_ptr[i + 1] - s_ptr[i])
                if record.mask[i]:
                    if rec_n[0] + n > cap:
                        return j, pos, i, n
                    for _ in range(n):
                        record.t[rec_n[0]] = j + 1
                        record.i[rec_n[0]] = i
                        rec_n[0] += 1
            for r in range(var_idx.size):
                var_out[j - j0, r] = v[var_idx[r]]
            stats[ST_STEPS] += 1
            j += 1
            pos = 0
        return j1, 0, -1, 0

    return run_speck


run_speck = _speck_loop(source_stamp(__file__, CACHE_UNIT))
