"""Exception hierarchy of modal_twin.

Every error subclasses :class:`ModalTwinError` and the builtin it resembles, so callers may
catch either. Messages name the argument, what was expected and what came.
"""

from __future__ import annotations

__all__ = [
    "BagError",
    "ConfigError",
    "ConvergenceError",
    "LaunchError",
    "ModalTwinError",
    "ModelError",
    "OptionError",
    "ShapeError",
    "SignalError",
]


class ModalTwinError(Exception):
    """Base of all modal_twin errors."""


class ShapeError(ModalTwinError, ValueError):
    """An array has the wrong shape (message gives expected and found)."""


class OptionError(ModalTwinError, ValueError):
    """An option or keyword has an unknown value (message lists the valid ones)."""


class ConfigError(ModalTwinError, ValueError):
    """A configuration file (YAML) is malformed; the message names file, key and problem."""


class ModelError(ModalTwinError, ValueError):
    """A structural model is invalid: negative mass, singular or unstable matrices."""


class SignalError(ModalTwinError, ValueError):
    """A signal carries non-finite samples, gaps or an inconsistent channel layout."""


class ConvergenceError(ModalTwinError, RuntimeError):
    """An iterative solver did not converge; the message gives the residual reached."""


class BagError(ModalTwinError, OSError):
    """A bag file is missing, truncated, foreign or cannot be written."""


class LaunchError(ModalTwinError, RuntimeError):
    """A launched run failed (a node died or did not come up); the message names it."""
