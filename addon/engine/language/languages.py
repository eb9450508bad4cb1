"""The languages a transcript can be in, and the codes users write for them.

The table is ``data/languages.json``: each language under its ISO 639-1 code
(or a BCP-47 tag such as ``pt-BR`` where a region speaks it differently),
with its name, the eSpeak NG voice that reads it (:mod:`.espeak`; English
has none: it is read with the CMU dictionary) and the other codes it goes
by (ISO 639-3, 639-2/B, regional tags).  :func:`resolve` accepts any of
them in any case, with ``_`` or ``-``; a tag the table does not list falls
back to its first subtag (``de-AT`` is ``de``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

from ..errors import LipSyncError

DATA = Path(__file__).parent.parent / "data" / "languages.json"
ENGLISH = "en"


@dataclass(frozen=True)
class Language:
    code: str                  # as the table names it: "de", "pt-BR", "zh"
    name: str
    espeak: str | None         # the eSpeak NG voice; None: English, read with the CMU dictionary
    codes: tuple[str, ...] = ()
    phone_fixes: dict = field(default_factory=dict, compare=False, hash=False)

    @property
    def is_english(self) -> bool:
        return self.espeak is None


@lru_cache(maxsize=1)
def _doc() -> dict:
    with open(DATA, encoding="utf-8") as fh:
        return json.load(fh)


def stand_ins() -> dict[str, str]:
    """Phone -> the English phone the aligner looks for in its place, for
    words read from IPA (see ``stand_ins_description`` in the table)."""
    return dict(_doc().get("stand_ins", {}))


@lru_cache(maxsize=1)
def table() -> dict[str, Language]:
    doc = _doc()
    return {code: Language(code, e["name"], e.get("espeak"), tuple(e.get("codes", ())), e.get("phone_fixes", {}))
            for code, e in doc["languages"].items()}


@lru_cache(maxsize=1)
def _index() -> dict[str, str]:
    out: dict[str, str] = {}
    for code, lang in table().items():
        for name in (code,) + lang.codes:
            out.setdefault(name.lower().replace("_", "-"), code)
    return out


def supported() -> str:
    """``de (German), en (English), ...``: every language, for messages and ``--help``."""
    return ", ".join(f"{code} ({lang.name})" for code, lang in sorted(table().items()))


def resolve(code: str | Language | None = None) -> Language:
    """The language a user's code names (None or empty: English).  An
    unknown code is a :class:`LipSyncError` listing the supported ones."""
    if isinstance(code, Language):
        return code
    if code is None or not str(code).strip():
        return table()[ENGLISH]
    key = str(code).strip().lower().replace("_", "-")
    index = _index()
    while key:
        if key in index:
            return table()[index[key]]
        key = key.rpartition("-")[0]
    raise LipSyncError(f"unknown language {str(code).strip()!r}; supported (ISO 639-1 or 639-3 codes, BCP-47 "
                       f"tags): {supported()}")
