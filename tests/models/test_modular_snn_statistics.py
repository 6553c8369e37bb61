"""Regression bounds on the per-image statistics that broke in the Modular SNN.

One module at the authors' code's parameters (400 neurons, 784 inputs, 350 ms images,
0.1 ms step, 5 ms clamp and 50 ms spike lockout) trained one epoch on four synthetic
places, then shown six reference images with learning off. Measured on this machine:
1.05 spikes per neuron per image (the authors' code: 0.56 on nordland64 while learning),
at most 6 spikes of one neuron on one image, at most 24 % of the neurons assigned to one
place, 2 % of the neurons firing for every reference image. Two earlier states of the
model fail these bounds: no lockout at 0.5 ms (one neuron fired 31 times for one image)
and the lockout at 0.5 ms (the E->I->E loop closes in 1 ms instead of 0.2 ms, every neuron
fires 7 times for every image, all of them on one place).
"""

from __future__ import annotations

import numpy as np
import pytest

from neurovpr.data.synthetic import synthetic_traverse
from neurovpr.models.modular_snn import TrainingSettings, assign_neurons, train_module


@pytest.fixture(scope="module")
def trained() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    reference = synthetic_traverse(6, seed=2).reference.preprocessed(progress=False)
    places = np.arange(4)
    settings = TrainingSettings(epochs=1, module_size=4, assignment_presentations=4)
    _, own, responses, _ = train_module(reference, places, settings, seed=1)
    return own, responses, assign_neurons(own, places)


def test_spikes_per_neuron_per_image(trained: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    own, responses, _ = trained
    # the 50 ms lockout allows at most ceil(350 / 50) = 7 spikes of one neuron in one 350 ms image
    assert responses.max() <= 7 and own.max() <= 7
    assert 0.2 <= responses.mean() <= 2.5, responses.mean()


def test_largest_share_of_a_module_on_one_place(trained: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    _, _, assignments = trained
    share = np.bincount(assignments[assignments >= 0], minlength=4).max() / assignments.size
    assert share <= 0.5, share
    assert np.count_nonzero(np.bincount(assignments[assignments >= 0], minlength=4)) == 4  # every place has neurons


def test_hyperactive_fraction(trained: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    _, responses, _ = trained
    fired_for_all = np.mean(np.count_nonzero(responses, axis=0) == responses.shape[0])
    assert fired_for_all <= 0.2, fired_for_all


def test_the_inhibition_loop_has_no_delay_as_in_the_authors_code() -> None:
    """E->I and I->E are zero-delay synapses (Brian2's on_pre without delay); one step each is an option."""
    from neurovpr.models.modular_snn import ModuleParameters, build_module

    net = build_module(ModuleParameters(n_neurons=4))
    assert net.projections["exc->inh"].synapse.delay == 0.0 and net.projections["lateral"].synapse.delay == 0.0
    stepped = build_module(ModuleParameters(n_neurons=4, delay_recurrent=0.1))
    assert not any(p.zero_delay for p in stepped.projections.values())


def test_euler_conductances_decay_by_the_codes_factor_per_step() -> None:
    """With ``euler_conductances`` a conductance falls by exactly ``1 - dt / tau`` per step (Brian2's Euler step in the code)."""
    import neurovpr as nv
    from neurovpr.models.modular_snn import ModuleParameters, build_module

    dt = 0.1
    params = ModuleParameters(n_input=1, n_neurons=1, euler_conductances=True, delay_min=0.1, delay_max=0.2)
    net = build_module(params, seed=3, name="euler", dt=dt)
    cell = net.populations["exc"].cell_type
    assert np.exp(-dt / cell.tau_syn_E) == pytest.approx(1 - dt / params.tau_ge, rel=1e-12)
    assert np.exp(-dt / cell.tau_syn_I) == pytest.approx(1 - dt / params.tau_gi, rel=1e-12)
    sim = nv.compile(net, backend="reference", dt=dt, seed=0)
    sim.plasticity(False)
    sim.record("exc", "gsyn_exc")
    sim.run(30.0, inputs={"pixels": 300.0})
    g = sim.trace("exc", "gsyn_exc")[1][:, 0]
    ratio = g[1:][g[:-1] > 0] / g[:-1][g[:-1] > 0]
    # a step without an arrival decays by 0.9 exactly; one with an arrival ends higher
    assert ratio.size > 50 and ratio.min() == pytest.approx(1 - dt / params.tau_ge, rel=1e-12)
    assert np.count_nonzero(np.isclose(ratio, 0.9, rtol=1e-12, atol=0)) > 0.5 * ratio.size
    with pytest.raises(nv.ValidationError, match="euler_conductances needs the time step"):
        build_module(params)
    with pytest.raises(nv.ValidationError, match=r"tau_gi = 0\.5 ms with euler_conductances needs a time step below it"):
        build_module(params, dt=0.5)
    exact = build_module(ModuleParameters(n_input=1, n_neurons=1)).populations["exc"].cell_type
    assert exact.tau_syn_E == params.tau_ge and exact.tau_syn_I == params.tau_gi


def test_settings_of_runs_saved_before_euler_conductances_are_unchanged() -> None:
    """The switch is written only when on, so earlier runs keep their fingerprints (resume, evaluation)."""
    from neurovpr.models.modular_snn import ModuleParameters, TrainingSettings

    plain = TrainingSettings().as_dict()
    assert "euler_conductances" not in plain["params"]
    assert TrainingSettings.from_dict(plain) == TrainingSettings()
    on = TrainingSettings(params=ModuleParameters(euler_conductances=True))
    assert on.as_dict()["params"]["euler_conductances"] is True
    assert TrainingSettings.from_dict(on.as_dict()) == on
