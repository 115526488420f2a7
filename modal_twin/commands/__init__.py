"""Sub-commands of ``modal-twin``, one module each.

Each module defines ``register(sub)`` that adds its parser to the sub-parsers of
:mod:`modal_twin.cli` and sets ``func`` to a function ``(args) -> int`` returning an
:class:`modal_twin.exit_codes.ExitCode`. ``record`` and ``replay`` keep their own
mains (:mod:`modal_twin.io.recorder`, :mod:`modal_twin.io.replay`); ``demo``, which runs
other commands, has ``register`` / ``run`` in :mod:`modal_twin.demo` (above commands in
the stage order).
"""
