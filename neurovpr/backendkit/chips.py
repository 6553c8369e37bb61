"""The fit of a network on the chip a backend stands for (``xylo``, ``speck``).

Such a backend runs only what fits its chip, whether or not ``hardware=`` was given: without
it, the network is partitioned onto the backend's own hwspec first, with the compile's ``dt``
and ``seed``. A network that does not fit is refused as an unsupported feature (one sentence
with the first broken limit), so that ``neurovpr compare`` reports the backend as a refused
row, as it does for any feature a backend lacks.
"""

from __future__ import annotations

from neurovpr.errors import UnsupportedFeatureError, ValidationError
from neurovpr.hardware.check import HardwareTarget, hardware_target
from neurovpr.ir.network import Network

__all__ = ["chip_target"]


def chip_target(
    network: Network, backend: str, hwspec: str, hardware: HardwareTarget | None, *, dt: float, seed: int
) -> HardwareTarget:
    """``hardware`` when given, else the fit of ``network`` on ``hwspec``; a misfit raises.

    Raises
    ------
    UnsupportedFeatureError
        If the network does not fit ``hwspec`` (naming the backend, the number of broken
        limits and the first of them).
    """
    if hardware is not None:
        return hardware
    try:
        return hardware_target(network, hwspec, dt=dt, seed=seed)
    except ValidationError as exc:
        raise UnsupportedFeatureError(f"Backend {backend!r} cannot run it: {exc}") from exc
