"""One set of process exit codes for the command line, the replayer and the launcher.

=====  =============  ===========================================================
code   name           meaning
=====  =============  ===========================================================
0      OK             done (also "nothing to do", which prints why)
1      FAILED         the job ran and did not reach its goal (a node died, the
                      error did not fall)
2      USAGE          bad arguments or bad input: a file that is not what it
                      claims, a channel map that does not fit, a missing role
3      NOT_READY      a launched graph did not come up in time
130    INTERRUPTED    stopped by Ctrl-C / SIGINT
=====  =============  ===========================================================
"""

from __future__ import annotations

from enum import IntEnum

__all__ = ["ExitCode"]


class ExitCode(IntEnum):
    """Exit codes shared by ``modal-twin``, ``modal-twin replay`` and the launcher."""

    OK = 0
    FAILED = 1
    USAGE = 2
    NOT_READY = 3
    INTERRUPTED = 130
