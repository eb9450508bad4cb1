"""Phones that connected speech shortens keep only their usual length.

In running speech the /ð/ of "the", "this", "that" is a brief dental
gesture between two longer sounds.  pocketsphinx's /ð/ model, which needs at
least three frames and sits between the transitions of its neighbours,
tends to take the end of the preceding sound as well: its /ð/ starts tens of
milliseconds early, while its end (the onset of the next vowel) agrees with
listeners and with dedicated aligners.

:func:`shorten_reduced` caps each such phone at its ``reduced`` length in
``data/timing.json`` by moving its start later, so the phone keeps its end.
When the phone before it ends where it starts (no pause between them), that
phone is extended to meet it, in the same word or the word before.
"""

from __future__ import annotations

from ..pauses import settings


def _longest() -> dict[str, float]:
    return {str(p): float(s) for p, s in settings().get("reduced", {}).items()}


def shorten_reduced(result: list, estimated: list[bool]) -> None:
    """Cap every phone named in ``reduced`` at its length, in place.

    ``result`` holds per word a list of (phone, start, end), or None; words
    placed by estimate are left alone, and so is a phone before them."""
    longest = _longest()
    if not longest:
        return
    before = None   # (word, phone index) of the phone placed last, if measured
    for wi, ph in enumerate(result):
        if not ph or estimated[wi]:
            before = None
            continue
        for k, (p, a, b) in enumerate(ph):
            cap = longest.get(p)
            if cap is not None and b - a > cap + 1e-9:
                start = b - cap
                ph[k] = (p, start, b)
                if before is not None:
                    w, j = before
                    q, qa, qb = result[w][j]
                    if abs(qb - a) < 1e-6:
                        result[w][j] = (q, qa, start)
            before = (wi, k)
