"""Exception types raised by neurovpr.

Every error a user can cause is a single sentence naming the object, the offending
value and the limit it broke, so the command line can print it on one line.
"""

from __future__ import annotations

__all__ = [
    "NeurovprError",
    "ValidationError",
    "UnsupportedFeatureError",
    "BackendUnavailableError",
    "FileFormatError",
    "SimulationError",
]


class NeurovprError(Exception):
    """Base class of every error neurovpr raises on purpose."""


class ValidationError(NeurovprError, ValueError):
    """A graph element, argument or file content has an invalid value."""


class UnsupportedFeatureError(NeurovprError):
    """A backend was asked to run a feature it declares it cannot run."""


class BackendUnavailableError(NeurovprError):
    """A backend is unknown, or known but its simulator cannot be imported."""


class FileFormatError(NeurovprError):
    """A saved network file is truncated, corrupted or of an unknown version."""


class SimulationError(NeurovprError):
    """A simulation was driven in a way its state does not allow."""
