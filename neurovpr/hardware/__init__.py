"""Hardware targets: specifications, fit checking, energy estimates.

* :func:`load_hwspec` / :func:`known_hwspecs` read ``hwspecs/<name>.toml``.
* :func:`check_network` partitions a network with the target vendor's own rules
  (NengoLoihi for Loihi, sPyNNaker and PACMAN for SpiNNaker) and reports per-core use
  and every broken limit; :func:`hwspec_for_compile` is what ``nv.compile(...,
  hardware=NAME)`` calls.
* :func:`estimate_energy` turns the activity of a run (``activity.json``, written by
  :func:`write_activity`) into joules per inference.
"""

from .check import CheckReport, check_network, hwspec_for_compile
from .energy import CpuEnergyMeter, EnergyReport, estimate_energy, rapl_status, read_activity, write_activity
from .hwspec import HwSpec, known_hwspecs, load_hwspec
from .partition import CoreSlice, Partition, Violation, partition

__all__ = [
    "CheckReport",
    "CoreSlice",
    "CpuEnergyMeter",
    "EnergyReport",
    "HwSpec",
    "Partition",
    "Violation",
    "check_network",
    "estimate_energy",
    "hwspec_for_compile",
    "known_hwspecs",
    "load_hwspec",
    "partition",
    "rapl_status",
    "read_activity",
    "write_activity",
]
