"""Sub-commands of ``modal-twin``, one module each.

Each module defines ``register(sub)`` that adds its parser to the sub-parsers of
:mod:`modal_twin.cli` and sets ``func`` to a function ``(args) -> int`` returning an
:class:`modal_twin.exit_codes.ExitCode`.
"""
