"""Speck's number formats on the reference backend (``[formats].arithmetic = "speck"``).

``nv.compile(net, backend="reference", hardware="speck")`` runs :class:`SpeckSimulation`:
the network as Speck's integer IAF layers, stepped by :func:`.kernels_speck.run_speck`.
The values of each layer (charges per spike, threshold, bias per channel, ``min_v_mem``)
are :func:`neurovpr.hardware.speck_values.speck_values`'; they are made integers here as
Sinabs 3.1.3's ``discretize_conv_spike_`` makes them (``sinabs/backend/dynapcnn/discretize.py``,
which ``DynapcnnLayer`` and so ``DynapcnnNetwork`` apply), computed again in float32 as torch
computes it:

* ``scale(x, bits)``: ``(2**(bits-1) - 1) / max(x)`` when ``|min(x)| <= |max(x)| * 2**(bits-1) /
  (2**(bits-1) - 1)``, else ``2**(bits-1) / |min(x)|`` (``determine_discretization_scale``);
* one scale per layer, the least of ``scale(kernel, weight_bits)``, ``scale(bias, weight_bits)``
  (zeros without a bias) and ``scale((min_v_mem, threshold), voltage_bits)``;
* every value times the scale, rounded half to even (``torch.round``).

The membrane is recorded as ``v_rest + v / scale`` (mV). :func:`speck_problem` refuses what
Speck's layers cannot hold (:func:`~neurovpr.hardware.speck_values.speck_problems`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neurovpr.errors import UnsupportedFeatureError
from neurovpr.hardware.hwspec import HwSpec
from neurovpr.hardware.speck_values import lowest_state, speck_problems, speck_values, threshold_problems
from neurovpr.ir.network import Network

from . import kernel_layout as kl
from . import kernels_fixed as kf
from . import kernels_speck as ks
from .fixed_point import FixedPointSimulation
from .quantisation import FixedLayout
from .simulation import ReferenceSimulation

__all__ = ["SpeckSimulation", "quantise_speck", "speck_problem", "sinabs_scale"]


def speck_problem(network: Network, spec: HwSpec, dt: float, problems: list[str] | None = None) -> Exception | None:
    """The first reason ``network`` cannot run as Speck's integer layers (of ``problems`` when given), as the error."""
    problems = speck_problems(network, spec, dt) if problems is None else problems
    if not problems:
        return None
    more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
    return UnsupportedFeatureError(f"Hardware emulation of {spec.name!r} cannot run {problems[0]}{more}.")


def sinabs_scale(values: np.ndarray, bits: int) -> np.float32:
    """``determine_discretization_scale`` of Sinabs in float32 (``inf`` for all zeros)."""
    x = np.asarray(values, dtype=np.float32)
    lo, hi = -(2 ** (bits - 1)), 2 ** (bits - 1) - 1
    v_min, v_max = np.abs(x.min()), np.abs(x.max())
    with np.errstate(divide="ignore"):
        if v_min <= v_max * np.float32(abs(lo / hi)):
            return np.float32(np.abs(np.float32(hi) / x.max()))
        return np.float32(np.abs(np.float32(lo) / x.min()))


def _ints(values: np.ndarray, scale: np.float32) -> np.ndarray:
    return np.round(np.asarray(values, dtype=np.float32) * scale).astype(np.int64)


def quantise_speck(network: Network, spec: HwSpec, lay: Any, *, dt: float, seed: int) -> FixedLayout:
    """The integer network: per-neuron columns ``SP_*`` of :mod:`.kernels_speck`, one ring column per neuron."""
    fmt = spec.formats
    weights = {name: lay.s_w[pos] for name, pos in lay.proj_static.items()}
    params = np.zeros((lay.n, ks.N_SPECK_COLS), dtype=np.int64)
    s_val = np.zeros(lay.s_w.size, dtype=np.int64)
    v_unit = np.ones(lay.n)
    blocks, by_proj = [], {}
    layers = speck_values(network, dt=dt, seed=seed, weights=weights)
    problem = speck_problem(network, spec, dt, threshold_problems(layers, spec))
    if problem is not None:
        raise problem
    for layer in layers:
        vmin, thr = np.float32(lowest_state(layer, spec)), np.float32(layer.threshold)
        bias = np.zeros(layer.kernel.shape[0]) if layer.bias is None else layer.bias
        scale = min(
            sinabs_scale(layer.kernel, fmt.weight_bits),
            sinabs_scale(bias, fmt.weight_bits),
            sinabs_scale(np.array([vmin, thr], np.float32), fmt.voltage_bits),
        )
        lo, hi = lay.offsets[layer.population]
        pos = lay.proj_static[layer.projection]
        s_val[pos] = _ints(lay.s_w[pos] * layer.gain, scale)
        by_proj[layer.projection] = {"value": s_val[pos], "exponent": np.zeros(pos.size, np.int64)}
        per_channel = (hi - lo) // layer.kernel.shape[0]
        params[lo:hi, ks.SP_VTH] = _ints(thr, scale)
        params[lo:hi, ks.SP_VMIN] = _ints(vmin, scale)
        params[lo:hi, ks.SP_BIAS] = np.repeat(_ints(bias, scale), per_channel)
        v_unit[lo:hi] = 1.0 / float(scale)
        blocks.append(
            {
                "population": layer.population,
                "scale": float(scale),
                "threshold": int(params[lo, ks.SP_VTH]),
                "min_v_mem": int(params[lo, ks.SP_VMIN]),
                "kernel": _ints(layer.kernel, scale),
                "bias": _ints(bias, scale),
                "v_rest": layer.v_rest,
            }
        )
    return FixedLayout(
        variant="speck",
        params=params,
        s_val=s_val,
        s_gp=lay.s_post.astype(np.int64),
        gp_post=np.zeros(0, np.int64),
        gp_exp=np.zeros(0, np.int64),
        n_gp=lay.n,
        v_unit=v_unit,
        blocks=blocks,
        weights=by_proj,
    )


class SpeckSimulation(FixedPointSimulation):
    """A reference simulation computing in Speck's integers (see the module docstring).

    :class:`.fixed_point.FixedPointSimulation` gives the checks (:func:`speck_problem`), the
    recordable variables and the requantisation after ``set_weights``; this class the Speck
    integers and loop.
    """

    def _quantise(self) -> FixedLayout:
        return quantise_speck(self._network, self._spec, self._lay, dt=self._dt, seed=self._seed)

    def _reset_state(self) -> None:
        ReferenceSimulation._reset_state(self)
        layers = [b["population"] for b in self._integer_ring().blocks]
        self._order = np.concatenate([np.arange(*self._lay.offsets[p]) for p in layers] or [np.zeros(0)]).astype(np.int64)

    def _run(self, n_steps: int) -> None:
        fx = self._fx
        assert fx is not None
        j, pos, j1 = self._step, 0, self._step + n_steps
        raw = np.zeros((n_steps, self._var_idx.size))
        syn = kf.FixedSynapses(self._lay.s_ptr, fx.s_gp, fx.s_val, self._lay.s_delay)
        while j < j1:
            var = kl.VarRecord(self._var_idx, np.zeros_like(self._var_idx), raw[j - self._step :])  # Speck records v only
            j, pos, neuron, spikes = ks.run_speck(
                j,
                pos,
                j1,
                fx.params,
                self._order,
                self._v_i,
                self._counts,
                syn,
                self._acc,
                self._sources(),
                self._spike_record(),
                self._headroom,
                var,
                self._stats,
            )
            self._flush_spikes()
            if neuron >= 0:  # the record was full: these spikes go straight to the record's chunks
                self._spike_chunks.append((np.full(spikes, j + 1, np.int64), np.full(spikes, neuron, np.int64)))
        for col, key in enumerate(self._var_keys):
            i = self._lay.offsets[key[0]][0] + key[2]
            v_rest = next(b["v_rest"] for b in fx.blocks if b["population"] == key[0])
            self._recorders[key].append(v_rest + raw[:, col] * fx.v_unit[i])
        self._step = j1
