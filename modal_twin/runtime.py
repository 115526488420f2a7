"""Process settings the nodes, the command line and the benchmarks run with.

- One BLAS / OpenMP thread per process: a launch is many small processes on few cores, and
  BLAS threads made a 238-DOF eigen-solve 38x slower on the 2-core machine.
- glibc keeps freed blocks up to 32 MB in the heap instead of unmapping them: identification
  windows and twin blocks allocate the same large arrays again and again, and each fresh
  mapping costs page faults (N4SID on the 42 x 12 x 12,276 record: ~8-9k faults, 15-30 ms
  of a 90 ms run). glibc reads it at process start, so it is set in a child's environment.
"""

from __future__ import annotations

__all__ = ["MALLOC_TUNABLES", "THREAD_ENV", "runtime_env"]

MALLOC_TUNABLES = "glibc.malloc.mmap_threshold=33554432:glibc.malloc.trim_threshold=268435456"
THREAD_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def runtime_env(env: dict[str, str]) -> dict[str, str]:
    """``env`` with the settings above wherever it does not set them itself."""
    out = dict(env)
    for k, v in {**THREAD_ENV, "GLIBC_TUNABLES": MALLOC_TUNABLES}.items():
        out.setdefault(k, v)
    return out
