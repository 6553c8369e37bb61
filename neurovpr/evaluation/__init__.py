"""Evaluation: metrics, sequence matching and plots, on ``[reference, query]`` distance matrices.

- :mod:`~neurovpr.evaluation.metrics` -- Recall@N, precision-recall, ROC, correct-match sparsity
- :mod:`~neurovpr.evaluation.concentration` -- how concentrated the best matches are
- :mod:`~neurovpr.evaluation.sequence` -- identity-kernel sequence matching and SeqSLAM
- :mod:`~neurovpr.evaluation.plots` -- PNG figures

Names are imported on first use, so ``import neurovpr.evaluation`` does not load scikit-learn.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "recall_at_n": "neurovpr.evaluation.metrics",
    "precision_recall": "neurovpr.evaluation.metrics",
    "evaluate": "neurovpr.evaluation.metrics",
    "distance_from_similarity": "neurovpr.evaluation.metrics",
    "auc_roc": "neurovpr.evaluation.metrics",
    "roc": "neurovpr.evaluation.metrics",
    "correct_match_sparsity": "neurovpr.evaluation.metrics",
    "match_concentration": "neurovpr.evaluation.concentration",
    "most_chosen": "neurovpr.evaluation.concentration",
    "identity_kernel": "neurovpr.evaluation.sequence",
    "seqslam": "neurovpr.evaluation.sequence",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'neurovpr.evaluation' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
