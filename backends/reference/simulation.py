"""ReferenceSimulation: state, inputs and read-out around the compiled step loop."""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

import numpy as np

from neurovpr.backendkit.params import per_neuron
from neurovpr.backendkit.sources import array_events
from neurovpr.backendkit.timing import window_steps
from neurovpr.errors import ValidationError
from neurovpr.ir.cells import IF_cond_exp_adaptive, SpikeSourceArray, SpikeSourcePoisson
from neurovpr.ir.network import Network
from neurovpr.runtime.simulation import Simulation
from neurovpr.runtime.weights import check_weight_range

if TYPE_CHECKING:
    from neurovpr.hardware.check import HardwareTarget

from . import kernel_layout as kl
from . import kernels
from .delivery import split_static
from .kernel_layout import BLOCK_SHIFT, C_I_CA_INIT, C_V_INIT, CV_WOFF, KIND_POISSON, VAR_CODES
from .normalisation import apply_factors, scale_factors
from .translation import build_layout

_PAST = -(2**40)


class ReferenceSimulation(Simulation):
    """A network compiled for the reference backend.

    Parameters
    ----------
    network, dt, seed
        See :func:`neurovpr.compile`.
    hardware
        The hardware target (only :class:`.fixed_point.FixedPointSimulation` computes in its formats).
    record_spikes
        Names of the populations whose spike trains are kept (default: all). Spike
        counts are always kept; leaving trains out saves memory in long training runs.
    """

    def __init__(
        self,
        network: Network,
        *,
        dt: float,
        seed: int,
        hardware: HardwareTarget | None = None,
        record_spikes: Iterable[str] | None = None,
    ) -> None:
        super().__init__(network, backend="reference", dt=dt, seed=seed, hardware=hardware)
        lay = self._lay = build_layout(network, dt, seed)
        n = lay.n
        self._x_pre = np.zeros(int(np.diff(lay.post_ptr).max(initial=0)))
        self._rec_mask = np.zeros(n, dtype=np.bool_)
        names = list(network.populations) if record_spikes is None else list(record_spikes)
        for name in names:
            if name not in lay.offsets:
                raise ValidationError(f"record_spikes: population {name!r} does not exist.")
            lo, hi = lay.offsets[name]
            self._rec_mask[lo:hi] = True
        self._theta = np.zeros(n)
        for name, pop in network.populations.items():
            if isinstance(pop.cell_type, IF_cond_exp_adaptive):
                lo, hi = lay.offsets[name]
                self._theta[lo:hi] = pop.cell_type.theta_init
        seed_state = np.random.SeedSequence(seed).generate_state(2, dtype=np.uint64)
        self._rng = np.array([seed_state[0] | np.uint64(1)], dtype=np.uint64)
        # Poisson sources
        self._pois_idx = np.flatnonzero(lay.kind == KIND_POISSON).astype(np.int64)
        self._pois_rate = np.zeros(self._pois_idx.size)
        self._pois_start = np.zeros(self._pois_idx.size, dtype=np.int64)
        self._pois_end = np.zeros(self._pois_idx.size, dtype=np.int64)
        self._pois_pos: dict[str, slice] = {}
        pos = 0
        self._arrays: dict[str, SpikeSourceArray] = {}
        for name, pop in network.populations.items():
            cell = pop.cell_type
            if isinstance(cell, SpikeSourcePoisson):
                sl = slice(pos, pos + pop.size)
                self._pois_pos[name] = sl
                self._pois_rate[sl] = per_neuron(cell.rate, pop.size)
                first, end = window_steps(cell.start, cell.duration, dt)
                self._pois_start[sl] = first
                self._pois_end[sl] = kl.NEVER if math.isinf(end) else int(end)
                pos += pop.size
            elif isinstance(cell, SpikeSourceArray):
                self._arrays[name] = cell
        self._pois_logq = np.zeros(self._pois_idx.size)
        self._pois_next = np.zeros(self._pois_idx.size, dtype=np.int64)
        # the float loop's heap of Poisson sources by next step (rebuilt from _pois_next at every call)
        self._queue = (np.zeros(self._pois_idx.size, np.int64), np.zeros(self._pois_idx.size, np.int64),
                       np.zeros(1, np.int64), np.zeros(self._pois_idx.size, np.int64))  # fmt: skip
        self._update_rates()
        self._stats = np.zeros(5, dtype=np.int64)
        self._recorders: dict[tuple[str, str], list[np.ndarray]] = {}
        self._var_keys: list[tuple[str, str]] = []
        self._var_idx = np.zeros(0, dtype=np.int64)
        self._var_code = np.zeros(0, dtype=np.int64)
        self._reset_state()

    # -- state -----------------------------------------------------------------
    def _reset_state(self) -> None:
        """Initial dynamic state; arrays of the right size are cleared in place rather than allocated again."""
        lay = self._lay
        n = lay.n
        self._step = 0
        n_seg = lay.seg_delay.size
        if not hasattr(self, "_buf"):
            self._v_init, self._ica_init = lay.params[:, C_V_INIT].copy(), lay.params[:, C_I_CA_INIT].copy()
            self._v = self._v_init.copy()
            self._isyn = np.zeros((2, n))
            self._ie, self._ii = self._isyn[0], self._isyn[1]
            self._ica = self._ica_init.copy()
            self._refr = np.zeros(n, dtype=np.int64)
            self._counts = np.zeros(n, dtype=np.int64)
            self._todo, self._scratch = np.zeros(n, dtype=np.int64), np.zeros((2, n))  # kernel scratch
            # static ring buffer: rows (receptor, slot) of whole 64-bit words of block marks
            n_blocks = -(-lay.n_blocks // 8) * 8
            self._buf = np.zeros(2 * lay.ring * (n_blocks << BLOCK_SHIFT))
            self._dirty = np.zeros(2 * lay.ring * n_blocks, dtype=np.bool_)
            self._dirty_words = self._dirty.view(np.uint64)
            self._row_any = np.zeros(2 * lay.ring, dtype=np.bool_)
            # per row, the range of neurons structured convolutions have reached (empty: n, 0)
            self._row_range = np.zeros((2, 2 * lay.ring), dtype=np.int64)
            self._row_range[0] = n
            self._flag = np.zeros(-(-n // 8) * 8, dtype=np.bool_)
            self._flag_words = self._flag.view(np.uint64)
            self._seg_xpre = np.zeros(n_seg)
            self._seg_last = np.full(n_seg, _PAST, dtype=np.int64)
            self._xpost1 = np.zeros(lay.n_traces)
            self._xpost2 = np.zeros(lay.n_traces)
            self._ev_n = np.zeros(lay.ring, dtype=np.int64)
            self._listed = np.zeros(4096, dtype=np.uint64)  # kernel scratch: synapses of a slot's short plastic events
            self._rec_n = np.zeros(1, dtype=np.int64)
        else:
            self._v[:] = self._v_init
            self._isyn.fill(0.0)
            self._ica[:] = self._ica_init
            self._refr.fill(0)
            self._counts.fill(0)
            width, marks = self._buf.size // self._row_any.size, self._dirty.size // self._row_any.size
            for row in np.flatnonzero(self._row_any):  # arrivals still pending: only marked rows hold non-zero entries
                self._buf[row * width : (row + 1) * width] = 0.0
                self._dirty[row * marks : (row + 1) * marks] = False
            self._row_any.fill(False)
            self._row_range[0] = n
            self._row_range[1] = 0
            self._flag.fill(False)
            self._seg_xpre.fill(0.0)
            self._seg_last.fill(_PAST)
            self._xpost1.fill(0.0)
            self._xpost2.fill(0.0)
            self._ev_n.fill(0)
            self._rec_n[0] = 0
        self._spike_chunks: list[tuple[np.ndarray, np.ndarray]] = []
        for key in self._recorders:
            self._recorders[key] = []
        self._build_array_events()
        need = max(1, n_seg * self._multiplicity)
        if getattr(self, "_ev", None) is None or self._ev.shape[1] != need:
            self._ev = np.zeros((lay.ring, need, 3), dtype=np.int64)  # per slot: plastic events of three words
        kernels.draw_poisson(0, self._pois_idx, self._pois_logq, self._pois_next, self._rng)
        cap = max(1 << 16, 4 * self._headroom)
        if getattr(self, "_rec_t", None) is None or self._rec_t.size != cap:
            self._rec_t = np.zeros(cap, dtype=np.int64)
            self._rec_i = np.zeros(cap, dtype=np.int64)

    def _build_array_events(self) -> None:
        steps, neurons = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
        for name, src in self._arrays.items():
            stamps, idx = array_events(src, self._dt)
            steps.append(stamps)
            neurons.append(idx + self._lay.offsets[name][0])
        st, ne = np.concatenate(steps), np.concatenate(neurons)
        order = np.lexsort((ne, st))
        self._arr_step, self._arr_neuron = st[order], ne[order]
        self._arr_ptr = np.array([np.searchsorted(self._arr_step, self._step, side="left")], dtype=np.int64)
        per_step = np.unique(self._arr_step, return_counts=True)[1] if st.size else np.zeros(1, np.int64)
        pair = np.unique(self._arr_step * self._lay.n + self._arr_neuron, return_counts=True)[1] if st.size else [1]
        self._multiplicity = int(max(1, np.max(pair)))
        self._headroom = int(self._lay.n + (per_step.max() if per_step.size else 0))

    def _update_rates(self) -> None:
        p = np.minimum(self._pois_rate * self._dt / 1000.0, 1.0)
        with np.errstate(divide="ignore"):
            self._pois_logq = np.where(p >= 1.0, -np.inf, np.log1p(-p))

    # -- Simulation hooks ---------------------------------------------------------
    @property
    def time(self) -> float:
        return self._step * self._dt

    def _set_input(self, population: str, value: Any) -> None:
        if isinstance(value, SpikeSourceArray):
            self._arrays[population] = value
            old_ring = self._ev.shape[1]
            self._build_array_events()
            need = max(1, self._lay.seg_delay.size * self._multiplicity)
            if need > old_ring:
                grown = np.zeros((self._lay.ring, need, 3), dtype=np.int64)
                grown[:, :old_ring] = self._ev
                self._ev = grown
            if self._rec_t.size < 4 * self._headroom:
                self._grow_record(4 * self._headroom)
        else:
            self._pois_rate[self._pois_pos[population]] = value
            self._update_rates()
            kernels.draw_poisson(self._step, self._pois_idx, self._pois_logq, self._pois_next, self._rng)

    def _grow_record(self, size: int) -> None:
        for attr in ("_rec_t", "_rec_i"):
            old = getattr(self, attr)
            new = np.zeros(size, dtype=np.int64)
            new[: old.size] = old
            setattr(self, attr, new)

    def _run(self, n_steps: int) -> None:
        lay = self._lay
        j0, j1 = self._step, self._step + n_steps
        var_out = np.zeros((n_steps, self._var_idx.size))
        j = j0
        while j < j1:
            reached = kernels.run_steps(
                j, j1, self._dt, self._plastic, self._headroom, lay.n_updated, *self._bundles(var_out[j - j0 :]), self._stats
            )
            self._flush_spikes()
            j = reached
        self._step = j1
        if self._var_idx.size:
            for col, key in enumerate(self._var_keys):
                self._recorders[key].append(var_out[:, col])

    def _bundles(self, var_out: np.ndarray) -> tuple:
        """The arrays :func:`.kernels.run_steps` works on, bundled by role (built per run: inputs may replace arrays)."""
        lay = self._lay
        return (
            kl.Neurons(
                lay.groups, lay.params, self._v, self._isyn, self._ie, self._ii, self._theta, self._ica, self._refr,
                self._flag, self._flag_words, self._counts, self._todo, self._scratch,
            ),
            self._spike_record(),
            kl.StaticTables(lay.d_seg_ptr, lay.d_seg_start, lay.d_seg, lay.d_post, lay.d_w, lay.d_blk_ptr, lay.d_blk),
            kl.Arrivals(
                self._buf, self._dirty, self._dirty_words, self._row_any, self._row_range, self._ev, self._ev_n, self._listed
            ),
            kl.ConvTables(lay.cv_index, lay.cv_par, lay.cv_w),
            kl.PlasticTables(
                lay.row_seg_ptr, lay.seg_start, lay.seg_delay, lay.seg_proj, lay.p_post, lay.p_w, lay.post_ptr,
                lay.post_syn, lay.post_seg, lay.post_rule, lay.proj_inh,
            ),
            kl.Traces(
                lay.rules, lay.pre_table, self._seg_xpre, self._seg_last, lay.tr_lo, lay.tr_hi, lay.tr_shift,
                lay.post_tr_ptr, lay.post_tr_idx, lay.trace_proj, lay.post_decay1, lay.post_decay2, self._xpost1,
                self._xpost2, self._x_pre,
            ),
            self._sources(),
            kl.VarRecord(self._var_idx, self._var_code, var_out),
        )  # fmt: skip

    def _sources(self) -> kl.Sources:
        """The spike sources' arrays, as the compiled loops take them."""
        return kl.Sources(
            self._pois_idx, self._pois_logq, self._pois_next, self._pois_start, self._pois_end, self._arr_step,
            self._arr_neuron, self._arr_ptr, self._rng, *self._queue,
        )  # fmt: skip

    def _spike_record(self) -> kl.SpikeRecord:
        """The spike record buffers, as the compiled loops take them."""
        return kl.SpikeRecord(self._rec_mask, self._rec_t, self._rec_i, self._rec_n)

    def _flush_spikes(self) -> None:
        m = int(self._rec_n[0])
        if m:
            self._spike_chunks.append((self._rec_t[:m].copy(), self._rec_i[:m].copy()))
            self._rec_n[0] = 0

    def _reset(self) -> None:
        self._reset_state()

    def _set_plasticity(self, on: bool) -> None:
        pass  # read by _run

    def _set_recording(self, population: str, variable: str, neurons: np.ndarray) -> None:
        keys = [(population, variable, int(i)) for i in neurons]
        kept = [k for k in self._var_keys if (k[0], k[1]) != (population, variable)]
        self._var_keys = kept + keys  # type: ignore[operator]
        self._var_idx = np.array([self._lay.offsets[k[0]][0] + k[2] for k in self._var_keys], dtype=np.int64)
        self._var_code = np.array([VAR_CODES[k[1]] for k in self._var_keys], dtype=np.int64)
        self._recorders = {k: self._recorders.get(k, []) for k in self._var_keys}  # type: ignore[misc]

    def _spike_counts(self, population: str) -> np.ndarray:
        lo, hi = self._lay.offsets[population]
        return self._counts[lo:hi].copy()

    def _spike_trains(self, population: str) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self._lay.offsets[population]
        if not self._rec_mask[lo]:
            raise ValidationError(f"spike_trains: population {population!r} was left out of record_spikes at compile time.")
        if not self._spike_chunks:
            return np.zeros(0), np.zeros(0, dtype=np.int64)
        t = np.concatenate([c[0] for c in self._spike_chunks])
        i = np.concatenate([c[1] for c in self._spike_chunks])
        keep = (i >= lo) & (i < hi)
        t, i = t[keep], i[keep] - lo
        order = np.lexsort((i, t))
        return t[order] * self._dt, i[order]

    def _trace(self, population: str, variable: str) -> tuple[np.ndarray, np.ndarray]:
        keys = [k for k in self._var_keys if (k[0], k[1]) == (population, variable)]  # type: ignore[index]
        n_steps = len(self._recorders[keys[0]]) and sum(c.size for c in self._recorders[keys[0]])  # type: ignore[index]
        values = np.zeros((n_steps, len(keys)))
        for col, key in enumerate(keys):
            if self._recorders[key]:  # type: ignore[index]
                values[:, col] = np.concatenate(self._recorders[key])  # type: ignore[index]
        times = (np.arange(n_steps) + 1 + (self._step - n_steps)) * self._dt
        return times, values

    def _connections(self, projection: str) -> tuple[np.ndarray, np.ndarray]:
        return self._lay.proj_pre[projection], self._lay.proj_post[projection]

    def _weight_store(self, projection: str) -> tuple[np.ndarray, np.ndarray]:
        if projection in self._lay.proj_plastic:
            return self._lay.p_w, self._lay.proj_plastic[projection]
        return self._lay.s_w, self._lay.proj_static[projection]

    def _weights(self, projection: str) -> np.ndarray:
        store, pos = self._weight_store(projection)
        return np.take(store, pos)  # a new array (fewer allocations than indexing and a copy)

    def _set_weights(self, projection: str, values: np.ndarray) -> None:
        store, pos = self._weight_store(projection)
        store[pos] = values
        lay = self._lay
        if store is not lay.s_w:
            return
        owner = [p for p, spec in enumerate(lay.conv_specs) if projection in spec.names]
        if owner:
            spec = lay.conv_specs[owner[0]]
            kernel = spec.kernel([lay.s_w[lay.proj_static[name]] for name in spec.names])
            if kernel is not None:
                woff = lay.cv_par[owner[0], CV_WOFF]
                lay.cv_w[woff : woff + kernel.size] = kernel
            else:  # the weights no longer share a kernel: the convolution goes the generic way
                specs = [other for other in lay.conv_specs if other is not spec]
                for key, value in split_static(lay.n, lay.s_ptr, lay.s_post, lay.s_w, lay.s_delay, lay.s_inh, specs,
                                               lay.proj_static).items():  # fmt: skip
                    setattr(lay, key, value)
        elif lay.d_w is not lay.s_w:
            lay.d_w[lay.d_of_s[pos]] = values

    def _normalise_weights(self, projection: str, total: float, w_max: float | None) -> None:
        # static projections the generic way, through _set_weights (convolution kernels, the delivery copy, and the
        # requantisation of hardware emulation, which refuses plastic projections and so never takes the path below)
        if projection not in self._lay.proj_plastic:
            super()._normalise_weights(projection, total, w_max)
            return
        store, pos = self._weight_store(projection)
        post = self._lay.proj_post[projection]
        n_post = self.network.populations[self.network.projections[projection].post].size
        factor, extent = np.empty(n_post), np.empty((2, n_post))
        clip, cap = w_max is not None, np.inf if w_max is None else w_max
        lo, hi, finite = scale_factors(store, pos, post, total, factor, extent, cap, clip)
        if pos.size:
            check_weight_range(self.network, projection, float(lo), float(hi), finite=bool(finite))
        apply_factors(store, pos, post, factor, cap, clip)

    def _learned_state(self, population: str) -> dict[str, np.ndarray]:
        pop = self._network.populations[population]
        if isinstance(pop.cell_type, IF_cond_exp_adaptive):
            lo, hi = self._lay.offsets[population]
            return {"theta": self._theta[lo:hi].copy()}
        return {}

    def _statistics(self) -> dict[str, int]:
        s = self._stats
        return {
            "steps": int(s[kl.ST_STEPS]),
            "neuron_updates": int(s[kl.ST_NEURON_UPDATES]),
            "spikes": int(s[kl.ST_SPIKES]),
            "synaptic_events": int(s[kl.ST_SYN_EVENTS]),
            "plastic_updates": int(s[kl.ST_PLASTIC_UPDATES]),
        }
