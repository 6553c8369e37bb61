"""Mushroom-body SNN (Zhu, Mangan & Webb, Science Robotics 2023): route familiarity from event-camera spikes.

* :mod:`.network` - the graph (PNs -> two-compartment Kenyon cells with plastic
  axo-axonic inhibition -> one MBON), its parameters and their sources;
* :mod:`.model` - learning and test phases on any backend, MBON rates, familiarity;
* :mod:`.training`, :mod:`.evaluation` - run directories, AUC-ROC against the SeqSLAM
  and Perfect Memory baselines, figures (:mod:`.plots`);
* :mod:`.plugin` - ``MODEL``, the ``neurovpr train/eval --model mbsnn`` integration.
"""

from .model import (
    MBONResponse,
    check_recording,
    compile_mbsnn,
    familiarity,
    naive_weights,
    present,
    segment_labels,
    window_rates,
)
from .network import (
    KC_KC,
    POPULATIONS,
    MBSNNParameters,
    build_network,
    kc_kc_connections,
    paper_neuron_count,
    pn_kc_connections,
)
from .plugin import MODEL, MBSNNPlugin

__all__ = [
    "KC_KC",
    "MBONResponse",
    "MBSNNParameters",
    "MBSNNPlugin",
    "MODEL",
    "POPULATIONS",
    "build_network",
    "check_recording",
    "compile_mbsnn",
    "familiarity",
    "kc_kc_connections",
    "naive_weights",
    "paper_neuron_count",
    "pn_kc_connections",
    "present",
    "segment_labels",
    "window_rates",
]
