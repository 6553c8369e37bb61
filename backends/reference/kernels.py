"""The compiled step loop of the reference backend.

One ``numba.njit`` function advances the whole network over a range of steps with
no Python in the loop. The order within step ``j`` follows docs/semantics.md:

1. sources emit their spikes stamped ``j`` (scheduled into the delay ring);
2. arrivals for step ``j``: plastic synapses' events (depression, pre traces) and
   the static ring slot, added to synaptic currents/conductances;
3. each neuron: exact propagation of the membrane over the step with the
   synaptic state at its start, decay of the synaptic state, threshold, reset,
   refractoriness (one step counter per neuron: the membrane is held while more
   than the lockout's extra steps remain, and a spike needs the counter at 0),
   adaptation, and on a spike the potentiation of its incoming plastic synapses
   and the scheduling of its outgoing spikes (stamped ``j + 1``);
4. recording of state variables at the end of the step.

Neurons are updated in *groups* of identical parameters (scalars, so the loops
compile to vector instructions), leaving out terms that are exactly ``+0.0`` for a
group (subtracting them is the identity: results are the same bit for bit). A group's
spikes are then handled in increasing neuron index, as a neuron-by-neuron loop would
(a spike only changes its own neuron and steps after ``j + 1``). Static arrivals are
summed per (receptor, ring slot, neuron): a spike adds each of its static segments (one
delay and receptor, see :func:`.delivery.static_delivery`) into one buffer row and
marks the blocks of neurons the segment reaches, so that delivery visits marked blocks
only. Convolutions are delivered from their kernel (:mod:`.convolution`): a spike's
targets and weights are computed from its position, and the buffer row records the range
of neurons reached. Within a buffer entry the contributions keep the order of a
synapse-by-synapse loop, so the sums are the same bit for bit. Pair STDP is
all-to-all with traces that jump by 1 (set to 1 for Diehl & Cook); all synapses of a
segment (one presynaptic neuron, projection and delay) see the same arrivals, so
their presynaptic trace is held once per segment (``seg_xpre``, decayed lazily from
its last arrival ``seg_last``); postsynaptic traces decay every step.

What the loop calls lives in modules named for what they hold: :mod:`.kernel_layout`
(codes, table columns, the bundles of arrays), :mod:`.kernel_sources` (random draws),
:mod:`.kernel_neurons`, :mod:`.kernel_plasticity` and :mod:`.kernel_delivery`. numba's
on-disk cache of a function sees only its own file change, so the two entry points here are
built by functions that close over a hash of all those files (``CACHE_UNIT``, see
:mod:`.kernel_cache`): a change to any of them compiles the loop anew. The kernels
allocate nothing, so they are compiled without numba's reference counting
(``_nrt=False``), which would cost atomic operations at every call. The step loop follows
numpy's error model (``error_model="numpy"``): its divisors are never zero (conductance
totals include the leak, time constants and ring sizes are positive), and Python's model
would test each divisor and keep the divisions from overlapping.

The loop returns early (before starting a step) when the spike record buffer may
overflow; the caller grows the buffer and calls again from that step.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numba import njit

from .kernel_cache import source_stamp
from .kernel_delivery import deliver_static, emit, later_slot
from .kernel_layout import (
    C_I_ALPHA,
    C_LOCK,
    C_REFRAC,
    C_THETA_PLUS,
    C_V_RESET,
    G_FLAGS,
    G_HI,
    G_KIND,
    G_LO,
    KIND_CURR,
    NEVER,
    ST_NEURON_UPDATES,
    ST_PLASTIC_UPDATES,
    ST_STEPS,
    VAR_EXC,
    VAR_INH,
    VAR_THETA,
    VAR_V,
)
from .kernel_neurons import update_cond, update_curr
from .kernel_plasticity import arrive_slot, decay_post_traces, post_traces, potentiate
from .kernel_sources import geometric_gap, queue_build, queue_due, queue_push

#: The modules whose code the compiled entry points below are made of (numba caches them
#: under a hash of all these files).
CACHE_UNIT = (
    "kernels", "kernel_layout", "kernel_sources", "kernel_neurons", "kernel_plasticity", "kernel_delivery", "prefetch", "libm"
)  # fmt: skip


def _step_loop(stamp: int) -> Callable[..., int]:
    """The step loop, cached under ``stamp`` (:func:`.kernel_cache.source_stamp` of ``CACHE_UNIT``)."""

    @njit(cache=True, _nrt=False, error_model="numpy")
    def run_steps(
        j0, j1, dt, plastic_on, headroom, n_updated, neurons, record, static, arrivals, conv, syn, stdp, sources, var, stats
    ):
        """Advance from step ``j0`` to ``j1`` (exclusive); return the step reached.

        ``headroom`` is the most spikes one step can record; the loop stops before a step
        that could overflow the record buffers. ``n_updated`` is the number of neurons the
        groups update (sources excluded). The bundles (:mod:`.kernel_layout`) are a ``Neurons``,
        ``SpikeRecord``, ``StaticTables``, ``Arrivals``, ``ConvTables``,
        ``PlasticTables``, ``Traces``, ``Sources`` and ``VarRecord``;
        ``stats`` holds the activity counters (``ST_*``).
        """
        stamp  # noqa: B018 - in numba's cache key (see .kernel_cache)
        groups, params, v, isyn, ie, ii = neurons.groups, neurons.params, neurons.v, neurons.isyn, neurons.ie, neurons.ii
        theta, ica, refr, flag, flag_words = neurons.theta, neurons.ica, neurons.refr, neurons.flag, neurons.flag_words
        counts = neurons.counts
        pois_idx, pois_logq, pois_next, pois_start, pois_end = (
            sources.pois_idx,
            sources.pois_logq,
            sources.pois_next,
            sources.pois_start,
            sources.pois_end,
        )
        arr_step, arr_neuron, arr_ptr, rng = sources.arr_step, sources.arr_neuron, sources.arr_ptr, sources.rng
        queue_t, queue_k, queue_n, due = sources.queue_t, sources.queue_k, sources.queue_n, sources.due
        queue_build(pois_next, queue_t, queue_k, queue_n)
        ev, ev_n, rec_n = arrivals.ev, arrivals.ev_n, record.n
        ring = ev_n.size
        n = v.size
        cap = record.t.size
        width = arrivals.buf.size // arrivals.row_any.size
        for j in range(j0, j1):
            if rec_n[0] + headroom > cap:
                return j
            slot = j % ring
            after = later_slot(slot, 1, ring)  # the slot of step j + 1
            # 1. sources: the Poisson ones due now (or, after a window change or a redraw, before), by index
            for d in range(queue_due(j, queue_t, queue_k, queue_n, due)):
                k = due[d]
                if pois_next[k] == j:
                    i = pois_idx[k]
                    if pois_start[k] <= j < pois_end[k]:
                        emit(i, j, slot, width, counts, stats, record, static, arrivals, conv, syn)
                    g = geometric_gap(rng, pois_logq[k])
                    pois_next[k] = NEVER if g == NEVER else j + 1 + g
                else:  # due in the past (window change or redraw): draw forward
                    g = geometric_gap(rng, pois_logq[k])
                    pois_next[k] = NEVER if g == NEVER else j + g
                if pois_next[k] != NEVER:
                    queue_push(queue_t, queue_k, queue_n, pois_next[k], k)
            while arr_ptr[0] < arr_step.size and arr_step[arr_ptr[0]] <= j:
                if arr_step[arr_ptr[0]] == j:
                    emit(arr_neuron[arr_ptr[0]], j, slot, width, counts, stats, record, static, arrivals, conv, syn)
                arr_ptr[0] += 1
            # 2. arrivals at plastic synapses (post traces hold their value at time j)
            arrive_slot(slot, ev_n[slot], ev, j, dt, plastic_on, syn, stdp, isyn, arrivals.listed, stats)
            ev_n[slot] = 0
            # postsynaptic traces advance to the end of the step
            decay_post_traces(stdp)
            # static arrivals
            deliver_static(slot, n, arrivals, isyn)
            # 3. neurons, group by group; then each group's spikes in increasing index
            stats[ST_NEURON_UPDATES] += n_updated
            for grp in range(groups.shape[0]):
                lo, hi, flags = groups[grp, G_LO], groups[grp, G_HI], groups[grp, G_FLAGS]
                if groups[grp, G_KIND] == KIND_CURR:
                    n_spikes = update_curr(lo, hi, flags, neurons)
                else:
                    n_spikes = update_cond(lo, hi, flags, dt, plastic_on, neurons)
                word = lo >> 3
                while n_spikes > 0:
                    if flag_words[word] != 0:
                        for i in range(word << 3, (word << 3) + 8):
                            if flag[i]:
                                flag[i] = False
                                n_spikes -= 1
                                v[i] = params[lo, C_V_RESET]
                                refr[i] = np.int64(params[lo, C_REFRAC] + params[lo, C_LOCK])
                                ica[i] += params[lo, C_I_ALPHA]
                                if plastic_on:
                                    theta[i] += params[lo, C_THETA_PLUS]
                                    stats[ST_PLASTIC_UPDATES] += potentiate(i, j + 1, dt, syn, stdp)
                                post_traces(i, stdp)
                                emit(i, j + 1, after, width, counts, stats, record, static, arrivals, conv, syn)
                    word += 1
            # 4. state recording
            if var.idx.size:
                row = j - j0
                var_out = var.out
                for r in range(var.idx.size):
                    i = var.idx[r]
                    c = var.code[r]
                    if c == VAR_V:
                        var_out[row, r] = v[i]
                    elif c == VAR_EXC:
                        var_out[row, r] = ie[i]
                    elif c == VAR_INH:
                        var_out[row, r] = ii[i]
                    elif c == VAR_THETA:
                        var_out[row, r] = theta[i]
                    else:
                        var_out[row, r] = ica[i]
            stats[ST_STEPS] += 1
        return j1

    return run_steps


def _poisson_draws(stamp: int) -> Callable[..., None]:
    """The Poisson redraw, cached under ``stamp``."""

    @njit(cache=True, _nrt=False)
    def draw_poisson(j: int, idx: np.ndarray, log_q: np.ndarray, nxt: np.ndarray, rng: np.ndarray) -> None:
        """(Re)draw the next spike step of every Poisson neuron from step ``j`` on."""
        stamp  # noqa: B018 - in numba's cache key (see .kernel_cache)
        for k in range(idx.size):
            g = geometric_gap(rng, log_q[k])
            nxt[k] = NEVER if g == NEVER else j + g

    return draw_poisson


_STAMP = source_stamp(__file__, CACHE_UNIT)
run_steps = _step_loop(_STAMP)
draw_poisson = _poisson_draws(_STAMP)
