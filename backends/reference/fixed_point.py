"""Number-format emulation: a network quantised into a chip's integer formats, and its simulation.

``nv.compile(net, backend="reference", hardware=NAME)`` runs :class:`FixedPointSimulation`:
the float layout of :mod:`.translation` is quantised once (:mod:`.quantisation`), with every format parameter
read from the hwspec's ``[formats]`` table, and the loops of :mod:`.kernels_fixed` run it
with integers only (docs/number_formats.md has the formats, update orders and checks). The
arithmetic is the one the hwspec's ``[formats].arithmetic`` names, whatever the hwspec's name.

* Loihi (``arithmetic = "loihi1"``, ``"loihi2"``): each core block of the compile's partition is
  discretised as NengoLoihi's ``discretize_block`` does, from the float compartment
  NengoLoihi builds for an ``IF_curr_exp`` population (threshold 1 at ``v_thresh``, 0 at
  ``v_reset``; gain ``R / (v_thresh - v_reset)``; a weight ``w`` acting as ``kappa w gain /
  decay_u``, ``kappa`` the constant-current equivalent of the exact integration over one
  step), keeping that pipeline's float32 storage and operation order so the integers equal
  NengoLoihi's.
* SpiNNaker (``arithmetic = "spinnaker"``): sPyNNaker's host conversion (s16.15 parameters, 16-bit weights
  under one ring-buffer shift per population and synapse type) and the constants its
  cores derive (``R``, ``exp_TC``, each synapse's ``decay`` and ``init``, refractory steps).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from neurovpr.backendkit.params import per_neuron
from neurovpr.errors import SimulationError, UnsupportedFeatureError, ValidationError
from neurovpr.hardware.check import HardwareTarget
from neurovpr.hardware.hwspec import HwSpec
from neurovpr.ir.cells import IF_cond_exp, IF_curr_exp, IF_curr_exp_ca2_adaptive
from neurovpr.ir.network import Network

from . import kernel_layout as kl
from . import kernels_fixed as kf
from .capabilities import RECORDABLE_ON_HARDWARE
from .quantisation import COND_SHIFT, FixedLayout, quantise
from .simulation import ReferenceSimulation

__all__ = ["FixedPointSimulation", "emulation_problem"]


def _uniform(value: Any) -> bool:
    arr = np.asarray(value, dtype=np.float64)
    return arr.ndim == 0 or bool(np.all(arr == arr.flat[0]))


def emulation_problem(network: Network, spec: HwSpec, dt: float) -> Exception | None:
    """The first reason ``network`` cannot run in ``spec``'s number formats, as the error to raise."""
    variant = spec.formats.arithmetic
    step = spec.timing.time_step_ms
    if variant == "xylo":
        from .xylo import xylo_problem

        return xylo_problem(network, dt, step)
    if variant == "speck":
        from .speck import speck_problem

        return speck_problem(network, spec, dt)
    if not math.isclose(dt, step, rel_tol=1e-9):
        return ValidationError(
            f"compile: hardware {spec.name!r} runs in steps of {step:g} ms ([timing].time_step_ms), got dt={dt:g} ms."
        )
    for proj in network.projections.values():
        if proj.plastic:
            return UnsupportedFeatureError(
                f"Hardware emulation of {spec.name!r} runs inference only: projection {proj.name!r} is plastic "
                f"({type(proj.synapse).__name__})."
            )
    allowed = (IF_curr_exp,) if variant != "spinnaker" else (IF_curr_exp, IF_cond_exp, IF_curr_exp_ca2_adaptive)
    for pop in network.populations.values():
        cell = pop.cell_type
        if pop.is_source:
            continue
        if type(cell) not in allowed:
            return UnsupportedFeatureError(
                f"Hardware emulation of {spec.name!r} cannot run population {pop.name!r} of {type(cell).__name__} "
                f"(it emulates {', '.join(c.__name__ for c in allowed)})."
            )
        if variant == "spinnaker":
            continue
        for name in ("tau_m", "tau_syn_E", "tau_syn_I"):
            if not _uniform(getattr(cell, name)):
                return UnsupportedFeatureError(
                    f"Hardware emulation of {spec.name!r} needs one {name} per population (a core block shares its "
                    f"decay constant), population {pop.name!r} has one per neuron."
                )
        kinds = {p.receptor_type for p in network.projections.values() if p.post == pop.name}
        if kinds == {"excitatory", "inhibitory"} and float(np.asarray(cell.tau_syn_E).flat[0]) != float(
            np.asarray(cell.tau_syn_I).flat[0]
        ):
            return UnsupportedFeatureError(
                f"Hardware emulation of {spec.name!r} gives a compartment one synaptic current: population "
                f"{pop.name!r} receives both receptor types with tau_syn_E {np.asarray(cell.tau_syn_E).flat[0]:g} "
                f"!= tau_syn_I {np.asarray(cell.tau_syn_I).flat[0]:g} ms."
            )
    return None


# -- Loihi ---------------------------------------------------------------------------
class FixedPointSimulation(ReferenceSimulation):
    """A reference simulation computing in a chip's number formats.

    Parameters
    ----------
    network, dt, seed, record_spikes
        As :class:`.simulation.ReferenceSimulation`.
    hardware
        The hardware target ``nv.compile`` made (it fits; its partition gives the Loihi core blocks).
    """

    def __init__(
        self, network: Network, *, dt: float, seed: int, hardware: HardwareTarget, record_spikes: Any = None
    ) -> None:
        problem = emulation_problem(network, hardware.spec, dt)
        if problem is not None:
            raise problem
        self._spec = hardware.spec
        self._fx: FixedLayout | None = None
        super().__init__(network, dt=dt, seed=seed, hardware=hardware, record_spikes=record_spikes)

    @property
    def quantised(self) -> FixedLayout:
        """The integer network the chip would hold (read-only use)."""
        assert self._fx is not None
        return self._fx

    def _reset_state(self) -> None:
        super()._reset_state()
        if self._fx is None:
            self._fx = self._quantise()
        fx, n = self._fx, self._lay.n
        self._acc = np.zeros((self._lay.ring, max(1, fx.n_gp)), dtype=np.int64)
        self._refr_i = np.zeros(n, dtype=np.int64)
        if fx.variant == "spinnaker":
            self._v_i = fx.params[:, kf.S_V_INIT].copy()
            self._ica_i = fx.params[:, kf.S_I_CA_INIT].copy()
            self._ie_i, self._ii_i = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
        else:
            self._v_i = fx.params[:, kf.L_V_INIT].copy()
            self._u_i, self._q_i = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)

    def _integer_ring(self) -> FixedLayout:
        """Quantise once (again after ``set_weights``), clear an integer delay ring of one column per synapse group
        and integer membranes at 0; the quantised layout (the Xylo and Speck loops start from this state)."""
        if self._fx is None:
            self._fx = self._quantise()
        self._acc = np.zeros((self._lay.ring, self._fx.n_gp), dtype=np.int64)
        self._v_i = np.zeros(self._lay.n, dtype=np.int64)
        return self._fx

    def _set_recording(self, population: str, variable: str, neurons: np.ndarray) -> None:
        allowed = RECORDABLE_ON_HARDWARE[self._spec.formats.arithmetic]
        if variable not in allowed:
            raise SimulationError(
                f"record: {variable!r} is not recorded in the {self._spec.name} formats (recordable: "
                f"{', '.join(sorted(allowed))})."
            )
        super()._set_recording(population, variable, neurons)

    def _set_weights(self, projection: str, values: np.ndarray) -> None:
        super()._set_weights(projection, values)
        self._fx = self._quantise()

    def _quantise(self) -> FixedLayout:
        assert self._hardware is not None
        return quantise(self._network, self._spec, self._lay, dt=self._dt, partition=self._hardware.partition)

    def _run(self, n_steps: int) -> None:
        fx, lay, fmt = self._fx, self._lay, self._spec.formats
        assert fx is not None
        j0, j1 = self._step, self._step + n_steps
        raw = np.zeros((n_steps, self._var_idx.size))
        syn = kf.FixedSynapses(lay.s_ptr, fx.s_gp, fx.s_val, lay.s_delay)
        if fx.variant == "spinnaker":
            formats = kf.SpinnakerFormats(fmt.fraction_bits, 2**fmt.accumulator_bits - 1, COND_SHIFT)
            state = kf.SpinnakerState(self._v_i, self._ie_i, self._ii_i, self._ica_i, self._refr_i)
        else:
            loihi1 = fx.variant == "loihi1"
            variant, shift = (kf.LOIHI1, 0) if loihi1 else (kf.LOIHI2, fmt.weight_exponent_offset)
            formats = kf.LoihiFormats(variant, fmt.decay_bits, fmt.accumulator_bits, fmt.current_bits - 1, shift)
            state = kf.LoihiState(self._u_i, self._v_i, self._refr_i, self._q_i)
        j = j0
        while j < j1:
            sources, record = self._sources(), self._spike_record()
            var = kl.VarRecord(self._var_idx, self._var_code, raw[j - j0 :])
            if fx.variant == "spinnaker":
                reached = kf.run_spinnaker(
                    j, j1, formats, fx.params, state, self._counts, syn, self._acc, sources, record, self._headroom, var,
                    self._stats,
                )
            else:
                groups = kf.SynapseGroups(fx.gp_post, fx.gp_exp)
                reached = kf.run_loihi(
                    j, j1, formats, fx.params, state, groups, self._counts, syn, self._acc, sources, record,
                    self._headroom, var, self._stats,
                )
            self._flush_spikes()
            j = reached
        self._step = j1
        for col, key in enumerate(self._var_keys):
            self._recorders[key].append(self._physical(key, raw[:, col]))

    def _physical(self, key: Any, raw: np.ndarray) -> np.ndarray:
        """Recorded integers in PyNN units (mV, nA, uS)."""
        fx = self._fx
        assert fx is not None
        i = self._lay.offsets[key[0]][0] + key[2]
        if fx.variant == "spinnaker":
            cond = key[1].startswith("gsyn")
            return raw * fx.v_unit[i] / (2.0**COND_SHIFT if cond else 1.0)
        cell = self._network.populations[key[0]].cell_type
        return float(per_neuron(cell.v_reset, self._network.populations[key[0]].size)[key[2]]) + raw * fx.v_unit[i]
