"""An evaluating process gives large arrays back to the system (glibc's fixed mmap threshold).

glibc raises its mmap threshold each time a mapped block is freed, after which blocks of that
size come from the heap, which fragments: a worker grew 30 % over the default experiment. After
`evaluate_batch` (which calls `steady_heap`), arrays of 20 MiB down to 2 MiB each get their own
mapping, and the heap does not grow. Each case runs in a fresh interpreter, since the
setting is per process.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

PROBE = """
import ctypes, sys
import numpy as np

class MallInfo2(ctypes.Structure):
    _fields_ = [(name, ctypes.c_size_t) for name in (
        "arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks",
        "fordblks", "keepcost")]

libc = ctypes.CDLL("libc.so.6")
libc.mallinfo2.restype = MallInfo2
if sys.argv[1] == "evaluate":
    from ariel.evaluation import BodySpec, EvaluationTask, build, evaluate_batch
    from ariel.evaluation._heap import steady_heap
    from ariel.plugins import controllers
    gecko = EvaluationTask(BodySpec("prebuilt", "gecko"), duration=0.05, record_bodies=False)
    n = controllers.make("na_cpg").num_parameters(build(gecko).model)
    assert evaluate_batch([EvaluationTask(**{**vars(gecko), "params": [0.1] * n})])[0].ok
    assert steady_heap()
heap = libc.mallinfo2().arena
for mib in range(20, 1, -1):  # bodies of other sizes: each freed block raises glibc's bound
    block = np.ones(mib << 20, dtype=np.uint8)
    del block
print((libc.mallinfo2().arena - heap) >> 20)  # MiB the heap grew
"""


def _glibc_with_mallinfo2() -> bool:
    try:
        version = os.confstr("CS_GNU_LIBC_VERSION") or ""
    except (AttributeError, ValueError, OSError):
        return False
    if not version.startswith("glibc "):
        return False
    major, minor = (int(part) for part in version.split()[1].split(".")[:2])
    return (major, minor) >= (2, 33)  # mallinfo2


needs_glibc = pytest.mark.skipif(not _glibc_with_mallinfo2(), reason="glibc >= 2.33 only")


def _heap_growth_mib(mode: str) -> int:
    # glibc's defaults: importing Dask (other tests) sets MALLOC_TRIM_THRESHOLD_ in this
    # process's environment for its workers, and a fixed trim threshold hides the effect.
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    result = subprocess.run(
        [sys.executable, "-c", PROBE, mode], capture_output=True, text=True, timeout=120, env=env
    )
    assert result.returncode == 0, result.stderr[-2000:]
    return int(result.stdout.strip())


@needs_glibc
def test_after_an_evaluation_large_arrays_do_not_grow_the_heap() -> None:
    assert _heap_growth_mib("evaluate") <= 2


@needs_glibc
def test_without_it_glibc_would_keep_them_on_the_heap() -> None:
    assert _heap_growth_mib("plain") >= 10  # the probe can tell the difference
