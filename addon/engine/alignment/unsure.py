"""Closed lips the recogniser was unsure of, from its word lattice.

Without a transcript the mouth shows the recogniser's best guess of the
words, and a guess that misses a /p b m/ ("hung" for "um", "of" for
"some") leaves the lips open where the speaker's closed.  The recogniser's
lattice keeps the other words it weighed; where those that close the lips
at a moment carry much of its weight there, the lips close even though the
best guess has no /p b m/.

:func:`labial_weight` sums, frame by frame, the posterior weight of the
lattice's words over their /p b m/ (each word's phones spread evenly over
its time; the acoustic scores scaled by :data:`ACOUSTIC_SCALE`);
:func:`with_closures` puts a /p b m/ into the words heard wherever that
weight is :data:`CLOSED` or more for :data:`SHORTEST` frames and the words
heard have no /p b m/ within :data:`NEAR` frames.
"""

from __future__ import annotations

import os
import tempfile

import numpy as np

from .speech import runs

#: Phones that close the lips.
LABIAL = ("P", "B", "M")
#: The lattice's acoustic scores are scaled by this before they are weighed (unscaled, the best
#: path takes all the weight; the other words need a flatter scale to count at all).
ACOUSTIC_SCALE = 0.01
#: The lips close where the words closing them hold this much of the lattice's weight ...
#: (bench/no_transcript.py, lips closed at /p b m/ on TIMIT, the natural monologues and the
#: voice-quality clips: none 0.907 0.520 0.679; at 0.5 0.916 0.560 0.716; at 0.4 0.925 0.560 0.741,
#: vowel frames closed 0.19 -> 0.22 %, 0.88 -> 1.89 %, 0.20 -> 0.98 %, pauses at rest kept; at 0.3
#: 0.944 0.680 0.765, but a pause of the voice-quality clips closed and vowels closed 0.28, 2.08 and
#: 1.40 %.  Each group's own best setting raises the other two over none.)
CLOSED = 0.4
#: ... for at least this many frames (10 ms) ...
SHORTEST = 3
#: ... and the words heard have no /p b m/ within this many frames.
NEAR = 5


def _read_htk(path: str) -> tuple[dict[int, tuple[float, str]], list[tuple[int, int, float]], int, int]:
    nodes: dict[int, tuple[float, str]] = {}
    links: list[tuple[int, int, float]] = []
    start = end = -1
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            if line.startswith("start="):
                start = int(line.split("=", 1)[1])
            elif line.startswith("end="):
                end = int(line.split("=", 1)[1])
            elif line.startswith(("I=", "J=")):
                d = dict(kv.split("=", 1) for kv in line.split() if "=" in kv)
                if "I" in d:
                    nodes[int(d["I"])] = (float(d["t"]), d["W"])
                else:
                    links.append((int(d["S"]), int(d["E"]), float(d["a"])))
    return nodes, links, start, end


def labial_weight(decoder, frames: int) -> np.ndarray | None:
    """(frames, 3): the lattice weight of P, B and M at each 10 ms frame of
    the utterance ``decoder`` last decoded; None where it has no lattice."""
    lattice = decoder.get_lattice()
    if lattice is None:
        return None
    fd, path = tempfile.mkstemp(suffix=".slf")
    os.close(fd)
    try:
        lattice.write_htk(path)
        nodes, links, start, end = _read_htk(path)
    finally:
        os.unlink(path)
    if start not in nodes or end not in nodes or not links:
        return None
    order = sorted(nodes, key=lambda i: nodes[i][0])
    into: dict[int, list[int]] = {}
    out_of: dict[int, list[int]] = {}
    for k, (s, e, _) in enumerate(links):
        out_of.setdefault(s, []).append(k)
        into.setdefault(e, []).append(k)
    score = [ACOUSTIC_SCALE * a for _, _, a in links]
    alpha = dict.fromkeys(nodes, -np.inf)
    beta = dict.fromkeys(nodes, -np.inf)
    alpha[start], beta[end] = 0.0, 0.0
    for i in order:
        if i != start and i in into:
            alpha[i] = float(np.logaddexp.reduce([alpha[links[k][0]] + score[k] for k in into[i]]))
    for i in reversed(order):
        if i != end and i in out_of:
            beta[i] = float(np.logaddexp.reduce([beta[links[k][1]] + score[k] for k in out_of[i]]))
    total = alpha[end]
    if not np.isfinite(total):
        return None
    weight = np.zeros((frames, len(LABIAL)))
    for k, (s, e, _) in enumerate(links):
        name = nodes[s][1]
        post = float(np.exp(alpha[s] + score[k] + beta[e] - total))
        if post < 1e-3 or name.startswith(("!", "<", "[", "+")):
            continue
        pron = (decoder.lookup_word(name) or "").split()
        if not any(p in LABIAL for p in pron):
            continue
        t0, t1 = nodes[s][0] * 100.0, nodes[e][0] * 100.0
        step = (t1 - t0) / len(pron)
        for j, p in enumerate(pron):
            if p in LABIAL:
                a, b = int(round(t0 + j * step)), int(round(t0 + (j + 1) * step))
                weight[max(0, a):max(0, min(frames, b)), LABIAL.index(p)] += post
    return weight


def with_closures(words: list, weight: np.ndarray | None) -> list:
    """``words`` (text, [(phone, first frame, end frame, ...)], estimated),
    the words heard in one utterance, with a /p b m/ put in (cut from the
    phone it falls in) wherever :func:`labial_weight` says the lips close and
    the words have none near (:data:`CLOSED`, :data:`SHORTEST`, :data:`NEAR`)."""
    if weight is None or not words:
        return words
    have = np.zeros(len(weight), bool)
    for _, phones, _ in words:
        for p, a, b, *_ in phones:
            if p in LABIAL:
                have[max(0, a - NEAR):b + NEAR] = True
    total = weight.sum(axis=1)
    out = [(text, list(phones), est) for text, phones, est in words]
    for i, j in runs((total >= CLOSED) & ~have).tolist():
        if j - i < SHORTEST:
            continue
        phone = LABIAL[int(weight[i:j].sum(axis=0).argmax())]
        for _, phones, _ in out:
            k = next((k for k, (_, a, b, *_) in enumerate(phones) if a <= (i + j) // 2 < b), None)
            if k is None:
                continue
            p, a, b, *rest = phones[k]
            lo, hi = max(a, i), min(b, j)
            phones[k:k + 1] = (([(p, a, lo, *rest)] if lo > a else []) + [(phone, lo, hi)]
                               + ([(p, hi, b, *rest)] if b > hi else []))
            break
    return out
