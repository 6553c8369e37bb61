"""Non-spiking baselines of the papers, each returning a ``[reference, query]`` distance matrix.

- :mod:`.sad` -- sum of absolute differences on the Modular SNN's 28x28 patch-normalised
  images (Hussaini et al. 2024's baseline).
- :mod:`.perfect_memory` -- Perfect Memory: sum of squared differences to every stored
  reference image, best match = minimum (Zhu et al. 2023's baseline).
"""

from neurovpr.models.baselines.perfect_memory import perfect_memory_distances
from neurovpr.models.baselines.sad import baseline_inputs, sad_distances

__all__ = ["baseline_inputs", "perfect_memory_distances", "sad_distances"]
