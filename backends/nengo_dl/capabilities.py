"""What the ``nengo-dl`` backend can run: what the ``nengo`` backend runs, for the same reasons.

NengoDL simulates the Nengo network the ``nengo`` backend builds, and its LIF step is
Nengo's (the threshold crossing interpolated inside the step, the refractory period
started there), so the inference subset, the refusals, the tolerances and the conformance
cases the ``nengo`` backend cannot pass are the same; each unsupported case keeps the
``nengo`` backend's reason.
"""

from __future__ import annotations

import dataclasses
from types import MappingProxyType

from neurovpr.backends.nengo.capabilities import NENGO_CAPABILITIES

__all__ = ["NENGO_DL_CAPABILITIES"]

NENGO_DL_CAPABILITIES = dataclasses.replace(
    NENGO_CAPABILITIES,
    unsupported=MappingProxyType(
        {
            case: f"NengoDL runs the nengo backend's network with Nengo's LIF step, so as there: {reason}"
            for case, reason in NENGO_CAPABILITIES.unsupported.items()
        }
    ),
)
