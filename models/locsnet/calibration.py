"""Calibrating the place layer: how strongly it is driven, and how many places fire.

Training with ``place_loss="current"`` fixes the order of the places for each image but
not how far above threshold the place neurons are driven. :func:`calibrate_places`
scales and shifts the place weights, ``W' = a W + delta`` with ``a > 0``: every place of
an image gets the same extra input ``delta * sum(conv3 activation)``, so each image's
order of places is unchanged, and the shift arrives with the input spikes (a bias
would drive every place neuron before any input arrives). ``a`` and ``delta`` send the
mean of each image's largest input ``J`` to ``drive`` and the mean of its
``active``-th largest to the threshold 1.

The conv3 activations come either from the rate model (right after training) or from
the spiking network itself (:func:`calibrate_spiking`): the spike counts of the third
convolutional layer within the presentation window, on some training images. The
latter accounts for what the rate model cannot see: the layers' latency within a short
window and the time-step discretisation.
"""

from __future__ import annotations

import numpy as np

from neurovpr.errors import ValidationError

from .architecture import Architecture
from .conversion import SpikingParameters, to_spiking_network

__all__ = ["calibrate_places", "calibrate_spiking"]


def calibrate_places(
    params: dict[str, np.ndarray], currents: np.ndarray, drive_sums: np.ndarray, *, drive: float, active: int
) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """Scale and shift the place layer's input so the best place gets ``drive`` and ``active`` places fire.

    ``currents`` are the place inputs ``J`` (N, n_places) on the training images and
    ``drive_sums`` the summed activation of the third convolutional layer per image
    (N,). The new weights are ``a W + delta`` (``a > 0``): every place of an image gets
    the same extra input ``delta * drive_sum``, so each image's order of places is
    unchanged, and the shift arrives with the input spikes (a bias would drive the
    place neurons before any input arrives). ``a`` and ``delta`` send the mean of each
    image's largest ``J`` to ``drive`` and the mean of its ``active``-th largest to the
    threshold 1.
    """
    j = np.asarray(currents, dtype=np.float64)
    k = min(int(active), j.shape[1]) - 1
    ordered = -np.sort(-j, axis=1)
    top, kth = float(ordered[:, 0].mean()), float(ordered[:, k].mean())
    mean_sum = float(np.mean(drive_sums))
    a = (drive - 1.0) / (top - kth) if top - kth > 1e-9 else 1.0
    delta = (1.0 - a * kth) / mean_sum if mean_sum > 1e-12 else 0.0
    out = {name: np.array(v, dtype=np.float64) for name, v in params.items()}
    out["places.weight"] = a * out["places.weight"] + delta
    if "places.bias" in out:
        out["places.bias"] = a * out["places.bias"]
    return out, {"scale": a, "shift_per_activation": delta, "mean_top_current": top, "mean_kth_current": kth,
                 "mean_drive_sum": mean_sum}


def calibrate_spiking(
    arch: Architecture,
    params: dict[str, np.ndarray],
    spiking: SpikingParameters,
    images: np.ndarray,
    *,
    drive: float,
    active: int,
    seed: int = 0,
    progress: bool = False,
) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """:func:`calibrate_places` on the conv3 spike counts of the spiking network (reference backend).

    ``images`` (N, H, W) in [0, 1] are training images; each is presented for
    ``spiking.presentation`` ms and conv3's spike counts, as activations
    ``amplitude * count / presentation``, give the place inputs.
    """
    from .inference import SpikingClassifier, check_images

    imgs = check_images(arch, images, what="calibration images")
    clf = SpikingClassifier(to_spiking_network(arch, params, spiking), arch, spiking, seed=seed)
    acts = np.zeros((imgs.shape[0], arch.n_features))
    indices = range(imgs.shape[0])
    if progress:
        from tqdm.auto import tqdm

        indices = tqdm(indices, desc="calibrating the place layer", unit="image", leave=False)
    for i in indices:
        clf.sim.reset()
        clf.sim.run(spiking.presentation, inputs=clf._inputs(imgs[i]))
        acts[i] = clf.layer_counts("conv3") * (float(arch.neuron.amplitude) / spiking.presentation)
    if not acts.any():
        raise ValidationError(
            f"the third convolutional layer fired no spike in {spiking.presentation:g} ms on any of the "
            f"{imgs.shape[0]} calibration images; lengthen the presentation or raise the input rate."
        )
    currents = acts @ np.asarray(params["places.weight"], dtype=np.float64).T
    if "places.bias" in params:
        currents = currents + np.asarray(params["places.bias"])[None, :]
    out, info = calibrate_places(params, currents, acts.sum(axis=1), drive=drive, active=active)
    info["images"] = float(imgs.shape[0])
    return out, info
