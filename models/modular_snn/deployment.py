"""Deploying a trained module on current-based chips: conductance synapses as currents.

Nengo, NengoLoihi and Lava run ``IF_curr_exp`` neurons only; Loihi has no
conductance synapses. A trained module (``IF_cond_exp_adaptive`` excitatory and
``IF_cond_exp`` inhibitory neurons) is therefore deployed there as its current-based
approximation, built by :func:`to_current_based`:

- neurons: ``IF_cond_exp_adaptive`` with its learned, frozen threshold offset
  ``theta`` becomes ``IF_curr_exp`` with ``v_thresh + theta`` per neuron;
  ``IF_cond_exp`` becomes ``IF_curr_exp``; ``cm``, ``tau_m``, ``tau_refrac``,
  ``tau_syn_E``, ``tau_syn_I``, ``v_rest``, ``v_reset`` and ``i_offset`` are kept,
  except that a spike lockout longer than ``tau_refrac`` (``tau_lockout``, which no
  current-based target has) becomes the refractory period: the membrane is then held
  for the whole lockout instead of integrating after ``tau_refrac`` (V_ref's
  calibration absorbs part of the difference).
- synapses: a conductance ``g (E_rev - v)`` becomes the current ``g (E_rev - V_ref)``,
  so a weight ``w`` (uS) becomes ``w (E_rev_E - V_ref)`` (nA) on the excitatory
  receptor and ``w (V_ref - E_rev_I)`` (nA, subtracted by ``IF_curr_exp``) on the
  inhibitory one, with ``V_ref`` chosen per postsynaptic neuron and receptor.
  Learned STDP projections become static synapses with the learned weights and delays.

Choice of ``V_ref`` (:func:`calibrate_reference_voltages`). The charge a receptor
injects into neuron ``j`` over a presentation is ``sum_t g_j(t) (E_rev - v_j(t)) dt``
in the conductance network and ``sum_t g_j(t) (E_rev - V_ref) dt`` in the
approximation (the synaptic time courses are the same, as the time constants are).
They are equal when ``V_ref`` is the *conductance-weighted mean membrane voltage*
``sum_t g_j(t) v_j(t) / sum_t g_j(t)``, so that is what is measured, per neuron and
receptor, by running the original conductance network with learning off on the
``reference`` backend over calibration images (the module's own training images
when :meth:`~.plugin.ModularSNNPlugin.infer` deploys it) and recording ``v``,
``gsyn_exc`` and ``gsyn_inh``. It weights each voltage by how much input arrives
then, which a plain time average of ``v`` does not: lateral inhibition arrives while
another neuron fires, when this neuron is depolarised, and the input from the pixels
is strongest while the membrane climbs towards threshold. A neuron that received no
conductance on a receptor during calibration takes its population's weighted mean,
and a population that received none its ``v_rest``. The residual error is the
voltage dependence inside a presentation (the driving force varies by about
``v_thresh + theta - v_reset`` around ``V_ref``): near threshold, where it decides
a spike, the conductance network's excitatory drive is smaller and its inhibition
larger than at ``V_ref``, so the charge-matched approximation fires more (about 30%
more spikes on a small synthetic module). ``match_rate`` (default) therefore shifts
every ``V_ref`` by one offset, found by bisection, so that the approximation fires as
many spikes as the original on the calibration images with the same Poisson input;
the note names the shift. What remains changes spike timing and hence the
competition between neurons; the tests measure how often the predicted place
survives it.

Loihi's restrictions (``one_filter=True``, ``v_init_at_reset=True``). A Loihi
compartment has one synaptic filter: a population fed through both receptors with
``tau_syn_E != tau_syn_I`` (the excitatory layer: 1 ms and 0.5 ms) then takes
``tau_syn_E`` for both, and its inhibitory weights are multiplied by
``tau_syn_I / tau_syn_E`` so each spike injects the same charge (both time constants
are short against ``tau_m`` = 100 ms, so the membrane response is nearly the same).
NengoLoihi starts every voltage at ``v_reset``: the inhibitory layer (rest -60 mV,
reset -45 mV, threshold -40 mV) then starts 5 mV below threshold instead of 20 mV;
it has no input of its own and relaxes to rest with ``tau_m`` = 10 ms.
:func:`deployment_form` picks these only when the backend refuses the plain
approximation, and :func:`deployed_network`'s note says which it applied.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

import neurovpr as nv
from neurovpr.ir.connectivity import expand

from .network import INPUT

__all__ = [
    "FORMS",
    "ReferenceVoltages",
    "calibrate_reference_voltages",
    "to_current_based",
    "deployment_form",
    "deployed_network",
    "static_network",
]

_RECEPTOR_VARIABLE = {"excitatory": "gsyn_exc", "inhibitory": "gsyn_inh"}


@dataclass(frozen=True, slots=True, kw_only=True)
class ReferenceVoltages:
    """``V_ref`` (mV) per postsynaptic population and receptor, one value per neuron.

    Attributes
    ----------
    values
        ``{population: {"excitatory": array, "inhibitory": array}}``.
    source
        How they were obtained (one phrase, for notes).
    """

    values: Mapping[str, Mapping[str, np.ndarray]]
    source: str

    def __post_init__(self) -> None:
        for pop, receptors in self.values.items():
            for receptor, arr in receptors.items():
                if receptor not in _RECEPTOR_VARIABLE:
                    raise nv.ValidationError(f"reference voltage of {pop!r}: unknown receptor {receptor!r}.")
                a = np.asarray(arr, dtype=np.float64)
                if a.ndim != 1 or not np.all(np.isfinite(a)):
                    raise nv.ValidationError(f"reference voltage of {pop!r} ({receptor}) must be a finite 1-D array.")

    def get(self, population: str, receptor: str, size: int) -> np.ndarray:
        """The per-neuron ``V_ref`` of a population's receptor."""
        try:
            arr = np.asarray(self.values[population][receptor], dtype=np.float64)
        except KeyError:
            raise nv.ValidationError(f"no reference voltage for the {receptor} receptor of population {population!r}.") from None
        if arr.size != size:
            raise nv.ValidationError(f"reference voltage of {population!r} has {arr.size} values for {size} neurons.")
        return arr

    def summary(self) -> dict[str, dict[str, float]]:
        """Mean ``V_ref`` per population and receptor (mV), for notes."""
        return {p: {r: float(np.mean(v)) for r, v in rs.items()} for p, rs in self.values.items()}


def static_network(network: nv.Network) -> nv.Network:
    """``network`` with every plastic projection fixed at its current weights and delays (static synapses)."""
    out = network.copy()
    for proj in network.projections.values():
        if not isinstance(proj.synapse, nv.StaticSynapse):
            syn = proj.synapse
            out.replace_projection(proj.replace(synapse=nv.StaticSynapse(weight=syn.weight, delay=syn.delay)))
    return out


def _conductance_populations(network: nv.Network) -> list[str]:
    return [n for n, p in network.populations.items() if getattr(p.cell_type, "conductance_based", False)]


def calibrate_reference_voltages(
    network: nv.Network,
    images: np.ndarray,
    *,
    coding: Any,
    dt: float,
    seed: int,
    match_rate: bool = True,
) -> ReferenceVoltages:
    """Measure the conductance-weighted mean voltage of every neuron and receptor (see the module docstring).

    Parameters
    ----------
    network
        A trained module (conductance-based); it runs with learning off on ``reference``.
    images
        Calibration images, ``(N, ...)`` with ``n_input`` pixels each, 0..255.
    coding
        The :class:`~neurovpr.data.encoding.RateCoding` of the run (rates, presentation time).
    dt, seed
        Time step (ms) and compile seed.
    match_rate
        Then shift every ``V_ref`` by one offset, found by bisection, so that the
        approximation fires as many spikes on the calibration images (same Poisson
        input) as the original (see the module docstring).
    """
    flat = np.asarray(images).reshape(len(images), -1)
    if flat.shape[0] == 0:
        raise nv.ValidationError("reference-voltage calibration needs at least one image, got none.")
    pops = _conductance_populations(network)
    sim = nv.compile(static_network(network), backend="reference", dt=dt, seed=int(seed))
    for pop in pops:
        for var in ("v", *_RECEPTOR_VARIABLE.values()):
            sim.record(pop, var)
    sizes = {p: network.populations[p].size for p in pops}
    target = 0
    gv = {(p, r): np.zeros(sizes[p]) for p in pops for r in _RECEPTOR_VARIABLE}
    g = {(p, r): np.zeros(sizes[p]) for p in pops for r in _RECEPTOR_VARIABLE}
    for image in flat:
        sim.run(coding.presentation_ms, inputs={INPUT: coding.rates(image)})
        for p in pops:
            _, v = sim.trace(p, "v")
            for r, var in _RECEPTOR_VARIABLE.items():
                _, cond = sim.trace(p, var)
                gv[(p, r)] += np.sum(cond * v, axis=0)
                g[(p, r)] += np.sum(cond, axis=0)
            target += int(sim.spike_counts(p).sum())
        sim.reset()
    values: dict[str, dict[str, np.ndarray]] = {}
    for p in pops:
        rest = np.broadcast_to(np.asarray(network.populations[p].cell_type.v_rest, dtype=np.float64), (sizes[p],))
        values[p] = {}
        for r in _RECEPTOR_VARIABLE:
            total_g, total_gv = g[(p, r)], gv[(p, r)]
            fallback = total_gv.sum() / total_g.sum() if total_g.sum() > 0 else rest
            values[p][r] = np.where(total_g > 0, total_gv / np.where(total_g > 0, total_g, 1.0), fallback)
    charge = ReferenceVoltages(
        values=values, source=f"conductance-weighted mean voltage over {flat.shape[0]} image(s) on reference"
    )
    if not match_rate:
        return charge
    low, high = -_SHIFT_RANGE, _SHIFT_RANGE
    for _ in range(_SHIFT_STEPS):
        mid = 0.5 * (low + high)
        count = _spike_total(network, _shifted(network, charge, mid), flat, pops, coding=coding, dt=dt, seed=seed)
        low, high = (mid, high) if count > target else (low, mid)
    shift = 0.5 * (low + high)
    return ReferenceVoltages(
        values=_shifted(network, charge, shift).values,
        source=f"{charge.source}, shifted by {shift:+.2f} mV to match its {target} spikes",
    )


#: Range (mV) and bisection steps of the rate-matching shift of ``V_ref``.
_SHIFT_RANGE, _SHIFT_STEPS = 15.0, 8


def _shifted(network: nv.Network, v_ref: ReferenceVoltages, shift: float) -> ReferenceVoltages:
    """``V_ref + shift``, kept 0.5 mV inside the reversal potentials."""
    values: dict[str, dict[str, np.ndarray]] = {}
    for p, rs in v_ref.values.items():
        cell = network.populations[p].cell_type
        n = network.populations[p].size
        top = np.broadcast_to(np.asarray(cell.e_rev_E, dtype=np.float64), (n,)) - 0.5
        bottom = np.broadcast_to(np.asarray(cell.e_rev_I, dtype=np.float64), (n,)) + 0.5
        values[p] = {r: np.clip(np.asarray(v) + shift, bottom, top) for r, v in rs.items()}
    return ReferenceVoltages(values=values, source=v_ref.source)


def _spike_total(
    network: nv.Network, v_ref: ReferenceVoltages, images: np.ndarray, pops: list[str], *, coding: Any, dt: float, seed: int
) -> int:
    sim = nv.compile(to_current_based(network, v_ref, dt=dt, seed=seed), backend="reference", dt=dt, seed=int(seed))
    total = 0
    for image in images:
        sim.run(coding.presentation_ms, inputs={INPUT: coding.rates(image)})
        total += sum(int(sim.spike_counts(p).sum()) for p in pops)
        sim.reset()
    return total


def _receptors(network: nv.Network) -> dict[str, set[str]]:
    """Receptor types of the projections arriving at each population."""
    out: dict[str, set[str]] = {}
    for proj in network.projections.values():
        out.setdefault(proj.post, set()).add(proj.receptor_type)
    return out


def _current_cell(cell: Any, size: int) -> nv.IF_curr_exp:
    thresh = np.broadcast_to(np.asarray(cell.v_thresh, dtype=np.float64), (size,))
    refrac = cell.tau_refrac
    if isinstance(cell, nv.IF_cond_exp_adaptive):
        thresh = thresh + np.broadcast_to(np.asarray(cell.theta_init, dtype=np.float64), (size,))
        # no current-based target has a spike lockout apart from the clamp: the clamp covers the lockout
        refrac = np.maximum(np.asarray(cell.tau_refrac, dtype=np.float64), np.asarray(cell.tau_lockout, dtype=np.float64))
        refrac = float(refrac) if refrac.ndim == 0 else refrac
    uniform = bool(np.all(thresh == thresh[0]))
    return nv.IF_curr_exp(
        cm=cell.cm, tau_m=cell.tau_m, tau_refrac=refrac, tau_syn_E=cell.tau_syn_E, tau_syn_I=cell.tau_syn_I,
        v_rest=cell.v_rest, v_reset=cell.v_reset, v_thresh=float(thresh[0]) if uniform else thresh.copy(),
        i_offset=cell.i_offset,
    )  # fmt: skip


def _scalar(value: Any, what: str) -> float:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim and not np.all(arr == arr.ravel()[0]):
        raise nv.ValidationError(f"{what} differs between neurons; the current-based deployment needs one value.")
    return float(arr.ravel()[0])


def to_current_based(
    network: nv.Network,
    v_ref: ReferenceVoltages,
    *,
    dt: float,
    seed: int = 0,
    one_filter: bool = False,
    v_init_at_reset: bool = False,
    one_delay: bool = False,
    name: str | None = None,
) -> nv.Network:
    """The current-based approximation of a trained module (see the module docstring).

    Parameters
    ----------
    network
        The trained conductance-based module (plastic projections are fixed at their weights).
    v_ref
        Reference voltages per postsynaptic population and receptor.
    dt, seed
        Used to expand projections into their canonical connection lists (weights
        become one value per connection, scaled by the postsynaptic neuron's ``V_ref``);
        compile the result with the same ``seed`` when a connector is random.
    one_filter
        Give a population fed through both receptors one synaptic time constant
        (``tau_syn_E``), scaling inhibitory weights by ``tau_syn_I / tau_syn_E``.
    v_init_at_reset
        Start every neuron at ``v_reset`` (NengoLoihi's only initial state).
    one_delay
        Give every connection of a projection with several delays the projection's mean
        delay (on the ``dt`` grid): Loihi emulators spend one input axon per input and
        delay step, so the module's per-synapse input delays (U(0.5, 10) ms) exceed a
        core's input axons; with rate-coded Poisson input they only decorrelate arrivals.
    name
        Name of the new network (default: the original's with ``_current``).
    """
    src = static_network(network)
    out = nv.Network(name or f"{network.name}_current")
    inh_scale: dict[str, float] = {}
    receptors = _receptors(src)
    for pname, pop in src.populations.items():
        cell = pop.cell_type
        if pop.is_source:
            out.add_population(pname, pop.size, cell)
            continue
        if not isinstance(cell, (nv.IF_cond_exp, nv.IF_cond_exp_adaptive)):
            raise nv.ValidationError(
                f"population {pname!r} is {type(cell).__name__}; the current-based deployment converts IF_cond_exp and "
                "IF_cond_exp_adaptive only."
            )
        new = _current_cell(cell, pop.size)
        tau_e = _scalar(cell.tau_syn_E, f"tau_syn_E of {pname!r}")
        tau_i = _scalar(cell.tau_syn_I, f"tau_syn_I of {pname!r}")
        if one_filter and receptors.get(pname) == {"excitatory", "inhibitory"} and tau_e != tau_i:
            inh_scale[pname] = tau_i / tau_e
            new = new.replace(tau_syn_I=tau_e)
        v_init = pop.v_init
        if v_init_at_reset:
            v_init = cell.v_reset
        out.add_population(pname, pop.size, new, v_init=v_init)
    for proj in src.projections.values():
        post_pop = src.populations[proj.post]
        cell = post_pop.cell_type
        conns = expand(src, proj, dt=dt, seed=seed)
        ref = v_ref.get(proj.post, proj.receptor_type, post_pop.size)
        if proj.receptor_type == "excitatory":
            e_rev = np.broadcast_to(np.asarray(cell.e_rev_E, dtype=np.float64), (post_pop.size,))
            drive = e_rev - ref
        else:
            e_rev = np.broadcast_to(np.asarray(cell.e_rev_I, dtype=np.float64), (post_pop.size,))
            drive = ref - e_rev
        if np.any(drive <= 0):
            bad = int(np.flatnonzero(drive <= 0)[0])
            raise nv.ValidationError(
                f"reference voltage {ref[bad]:g} mV of neuron {bad} of {proj.post!r} lies beyond the {proj.receptor_type} "
                f"reversal potential {e_rev[bad]:g} mV, so its current-based weight would change sign."
            )
        weight = conns.weight * drive[conns.post]
        if proj.receptor_type == "inhibitory":
            weight = weight * inh_scale.get(proj.post, 1.0)
        delay = None if proj.synapse.delay is None else conns.delay
        if delay is not None and np.any(delay == 0):
            # zero-delay synapses (the module's E -> I -> E loop) take one step: the targets' synapses start there
            delay = float(dt) if np.all(delay == 0) else np.where(delay == 0, dt, delay)
        if one_delay and delay is not None and np.unique(delay).size > 1:
            delay = float(max(np.rint(float(np.mean(delay)) / dt), 1.0) * dt)
        out.connect(
            proj.pre, proj.post, proj.connector, nv.StaticSynapse(weight=weight, delay=delay),
            receptor_type=proj.receptor_type, name=proj.name,
        )  # fmt: skip
    return out


#: Deployment forms, in the order they are tried: the original network, its current-based
#: approximation, and the approximation with Loihi's restrictions (one filter, start at v_reset,
#: one delay per projection).
FORMS = ("original", "current", "current-one-filter")


def _placeholder_voltages(network: nv.Network) -> ReferenceVoltages:
    """``V_ref = v_rest`` everywhere: enough to build the structure a backend checks."""
    values = {
        p: {
            r: np.broadcast_to(np.asarray(pop.cell_type.v_rest, dtype=np.float64), (pop.size,)).copy() for r in _RECEPTOR_VARIABLE
        }
        for p, pop in network.populations.items()
        if not pop.is_source
    }
    return ReferenceVoltages(values=values, source="resting potentials")


def _build(network: nv.Network, form: str, v_ref: ReferenceVoltages, dt: float, seed: int) -> nv.Network:
    if form == "current":
        return to_current_based(network, v_ref, dt=dt, seed=seed)
    return to_current_based(network, v_ref, dt=dt, seed=seed, one_filter=True, v_init_at_reset=True, one_delay=True)


def deployment_form(network: nv.Network, backend: str, *, dt: float, current_based: bool = False) -> str:
    """Which of :data:`FORMS` ``backend`` runs for the trained module (the first it accepts).

    ``"original"`` when the backend runs the module itself (learning off, or the plastic
    projections made static when it does not learn); otherwise the current-based
    approximation, plain or with Loihi's restrictions (see the module docstring).
    ``current_based=True`` skips the original (to run the approximation on a backend
    that could run the original, e.g. to measure it on ``reference``).

    Raises
    ------
    UnsupportedFeatureError
        When the backend refuses every form (naming its first problem with the original).
    """
    chosen = nv.get_backend(backend)
    original = network if chosen.capabilities.learns else static_network(network)
    if not current_based and not chosen.unsupported_features(original):
        return "original"
    convertible = (nv.IF_cond_exp, nv.IF_cond_exp_adaptive)
    if all(p.is_source or isinstance(p.cell_type, convertible) for p in network.populations.values()):
        placeholder = _placeholder_voltages(network)
        for form in FORMS[1:]:
            if not chosen.unsupported_features(_build(network, form, placeholder, dt, 0)):
                return form
    chosen.check_network(original)
    raise AssertionError("unreachable: check_network accepted a network unsupported_features refused")


def deployed_network(
    network: nv.Network,
    form: str,
    calibration: np.ndarray,
    *,
    coding: Any,
    dt: float,
    seed: int,
) -> tuple[nv.Network, str | None]:
    """The network of ``form`` (from :func:`deployment_form`) and the note that says what it is.

    ``"original"`` returns ``network`` with plastic projections made static and no note;
    the current-based forms calibrate ``V_ref`` on ``calibration`` images
    (:func:`calibrate_reference_voltages`) and convert (:func:`to_current_based`).
    """
    if form not in FORMS:
        raise nv.ValidationError(f"deployment form is {form!r}, expected one of {', '.join(FORMS)}.")
    if form == "original":
        return static_network(network), None
    v_ref = calibrate_reference_voltages(network, calibration, coding=coding, dt=dt, seed=seed)
    means = ", ".join(f"{p} {r} {v:.1f} mV" for p, rs in v_ref.summary().items() for r, v in rs.items())
    note = (
        "deployed as the current-based approximation: IF_curr_exp with v_thresh + learned theta per neuron, conductance "
        f"weights times (E_rev - V_ref), V_ref per neuron and receptor the {v_ref.source} (means: {means})"
    )
    zero = [proj.name for proj in network.projections.values() if proj.zero_delay]
    if zero:
        note += f"; zero-delay projections ({', '.join(zero)}) delayed by one step ({dt:g} ms)"
    if form == "current-one-filter":
        both = {p for p in network.populations if {"excitatory", "inhibitory"} <= _receptors(network).get(p, set())}
        parts = []
        for p in sorted(both):
            cell = network.populations[p].cell_type
            if _scalar(cell.tau_syn_E, "tau_syn_E") != _scalar(cell.tau_syn_I, "tau_syn_I"):
                parts.append(
                    f"{p} tau_syn_I {_scalar(cell.tau_syn_I, 'tau_syn_I'):g} -> {_scalar(cell.tau_syn_E, 'tau_syn_E'):g} ms"
                )
        note += (
            "; one synaptic filter per neuron (" + ", ".join(parts) + ", inhibitory weights scaled to the same charge) "
            "and voltages starting at v_reset, and each projection's mean delay for all its connections, as the "
            "backend requires"
        )
    return _build(network, form, v_ref, dt, seed), note
