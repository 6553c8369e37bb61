"""Numerical tolerances of the conformance suite, per case, and a backend's declared overrides.

The defaults are those of the exact-integration reference backend: spike times and
exactly integrable traces agree with the analytic answer to floating-point
round-off. A backend whose simulator legitimately integrates differently (another
ODE scheme, a fixed-point number format) declares looser bounds in its capabilities:
``Capabilities(tolerances={case_id: ToleranceOverride(changes={...}, reason="...")})``.
A test (``test_declarations.py``) checks that every override names a known case and
bound, has a reason and only loosens the bound.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from neurovpr.runtime.backend import Capabilities

__all__ = ["Tolerances", "DEFAULT", "tolerances_for"]


@dataclass(frozen=True, slots=True, kw_only=True)
class Tolerances:
    """Bounds a backend's results must meet.

    Attributes
    ----------
    spike_time_ms
        Largest difference (ms) between a spike time and its analytic grid time.
    trace_rel
        Largest deviation of an exactly integrable recorded trace (current-based
        PSP, I_ca2, theta) from its closed form, relative to the trace's peak.
    cond_trace_rel
        Largest deviation of the conductance-based PSP from a high-precision ODE
        solution, relative to the PSP peak. The semantics' exponential-Euler step
        on the mean conductance errs by about ``(dt / tau_syn)**2 / 48`` of the peak
        (8.3e-6 for dt = 0.1 ms, tau_syn = 5 ms); the bound leaves a margin of 12.
    weight_rel
        Largest deviation of a learned weight from the formula, relative to the
        expected weight change.
    """

    spike_time_ms: float = 1e-9
    trace_rel: float = 1e-9
    cond_trace_rel: float = 1e-4
    weight_rel: float = 1e-9


#: The reference backend's bounds; every backend meets them unless it declares looser ones.
DEFAULT = Tolerances()


def tolerances_for(capabilities: Capabilities, case: str) -> Tolerances:
    """The bounds a backend with ``capabilities`` must meet in ``case``."""
    override = capabilities.tolerances.get(case)
    if override is None:
        return DEFAULT
    return dataclasses.replace(DEFAULT, **dict(override.changes))
