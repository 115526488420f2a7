"""modal_twin: structural vibration testing and digital twins on ROS 2 Jazzy.

Core code (everything but ``*/node.py``, :mod:`modal_twin.io` and :mod:`modal_twin.launch`)
is plain numpy / scipy and imports without ROS.
"""

from __future__ import annotations

__all__ = ["__version__"]

__version__ = "0.1.0"
