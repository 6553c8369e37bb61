"""LoCS-Net on a backend that cannot hold its leaky neurons: the integrate-and-fire form.

The converted LoCS-Net (:func:`~.conversion.to_spiking_network`) has leaky ``IF_curr_exp``
neurons (``tau_m`` = SoftLIF's ``tau_rc``) and, with ``feature_groups`` > 1, its third
convolution split into several populations, each feeding the place layer. A chip whose
neurons do not leak and whose layers take one input each (SynSense Speck / DYNAP-CNN,
the ``speck`` backend) refuses that network. :func:`deployed_classifier` then deploys its
*integrate-and-fire form*: the same trained weights and biases, ``tau_m = nv.NO_LEAK``
and the third convolution as one population. For inputs well above threshold a leaky
neuron's rate approaches ``I / (cm (v_thresh - v_rest))``, the non-leaky neuron's rate at
every input, so the form keeps the network's strong responses and adds firing below the
leaky neuron's rheobase. It is what the chip computes, not the network that was trained:
the difference is what ``neurovpr compare`` measures, and the row's notes say so. A backend
that refuses both forms gets the refusal of the trained network, which names its limit.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import neurovpr as nv
from neurovpr.errors import UnsupportedFeatureError

from .conversion import to_spiking_network, trained_parameters
from .inference import SpikingClassifier

__all__ = ["integrate_and_fire_form", "deployed_classifier"]


def integrate_and_fire_form(network: nv.Network, arch: Any, spiking: Any) -> tuple[nv.Network, Any]:
    """The trained network with non-leaky neurons and one ``conv3`` population; and its spiking parameters."""
    single = dataclasses.replace(spiking, feature_groups=1)
    form = to_spiking_network(arch, trained_parameters(network, arch, spiking), single, name=network.name)
    for pop in list(form.populations.values()):
        if isinstance(pop.cell_type, nv.IF_curr_exp):
            form.replace_population(pop.replace(cell_type=pop.cell_type.replace(tau_m=nv.NO_LEAK)))
    return form, single


def deployed_classifier(run: Any, backend: str, *, seed: int = 0) -> tuple[SpikingClassifier, list[str]]:
    """A classifier of the trained ``run`` on ``backend``, and notes on how it was deployed there.

    The trained network when ``backend`` compiles it; else its integrate-and-fire form
    (:func:`integrate_and_fire_form`) when ``backend`` compiles that; else the trained
    network's :class:`~neurovpr.errors.UnsupportedFeatureError`.
    """
    try:
        return SpikingClassifier(run.network, run.arch, run.spiking, backend=backend, seed=seed), []
    except UnsupportedFeatureError as exc:
        refused = exc
    form, spiking = integrate_and_fire_form(run.network, run.arch, run.spiking)
    try:
        clf = SpikingClassifier(form, run.arch, spiking, backend=backend, seed=seed)
    except UnsupportedFeatureError:
        raise refused from None
    note = (
        f"{backend} cannot run the trained network ({str(refused).rstrip('.')}); it runs its integrate-and-fire form: the same "
        f"weights, tau_m {float(run.arch.neuron.tau_rc):g} ms dropped (no leak) and conv3 as one population"
    )
    return clf, [note]
