"""The papers' models and the non-spiking baselines, installed as ``neurovpr.models.<name>``.

``get(name)`` gives an installed model's plugin (found by its entry point), ``names()``
their names::

    from neurovpr import models
    models.get("mbsnn").train(data="route.aedat4", out="runs/mb", learn="0.4:0.6")
"""

from neurovpr.apps.modelapi import get_model as get
from neurovpr.apps.modelapi import model_names as names

__all__ = ["get", "names"]
