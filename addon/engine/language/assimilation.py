"""Words as they are said in running speech, where that changes the lips.

A transcript spells words as written; speakers assimilate and reduce.
German "-en" after /p b/ is said with the lips shut ("Lappen" [lapm̩],
"Abend" [aːbm̩t]), as is English "happen"; /n/ before a labial is said [m]
("input", "in Bonn"); a syllabic nasal takes the place of schwa and nasal
("Stunden" [ʃtʊndn̩], "button").  Spelled out, such a word opens the mouth
where the speaker's lips stay shut.

The rules are data (``data/assimilation.json``, which a studio may extend).
Each gives a word another pronunciation, not a replacement: the aligner
chooses between them by the sound (:func:`variants`), and the mouth follows
the phones it chose.  A rule marked ``always`` is how the language is said
whatever the sound (German "-en" after /p b/): the word is said so alone
(:func:`said`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from ..datafile import read_object
from ..errors import PresetError

DATA = Path(__file__).resolve().parent.parent / "data" / "assimilation.json"


@dataclass(frozen=True)
class Rule:
    """``match`` (a run of phones) said as ``becomes`` after a phone of
    ``after`` and before one of ``before`` (either unset: any; ``#`` in
    ``before``: the end of the word), in the languages ``languages``
    (``*``: every one); with ``always``, in place of ``match`` rather than
    beside it."""

    name: str
    match: tuple[str, ...]
    becomes: tuple[str, ...]
    after: frozenset[str] | None = None
    before: frozenset[str] | None = None
    languages: frozenset[str] = frozenset({"*"})
    always: bool = False

    def applies(self, language: str) -> bool:
        return "*" in self.languages or language in self.languages


@lru_cache(maxsize=4)
def rules(path: Path = DATA) -> tuple[Rule, ...]:
    """The rules of ``path``, checked once."""
    doc = read_object(path)
    out = []
    for k, r in enumerate(doc.get("rules", [])):
        where = f"rules[{k}]"
        try:
            match, becomes = tuple(r["match"]), tuple(r["becomes"])
            if not match or not all(isinstance(p, str) for p in match + becomes):
                raise ValueError
            always = r.get("always", False)
            if not isinstance(always, bool):
                raise PresetError(str(path), f"{where}.always", "is true or false")
            out.append(Rule(str(r.get("name", where)), match, becomes,
                            frozenset(r["after"]) if "after" in r else None,
                            frozenset(r["before"]) if "before" in r else None,
                            frozenset(r.get("languages", ["*"])), always))
        except (KeyError, TypeError, ValueError):
            raise PresetError(str(path), where, "needs 'match' and 'becomes', lists of phones") from None
    return tuple(out)


@lru_cache(maxsize=4)
def held_alike(path: Path = DATA) -> dict[str, tuple[str, ...]]:
    """{vowel: the other vowels of its group} of ``path``'s ``held`` groups:
    vowels said alike when drawn out (:mod:`..alignment.held`)."""
    doc = read_object(path)
    out: dict[str, tuple[str, ...]] = {}
    groups = doc.get("held", {}).get("alike", [])
    for k, group in enumerate(groups if isinstance(groups, list) else [None]):
        if not isinstance(group, list) or len(group) < 2 or not all(isinstance(p, str) for p in group):
            raise PresetError(str(path), f"held.alike[{k}]", "needs a list of two or more phones")
        for p in group:
            out[p] = tuple(dict.fromkeys(out.get(p, ()) + tuple(q for q in group if q != p)))
    return out


def variants(words: list[list[str]], language: str, shown: list[list[str]] | None = None
             ) -> list[list[tuple[list[str], list[str]]]]:
    """Every word's other pronunciations in running speech: for each of
    ``words`` (their phones as the aligner is given them), a list of
    (phones, shown phones) pairs (``shown``: the phones the mouth shows, one
    for each aligned phone, where they differ; the rules rewrite both alike).
    Each rule applies alone, at every place it matches, and then all of
    them together; the next word's first phone counts as what follows a
    word's last."""
    shown = shown or words
    out: list[list[tuple[list[str], list[str]]]] = []
    active = [r for r in rules() if r.applies(language) and not r.always]
    for k, (ph, sh) in enumerate(zip(words, shown)):
        following = words[k + 1][0] if k + 1 < len(words) and words[k + 1] else None
        found: list[tuple[list[str], list[str]]] = []
        for group in [[r] for r in active] + ([active] if len(active) > 1 else []):
            a, s = list(ph), list(sh)
            for rule in group:
                a, s = _apply(rule, a, s, following)
            if a != list(ph) and (a, s) not in found:
                found.append((a, s))
        out.append(found)
    return out


def said(words: list[list[str]], language: str, shown: list[list[str]] | None = None
         ) -> list[tuple[list[str], list[str]]]:
    """Every word as ``language`` always says it in running speech: each of
    ``words`` (their phones as the aligner is given them) and its ``shown``
    phones, rewritten alike by the rules marked ``always``, in order; the
    next word's first phone counts as what follows a word's last."""
    shown = shown or words
    always = [r for r in rules() if r.applies(language) and r.always]
    out = []
    for k, (ph, sh) in enumerate(zip(words, shown)):
        following = words[k + 1][0] if k + 1 < len(words) and words[k + 1] else None
        a, s = list(ph), list(sh)
        for rule in always:
            a, s = _apply(rule, a, s, following)
        out.append((a, s))
    return out


def _apply(rule: Rule, phones: list[str], shown: list[str], following: str | None) -> tuple[list[str], list[str]]:
    """``phones`` (and ``shown`` alike) with ``rule`` applied wherever it matches."""
    n = len(rule.match)
    a, s = list(phones), list(shown)
    i = 0
    while i + n <= len(a):
        before = a[i - 1] if i > 0 else None
        end = i + n == len(a)
        after = following if end else a[i + n]
        if (tuple(a[i:i + n]) == rule.match and (rule.after is None or before in rule.after)
                and (rule.before is None or after in rule.before or (end and "#" in rule.before))):
            a[i:i + n] = list(rule.becomes)
            s[i:i + n] = list(rule.becomes)
            i += len(rule.becomes)
        else:
            i += 1
    return a, s
