"""Two decodes at once, in forked worker processes where that is safe."""

from __future__ import annotations

import os
import sys
from concurrent.futures import ProcessPoolExecutor

from .model import AlignSettings


def _pool(settings: AlignSettings):
    import multiprocessing

    n = settings.workers or os.cpu_count() or 1
    # fork shares the loaded modules and costs nothing to start; where it is
    # not available (Windows) or unsafe (macOS), everything runs in-process.
    if n < 2 or "fork" not in multiprocessing.get_all_start_methods() or sys.platform == "darwin":
        return None
    return ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork"))


class _Inline:
    """Stands in for a process pool: runs the call at once."""

    class _Done:
        def __init__(self, value):
            self._value = value

        def result(self):
            return self._value

    def submit(self, fn, *args):
        return self._Done(fn(*args))

    def shutdown(self):
        pass
