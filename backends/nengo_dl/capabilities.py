"""What the ``nengo-dl`` backend can run: what the ``nengo`` backend runs, for the same reasons.

NengoDL simulates the Nengo network the ``nengo`` backend builds, and its LIF step is
Nengo's (the threshold crossing interpolated inside the step, the refractory period
started there), so the inference subset, the refusals and the one conformance case the
``nengo`` backend cannot pass are the same.
"""

from __future__ import annotations

import dataclasses
from types import MappingProxyType

from neurovpr.backends.nengo.capabilities import NENGO_CAPABILITIES

__all__ = ["NENGO_DL_CAPABILITIES"]

#: Conformance cases (neurovpr.conformance) the ``nengo-dl`` backend cannot pass, with the reason.
_UNSUPPORTED = {
    "lif_rate_curr": (
        "NengoDL's LIF, like Nengo's, places a spike inside its step (linear interpolation of the threshold "
        "crossing) and starts the refractory period there, so it fires at the continuous-time LIF rate, not on "
        "the step grid this case checks"
    ),
}

NENGO_DL_CAPABILITIES = dataclasses.replace(NENGO_CAPABILITIES, unsupported=MappingProxyType(_UNSUPPORTED))
