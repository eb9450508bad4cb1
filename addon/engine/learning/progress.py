"""How far learning has got, for whoever shows it.

:func:`.fit.learn` and the clips' alignment report ``progress(step, frac)``:
the step (``align``, ``prepare``, ``fit``, ``evaluate``, ``done``) and how
much of that step is done.  :data:`PHASES` places each step in the whole, so
one bar can run from 0 to 1 (the Blender add-on's status bar, the command
line's).

:class:`Console` is what the command line shows on stderr, as ``batch``
does: a tqdm bar on a terminal; otherwise (a log, a pipe) one plain line as
each step begins, never a carriage return.
"""

from __future__ import annotations

import sys

#: Where each step lies in the whole: (start, share).
PHASES = {"align": (0.0, 0.3), "prepare": (0.3, 0.1), "fit": (0.4, 0.5), "evaluate": (0.9, 0.1),
          "done": (1.0, 0.0)}

#: What each step does, as a plain line says it.
LABELS = {"align": "aligning the clips", "prepare": "preparing the tracks", "fit": "fitting",
          "evaluate": "evaluating on the held-out clips"}


def overall(step: str, frac: float) -> float:
    """The share of the whole done at ``frac`` of ``step``."""
    start, share = PHASES.get(step, (0.0, 0.0))
    return min(1.0, max(0.0, start + share * min(1.0, max(0.0, frac))))


class Console:
    """``progress(step, frac)`` for the command line (module docstring).

    ``bar``: None decides by whether ``stream`` is a terminal.  Call
    :meth:`close` (or use it as a context manager) before printing the
    result, so the bar is gone first.
    """

    def __init__(self, stream=None, bar: bool | None = None):
        self.stream = stream if stream is not None else sys.stderr
        if bar is None:
            isatty = getattr(self.stream, "isatty", None)
            bar = bool(isatty and isatty())
        self._bar = None
        if bar:
            from tqdm import tqdm

            self._bar = tqdm(total=1000, file=self.stream, dynamic_ncols=True, leave=False,
                             bar_format="{desc:>9} {percentage:3.0f}%|{bar}| {elapsed}<{remaining}")
        self._step = None

    def __call__(self, step: str, frac: float) -> None:
        if self._bar is not None:
            if step != self._step:
                self._bar.set_description_str(step, refresh=False)
            done = int(round(1000 * overall(step, frac)))
            if done > self._bar.n:
                self._bar.update(done - self._bar.n)
            elif step != self._step:
                self._bar.refresh()
        elif step != self._step and step in LABELS:
            print(LABELS[step], file=self.stream, flush=True)
        self._step = step

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self):
        return self

    def __exit__(self, *_exc):
        self.close()
