"""Translation of neurovpr's IR into Nengo's normalised LIF terms (pure numpy, no Nengo import).

Nengo's ``LIF`` works on a normalised voltage ``u`` that rests at 0, fires above 1
and resets to 0, driven by an input ``J`` held constant over each step (its
zero-order-hold update ``u += (J - u) (1 - exp(-dt / tau_rc))``). The normalised
compartment of :mod:`neurovpr.backendkit.lif` (``u = (v - v_reset) / (v_thresh - v_reset)``,
``J = s (i_offset + kappa I) + (v_rest - v_reset) / (v_thresh - v_reset)``, ``I`` the synaptic
current at the start of the step) agrees with it exactly below threshold with
``tau_rc = tau_m``, ``tau_ref = tau_refrac``.

On the Nengo side ``s`` is the ensemble's ``gain`` (Nengo multiplies connections
into ``.neurons`` by it), the constant part of ``J`` its ``bias``, and a connection's transform
is ``kappa w dt / (1 - e_s)``: with spikes of height ``1 / dt`` and a first-order
filter of unit DC gain (``nengo.Lowpass(tau_syn)`` or the delayed discrete filter
below), the filtered current then starts at ``kappa w`` and decays by ``e_s`` per
step, exactly the exact-integration current.

Where Nengo differs from docs/semantics.md (and so the tolerances):

- spike timing inside a step: Nengo's LIF interpolates the threshold crossing and
  starts the refractory period there, so a neuron under constant input fires at the
  continuous-time LIF rate ``1 / (tau_ref + tau_rc log(1 + 1 / (J - 1)))`` instead of
  the step-grid rate (threshold tested at the end of a step, ``round(tau_refrac / dt)``
  refractory steps). The rates agree within ``dt`` per inter-spike interval;
- threshold: ``u > 1`` instead of ``v >= v_thresh`` (differs only on exact equality);
- delays: Nengo has no synaptic delay; the ``nengo`` backend builds one with a
  discrete filter ``(1 - e_s) z^-D / (1 - e_s z^-1)`` per projection and delay, so
  spike arrival is on the same step as the semantics. NengoLoihi accepts only
  ``nengo.Lowpass`` (``D = 1``): projections from spike sources keep the exact timing,
  projections between neuron populations act one step (``dt``) early.
"""

from __future__ import annotations

import math

import numpy as np

from neurovpr.backendkit.lif import current_factor, shared_constant_problems
from neurovpr.backendkit.params import per_neuron
from neurovpr.ir.cells import IF_curr_exp
from neurovpr.ir.connectors import ConvolutionConnector
from neurovpr.ir.network import Population

__all__ = [
    "lif_problems",
    "transform_scale",
    "filter_delay",
    "conv_padding_mode",
]

#: Relative tolerance for "equal" parameters (v_reset vs the initial voltage).
_RTOL = 1e-9


def lif_problems(pop: Population, *, loihi: bool) -> list[str]:
    """Why an ``IF_curr_exp`` population cannot be expressed as a Nengo (or NengoLoihi) LIF.

    Parameters
    ----------
    pop
        The population (other cell types are refused by the capability table).
    loihi
        Also apply NengoLoihi's restriction: every voltage starts at 0 (``v_reset``).

    Returns
    -------
    list of str
        One phrase per problem, naming the parameter and its value.
    """
    cell = pop.cell_type
    if not isinstance(cell, IF_curr_exp):
        return []
    problems = shared_constant_problems(pop, "one value per Nengo ensemble")
    if loihi:
        reset = per_neuron(cell.v_reset, pop.size)
        init = per_neuron(cell.v_rest if pop.v_init is None else pop.v_init, pop.size)
        close = np.isclose(init, reset, rtol=_RTOL, atol=1e-12)
        if not np.all(close):
            bad = int(np.flatnonzero(~close)[0])
            problems.append(
                f"initial voltage {init[bad]:g} mV != v_reset {reset[bad]:g} mV (population {pop.name!r}; "
                "NengoLoihi starts every voltage at 0, which stands for v_reset)"
            )
    return problems


def transform_scale(tau_syn: float, tau_m: float, dt: float) -> float:
    """Factor from a weight (nA) to a Nengo transform, given spikes of height ``1 / dt_s``.

    ``kappa dt_s / (1 - e_s)``; the ensemble's gain supplies ``R / (v_thresh - v_rest)``.
    """
    e_s = math.exp(-dt / tau_syn)
    return current_factor(tau_syn, tau_m, dt) * (dt / 1000.0) / (1.0 - e_s)


def filter_delay(steps: int, *, from_source: bool) -> int:
    """Steps from a spike in Nengo to its first effect on the target's input ``J``.

    A neuron spiking in step ``j`` (at ``(j + 1) dt``) with a delay of ``K`` steps acts
    from step ``j + 1 + K``; a source spike stamped at ``m dt`` is emitted by Nengo in
    step ``m`` (its gate neurons run one step later than the stamp) and acts from
    ``m + K``. Nengo's filter adds the rest.
    """
    return int(steps) if from_source else int(steps) + 1


def conv_padding_mode(conn: ConvolutionConnector) -> str | None:
    """``"valid"`` or ``"same"`` when Nengo's ``Convolution`` pads exactly like ``conn``, else ``None``.

    Nengo pads ``"same"`` like TensorFlow (output ``ceil(size / stride)``, total padding
    split with the smaller half first); neurovpr pads ``padding`` on every side.
    """
    if conn.padding == (0, 0):
        return "valid"
    out = conn.output_hw
    for axis in range(2):
        size, k, s, p = conn.input_shape[axis + 1], conn.kernel_shape[axis], conn.stride[axis], conn.padding[axis]
        same_out = -(-size // s)
        total = max((same_out - 1) * s + k - size, 0)
        if out[axis] != same_out or p != total // 2:
            return None
    return "same"
