"""The identification methods and mode selections, as every caller spells them.

A module of names only, outside the identification package (whose ``__init__`` loads the
methods and scipy with them): the command line builds its parser from it in ~0.1 s.
"""

from __future__ import annotations

__all__ = ["METHODS", "OUTPUT_ONLY", "SELECTIONS"]

METHODS = ("n4sid", "ssi-cov", "polymax")
"""The methods, as every caller spells them."""
OUTPUT_ONLY = ("ssi-cov",)
"""The methods that use no input."""
SELECTIONS = ("clusters", "stability")
"""Mode selections: clustering of the poles (default) or the stability rule of [004]."""
