"""Translation of ``IF_curr_exp`` populations and their projections into Lava's LIF terms (pure numpy).

Lava's LIF (``lava.proc.lif``) updates, per step, ``u = u (1 - du) + a_in`` and
``v = v (1 - dv) + u + bias`` and spikes when ``v > vth`` (then ``v = 0``). On the
normalised compartment of :mod:`neurovpr.backendkit.lif` (``v`` measured from ``v_reset``
in units of ``v_thresh - v_reset``, gain ``s``, constant input ``b``), with ``dv = 1 - e_m``,
``du = 1 - e_s`` (``e_x = exp(-dt / tau_x)``), ``vth = 1``,

- ``bias = (1 - e_m) b``,
- a synaptic weight ``W = (1 - e_m) s kappa w`` (negative for inhibitory projections),
  ``kappa`` the constant-current equivalent of a current decaying with ``tau_syn``
  over one step,

this is exactly the exact integration of docs/semantics.md, step by step; the
refractory period is Lava's ``LIFRefractory`` (``round(tau_refrac / dt)`` steps held at
rest while ``u`` keeps integrating). A spike reaches its target through
``DelayDense``/``DelaySparse`` (or a ``DelayConv``) one step plus ``delays`` later
(``Dense``/``Sparse``: one step), so a neuron projection uses ``delays = K`` and a
source projection (replayed one step after its stamp) ``K - 1``,
``K = round(delay / dt)``: arrival times match the semantics.

``fixed_pt`` (``lava-fixed``, bit-accurate Loihi 2) scales everything into Loihi's
integer formats: :mod:`neurovpr.backendkit.loihi2` computes the integers (threshold, decays,
bias, and each synapse process's weights and exponent) from the ``loihi2`` hwspec's
``[formats]``, the same integers the reference backend's ``loihi2`` emulation runs.

The float model (``lava``) is exact to rounding; the fixed model's error is the
quantisation: about ``2**-8`` of the largest weight of each projection, the
12-bit decays, and the per-step truncation of ``u`` and ``v``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from neurovpr.backendkit.lif import NormalisedLIF, current_factor, normalised_lif, shared_constant_problems
from neurovpr.backendkit.loihi2 import LIFIntegers, lif_integers
from neurovpr.ir.network import Population

__all__ = ["LavaLIF", "lif_problems", "lava_lif", "current_factor", "weight_scale"]


@dataclass(frozen=True, slots=True)
class LavaLIF:
    """One population in Lava's LIF terms.

    Attributes
    ----------
    compartment
        The population as a normalised compartment (gain, time constants, initial voltage, mV scale).
    du, dv, vth
        Float decays and threshold (``vth = 1``).
    bias
        Float bias per neuron (``dv`` times the compartment's constant input).
    refractory_steps
        ``round(tau_refrac / dt)``.
    integers
        The fixed-point model's parameters (threshold integer ``vth_man``, voltage integers per
        threshold ``v_scale``, decays, bias, initial voltage).
    """

    compartment: NormalisedLIF
    du: float
    dv: float
    vth: float
    bias: np.ndarray
    refractory_steps: int
    integers: LIFIntegers


def lif_problems(pop: Population) -> list[str]:
    """Why an ``IF_curr_exp`` population cannot be a Lava LIF (phrases naming parameter and value)."""
    return shared_constant_problems(pop, "Lava's LIF has one decay per process")


def weight_scale(lif: LavaLIF, receptor_type: str, dt: float) -> np.ndarray:
    """Per postsynaptic neuron, the factor from a weight (nA) to Lava's float weight ``W``."""
    c = lif.compartment
    sign = 1.0 if receptor_type == "excitatory" else -1.0
    kappa = current_factor(c.tau_syn(receptor_type), c.tau_m, dt)
    return sign * lif.dv * kappa * c.gain


def lava_lif(pop: Population, dt: float, fmt: Any, receptors: frozenset[str] = frozenset()) -> LavaLIF:
    """Map an ``IF_curr_exp`` population (checked by :func:`lif_problems`) for both Lava models.

    ``fmt`` is the ``loihi2`` hwspec's ``[formats]``. ``receptors`` are the receptor types of
    its incoming projections: Lava's LIF has one synaptic current, whose decay is
    ``tau_syn_I``'s when only inhibitory input arrives and ``tau_syn_E``'s otherwise (both
    must then be equal; checked elsewhere).

    Raises
    ------
    ValueError
        When ``i_offset`` is too large for Loihi 2's bias format (the message names it).
    """
    c = normalised_lif(pop)
    ints = lif_integers(pop, dt, fmt, inhibitory_only=receptors == frozenset({"inhibitory"}))
    return LavaLIF(
        compartment=c,
        du=ints.decay_u,
        dv=ints.decay_v,
        vth=1.0,
        bias=ints.bias,
        refractory_steps=round(c.tau_refrac / dt),
        integers=ints,
    )
