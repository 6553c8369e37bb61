"""Xylo Audio 2's number formats on the reference backend (``[formats].arithmetic = "xylo"``).

``nv.compile(net, backend="reference", hardware="xylo")`` runs :class:`XyloSimulation`: the
network in Xylo's integers, stepped by :func:`.kernels_xylo.run_xylo` (XyloSim's update
order, 16-bit saturating state, bit-shift decays, reset by subtraction, up to 31 spikes per
step for hidden and 1 for output neurons). A network for Xylo is given in chip units
(hwspecs/xylo.toml, ``weight_scaling = "integer"``): for each ``IF_curr_exp`` population

* weights are the integer weights (the fit check refuses other values); an excitatory
  projection feeds synapse 1, an inhibitory one synapse 2 with the weight negated;
* ``dash_mem = round(log2(tau_m / dt))``, ``dash_syn = round(log2(tau_syn_E / dt))``,
  ``dash_syn2 = round(log2(tau_syn_I / dt))`` (Rockpool's conversion of time constants,
  ``Xylo2Neurons._convert_from``: ``log2(tau / dt)``), so ``x -= x >> dash`` is the decay
  ``1 - dt / tau``;
* threshold ``v_thresh - v_rest`` and bias ``i_offset``, both integers, and the membrane is
  recorded as ``v_rest + v``. Xylo resets by subtracting the threshold; ``v_reset`` and
  ``tau_refrac`` have no Xylo counterpart and are not used.

Which populations are outputs (one spike per step at most) is the partition's
(:func:`neurovpr.hardware.xylo.xylo_layout`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from neurovpr.backendkit.params import per_neuron
from neurovpr.errors import UnsupportedFeatureError, ValidationError
from neurovpr.hardware.xylo import xylo_layout
from neurovpr.ir.cells import IF_curr_exp
from neurovpr.ir.network import Network

from . import kernel_layout as kl
from . import kernels_fixed as kf
from . import kernels_xylo as kx
from .fixed_point import FixedPointSimulation
from .quantisation import FixedLayout
from .simulation import ReferenceSimulation

__all__ = ["XyloSimulation", "quantise_xylo", "xylo_problem", "MAX_SPIKES_HIDDEN", "MAX_SPIKES_OUTPUT"]

#: Spikes a hidden / output neuron may emit in one step (XyloSim XyloIAFNeuron.h MAX_NUM_SPIKES, MAX_NUM_OUT_SPIKES).
MAX_SPIKES_HIDDEN, MAX_SPIKES_OUTPUT = 31, 1


def _dash(tau: Any, size: int, dt: float, where: str, bits: int) -> np.ndarray:
    value = per_neuron(tau, size).astype(np.float64)
    dash = np.round(np.log2(value / dt)).astype(np.int64)
    if dash.min() < 0 or dash.max() >= 2**bits:
        raise ValidationError(f"{where}: log2(tau / dt {dt:g} ms) rounds to {dash.min()}..{dash.max()}, outside "
                              f"Xylo's {bits}-bit decay shift 0..{2**bits - 1}.")
    return dash


def _integer(value: Any, size: int, where: str, bits: int) -> np.ndarray:
    arr = per_neuron(value, size).astype(np.float64)
    top = 2 ** (bits - 1)
    if not np.array_equal(arr, np.round(arr)) or arr.min() < -top or arr.max() >= top:
        raise ValidationError(f"{where} must be integers within the {bits}-bit range of Xylo "
                              f"[{-top}, {top - 1}], got {arr.min():g}..{arr.max():g}.")
    return arr.astype(np.int64)


def xylo_problem(network: Network, dt: float, step: float) -> Exception | None:
    """The first reason ``network`` cannot run in Xylo's integers, as the error to raise."""
    if not math.isclose(dt, step, rel_tol=1e-9):
        return ValidationError(f"compile: hardware 'xylo' runs in steps of {step:g} ms, got dt={dt:g} ms.")
    for proj in network.projections.values():
        if proj.plastic:
            return UnsupportedFeatureError(f"Xylo runs inference only: projection {proj.name!r} is plastic.")
    for pop in network.populations.values():
        if not pop.is_source and type(pop.cell_type) is not IF_curr_exp:
            return UnsupportedFeatureError(f"Xylo emulation runs IF_curr_exp only, population {pop.name!r} is "
                                           f"{type(pop.cell_type).__name__}.")
    return None


def quantise_xylo(network: Network, spec: Any, lay: Any, *, dt: float) -> FixedLayout:
    """The integer network: per-neuron columns ``X_*`` of :mod:`.kernels_xylo`, one ring column per (neuron, synapse)."""
    fmt = spec.formats
    params = np.zeros((lay.n, kx.N_XYLO_COLS), dtype=np.int64)
    outputs = set(xylo_layout(network, spec.rules).outputs)
    for pop in network.populations.values():
        if pop.is_source:
            continue
        cell = pop.cell_type
        lo, hi = lay.offsets[pop.name]
        rows = np.arange(lo, hi)
        params[rows, kx.X_ACTIVE] = 1
        params[rows, kx.X_DASH_MEM] = _dash(cell.tau_m, pop.size, dt, f"Population {pop.name!r} tau_m", fmt.decay_bits)
        params[rows, kx.X_DASH_SYN1] = _dash(cell.tau_syn_E, pop.size, dt, f"Population {pop.name!r} tau_syn_E", fmt.decay_bits)
        params[rows, kx.X_DASH_SYN2] = _dash(cell.tau_syn_I, pop.size, dt, f"Population {pop.name!r} tau_syn_I", fmt.decay_bits)
        thresh = per_neuron(cell.v_thresh, pop.size) - per_neuron(cell.v_rest, pop.size)
        params[rows, kx.X_VTH] = _integer(thresh, pop.size, f"Population {pop.name!r} v_thresh - v_rest",
                                          fmt.voltage_bits)
        params[rows, kx.X_BIAS] = _integer(cell.i_offset, pop.size, f"Population {pop.name!r} i_offset",
                                           fmt.voltage_bits)
        params[rows, kx.X_MAX_SPIKES] = MAX_SPIKES_OUTPUT if pop.name in outputs else MAX_SPIKES_HIDDEN
    inh = lay.s_inh.astype(np.int64)
    s_val = np.round(np.where(inh == 1, -np.abs(lay.s_w), lay.s_w)).astype(np.int64)
    s_gp = 2 * lay.s_post.astype(np.int64) + inh
    weights = {name: {"value": s_val[pos], "exponent": np.zeros(pos.size, np.int64)}
               for name, pos in lay.proj_static.items()}
    return FixedLayout(variant="xylo", params=params, s_val=s_val, s_gp=s_gp, gp_post=np.zeros(0, np.int64),
                       gp_exp=np.zeros(0, np.int64), n_gp=2 * lay.n, v_unit=np.ones(lay.n), weights=weights)


class XyloSimulation(FixedPointSimulation):
    """A reference simulation computing in Xylo Audio 2's integers (see the module docstring).

    :class:`.fixed_point.FixedPointSimulation` gives the checks (:func:`xylo_problem`), the
    recordable variables and the requantisation after ``set_weights``; this class the Xylo
    integers and loop.
    """

    def _quantise(self) -> FixedLayout:
        return quantise_xylo(self._network, self._spec, self._lay, dt=self._dt)

    def _reset_state(self) -> None:
        ReferenceSimulation._reset_state(self)
        self._integer_ring()
        self._isyn_i = np.zeros((self._lay.n, 2), dtype=np.int64)

    def _run(self, n_steps: int) -> None:
        fx = self._fx
        assert fx is not None
        # up to 31 spikes per neuron and step are recorded
        headroom = self._headroom + MAX_SPIKES_HIDDEN * self._lay.n
        if self._rec_t.size < 4 * headroom:
            self._grow_record(4 * headroom)
        j, j1 = self._step, self._step + n_steps
        raw = np.zeros((n_steps, self._var_idx.size))
        while j < j1:
            syn = kf.FixedSynapses(self._lay.s_ptr, fx.s_gp, fx.s_val, self._lay.s_delay)
            var = kl.VarRecord(self._var_idx, np.zeros_like(self._var_idx), raw[j - self._step :])  # Xylo records v only
            reached = kx.run_xylo(
                j, j1, self._spec.formats.voltage_bits, fx.params, self._v_i, self._isyn_i, self._counts, syn, self._acc,
                self._sources(), self._spike_record(), headroom, var, self._stats,
            )
            self._flush_spikes()
            j = reached
        for col, key in enumerate(self._var_keys):
            cell = self._network.populations[key[0]].cell_type
            v_rest = float(per_neuron(cell.v_rest, self._network.populations[key[0]].size)[key[2]])
            self._recorders[key].append(v_rest + raw[:, col])
        self._step = j1
