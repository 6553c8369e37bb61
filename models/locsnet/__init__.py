"""LoCS-Net: a localizing convolutional spiking network for visual place recognition.

Akcal et al., Frontiers in Neurorobotics 2025. Places are classes; a 56x56 grayscale
image passes three convolutional LIF layers and a dense place layer; the network is
trained through the SoftLIF rate approximation, with torch or with NengoDL as the paper
did, and run as a spiking network on any neurovpr backend.

- :mod:`.architecture` -- layer sizes and neuron parameters, as data (JSON)
- :mod:`.preprocess` -- 56x56 grayscale, patch-normalised input in [0, 1]
- :mod:`.places` -- place labels: frame groups, grid tiles, ground truth per place
- :mod:`.torchnet` -- SoftLIF and the torch network (needs torch)
- :mod:`.training` -- training, quantisation-aware training, calibration (needs torch)
- :mod:`.nengo_training` -- training with NengoDL (``--trainer nengo-dl``; needs the ``nengo-dl`` backend)
- :mod:`.quantise` -- a chip's weight format from its hwspec
- :mod:`.conversion` -- trained weights to a spiking neurovpr network and back
- :mod:`.inference` -- the rate model in numpy and the spiking classifier
- :mod:`.runs` -- run directories (network.h5, architecture.json, run.json)
- :mod:`.report` -- metrics, baselines and plots of an evaluation
- :mod:`.plugin` -- ``neurovpr train/eval --model locsnet``; :data:`MODEL` is its entry point

torch is imported only by :mod:`.torchnet` and :mod:`.training`, NengoDL and TensorFlow only by
:mod:`.nengo_training` (through the ``nengo-dl`` backend found by the registry).
"""

from .architecture import Architecture, ConvSpec, paper_architecture, small_architecture
from .conversion import SpikingParameters, to_spiking_network, trained_parameters
from .inference import QueryResult, SpikingClassifier, lif_rate, rate_forward, softlif_rate
from .places import PlaceLabels, frame_labels, grid_labels, place_ground_truth
from .plugin import MODEL, LoCSNetPlugin

__all__ = [
    "MODEL",
    "Architecture",
    "ConvSpec",
    "LoCSNetPlugin",
    "PlaceLabels",
    "QueryResult",
    "SpikingClassifier",
    "SpikingParameters",
    "frame_labels",
    "grid_labels",
    "lif_rate",
    "paper_architecture",
    "place_ground_truth",
    "rate_forward",
    "small_architecture",
    "softlif_rate",
    "to_spiking_network",
    "trained_parameters",
]
