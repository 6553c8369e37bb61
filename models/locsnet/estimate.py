"""LoCS-Net's memory and work, estimated from the training options before any data is read.

The data decides only the number of places; the estimate takes the smallest (two),
so what it refuses is past the limit whatever the data.
"""

from __future__ import annotations

import math

from neurovpr.resources import ACTIVITY, STEP_COST, require_memory, require_work

from .architecture import Architecture
from .conversion import SpikingParameters

__all__ = ["check_resources"]

#: Bytes per layer unit and image in a training batch: float32 activation, pre-activation,
#: their gradients in the backward pass (a generous upper bound).
_TRAIN_BYTES_PER_UNIT = 16.0


def check_resources(
    arch: Architecture, *, batch_size: int, spiking: SpikingParameters, calibration_images: int, what: str = "train"
) -> None:
    """Refuse options whose training batches or spiking calibration are past the memory or work limit.

    Parameters
    ----------
    arch
        The architecture (with the smallest number of places when the data is not read yet).
    batch_size
        Images per training batch.
    spiking
        Time step and presentation of the spiking calibration.
    calibration_images
        Images the spiking calibration presents (0: none).

    Raises
    ------
    neurovpr.resources.ResourceLimitError
        One sentence naming the options, the estimate and the limit.
    """
    units = sum(arch.layer_sizes().values())
    require_memory(
        _TRAIN_BYTES_PER_UNIT * batch_size * units,
        f"{what}: LoCS-Net training batches of {batch_size} images (--batch-size) through {units} layer units",
    )
    if calibration_images > 0:
        steps = math.ceil(spiking.presentation / spiking.dt)
        per_step = STEP_COST + units + arch.n_synapses() * ACTIVITY
        require_work(
            float(calibration_images) * steps * per_step,
            f"{what}: LoCS-Net's spiking calibration on {calibration_images} images (--calibration-images) of "
            f"{steps} steps each (--presentation {spiking.presentation:g} ms / --dt {spiking.dt:g} ms)",
        )
