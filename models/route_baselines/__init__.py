"""Frame-based route-familiarity baselines of the mushroom-body paper (Zhu, Mangan, Webb 2023).

Both take the frames of a learned route segment and test frames, and return one
familiarity score per test frame (higher = more familiar):

* :func:`perfect_memory_familiarity` - minimum sum of squared differences to every
  learned frame;
* :func:`seqslam_familiarity` - SeqSLAM's sequence matching;

both with contrast enhancement (patch normalisation) and second-minimum normalisation
(see :mod:`neurovpr.models.route_baselines.normalisation`). Frames can be camera frames
or frames built from events or PN spikes (:func:`neurovpr.data.events.pn_frames`,
:func:`neurovpr.data.events.event_frames`).
"""

from .normalisation import (
    enhance_local_contrast,
    patch_normalise,
    second_min_familiarity,
)
from .perfect_memory import perfect_memory_familiarity, sum_squared_differences
from .seqslam import (
    seqslam_familiarity,
    sequence_scores,
    sum_absolute_differences,
)

__all__ = [
    "enhance_local_contrast",
    "patch_normalise",
    "perfect_memory_familiarity",
    "second_min_familiarity",
    "seqslam_familiarity",
    "sequence_scores",
    "sum_absolute_differences",
    "sum_squared_differences",
]
