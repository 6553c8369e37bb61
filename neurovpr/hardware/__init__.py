"""Hardware targets: specifications, fit checking, energy estimates.

* :func:`load_hwspec` / :func:`known_hwspecs` read ``hwspecs/<name>.toml``.
* :func:`check_network` partitions a network with the rules of the architecture the
  hwspec names (NengoLoihi for Loihi, sPyNNaker and PACMAN for SpiNNaker; architectures
  are found through the ``neurovpr.architectures`` entry point, :mod:`.architectures`) and
  reports per-core use and every broken limit; :func:`hardware_target` is what
  ``nv.compile(..., hardware=NAME)`` calls: one partition, at the compile's dt and seed,
  for the verdict, the emulation and the energy.
* :func:`estimate_energy` turns the activity of a run (``activity.json``, written by
  :func:`write_activity`) into joules per inference.
"""

from .architectures import Architecture, get_architecture, known_architectures
from .check import CheckReport, HardwareTarget, check_network, hardware_target
from .cores import CoreSlice, Partition, Violation
from .energy import CpuEnergyMeter, EnergyReport, estimate_energy, rapl_status, read_activity, write_activity
from .hwspec import HwSpec, known_hwspecs, load_hwspec
from .partition import partition

__all__ = [
    "Architecture",
    "CheckReport",
    "CoreSlice",
    "CpuEnergyMeter",
    "EnergyReport",
    "HardwareTarget",
    "HwSpec",
    "Partition",
    "Violation",
    "check_network",
    "estimate_energy",
    "get_architecture",
    "hardware_target",
    "known_architectures",
    "known_hwspecs",
    "load_hwspec",
    "partition",
    "rapl_status",
    "read_activity",
    "write_activity",
]
