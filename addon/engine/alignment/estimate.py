"""Phonemes placed by estimate, where the acoustic model cannot place them."""

from __future__ import annotations

from collections.abc import Sequence

from .model import typical_duration


def _estimate(phones_per_word: Sequence[Sequence[str]], spans: list[tuple[float, float]]):
    """Spread words over speech spans in proportion to their typical length.
    Returns per word a list of (phone, start, end)."""
    weights = [[typical_duration(p) for p in ph] for ph in phones_per_word]
    total = sum(sum(w) for w in weights) or 1.0
    span_total = sum(b - a for a, b in spans) or 1e-3

    def at(x: float) -> float:  # a clock that runs only during speech
        for a, b in spans:
            if x <= b - a:
                return a + x
            x -= b - a
        return spans[-1][1]

    out = []
    clock = 0.0
    for ph, w in zip(phones_per_word, weights):
        cur = []
        for p, d in zip(ph, w):
            d = d / total * span_total
            cur.append((p, at(clock), at(clock + d)))
            clock += d
        out.append(cur)
    return out


def _clean(ph: list[tuple[str, float, float]]) -> list[tuple[str, float, float]]:
    """pocketsphinx may report a phone of zero frames; give it a sliver."""
    out = []
    for p, a, b in ph:
        if out and a < out[-1][2]:
            a = out[-1][2]
        out.append((p, a, max(b, a + 0.005)))
    return out
