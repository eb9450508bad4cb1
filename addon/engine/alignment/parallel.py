"""Work on both cores at once, in forked worker processes where that is safe."""

from __future__ import annotations

import os
import sys
from concurrent.futures import ProcessPoolExecutor
from collections.abc import Callable

from .model import AlignSettings


def _can_fork(settings: AlignSettings) -> bool:
    import multiprocessing

    n = settings.workers or os.cpu_count() or 1
    # fork shares the loaded modules and costs nothing to start; where it is
    # not available (Windows) or unsafe (macOS), everything runs in-process.
    return n >= 2 and "fork" in multiprocessing.get_all_start_methods() and sys.platform != "darwin"


def _pool(settings: AlignSettings):
    import multiprocessing

    if not _can_fork(settings):
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


class Background:
    """``fn(*args)`` computed in a forked process while the caller goes on
    (the alignment of a clip long enough to be split keeps both cores busy
    only part of the time).  :meth:`result` returns its value; if the worker
    could not run it, or it raised, the call is made again in-process, so
    errors surface exactly as they would without the worker."""

    def __init__(self, fn: Callable, *args, settings: AlignSettings | None = None):
        import multiprocessing

        self._fn, self._args = fn, args
        self._pool = self._future = None
        if _can_fork(settings or AlignSettings()):
            try:
                self._pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork"))
                self._future = self._pool.submit(fn, *args)
            except (OSError, RuntimeError):
                self.close()

    def result(self):
        try:
            if self._future is not None:
                return self._future.result()
        except Exception:  # noqa: BLE001 - the worker died or raised: compute it here
            pass
        finally:
            self.close()
        return self._fn(*self._args)

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
        self._pool = self._future = None
