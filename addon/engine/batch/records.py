"""What made an output: a record of a line's inputs, settings, presets and
engine (``produced_by``: first in the JSON, beside a CSV), whose
fingerprint a rerun compares to decide whether the output is up to date."""

from __future__ import annotations

import hashlib
import json
import os
import re
import time
from dataclasses import fields, is_dataclass
from functools import lru_cache
from pathlib import Path

from ..settings import LineSettings
from .lines import Line, line_text, transcript_file

#: The layout of that record ("produced_by"); a new layout makes every output stale.
RECORD_SCHEMA = 1
#: A CSV output's record is kept beside it, in a file named so (a JSON output holds its own).
CSV_RECORD_SUFFIX = ".produced_by"

@lru_cache(maxsize=1)
def engine_version() -> str:
    """The extension's version, from ``blender_manifest.toml`` (in the
    extension's folder, or one above it in a checkout), or from the
    ``VERSION`` file of an engine shipped on its own (to a Dask cluster)."""
    engine = Path(__file__).resolve().parent.parent
    shipped = engine / "VERSION"
    if shipped.is_file():
        return shipped.read_text(encoding="utf-8").strip()
    for folder in (engine.parent, engine.parent.parent):
        try:
            text = (folder / "blender_manifest.toml").read_text(encoding="utf-8")
        except OSError:
            continue
        m = re.search(r'(?m)^version\s*=\s*"([^"]+)"', text)
        if m:
            return m.group(1)
    return "unknown"


@lru_cache(maxsize=1)
def _engine_data() -> str:
    """A hash of the engine's data files (timing, built-in presets and
    viseme sets, the arousal model ...), which can change between releases."""
    data = Path(__file__).resolve().parent.parent / "data"
    h = hashlib.sha256()
    for p in sorted(data.rglob("*")):
        if p.is_file():
            h.update(p.relative_to(data).as_posix().encode() + b"\0" + p.read_bytes() + b"\0")
    return h.hexdigest()


def _plain(x):
    """``x`` as JSON-ready values (a viseme set's arrays, its dataclass)."""
    if is_dataclass(x):
        return {f.name: _plain(getattr(x, f.name)) for f in fields(x)}
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if hasattr(x, "tolist"):
        return x.tolist()
    return x


def _digest(x) -> str:
    return hashlib.sha256(json.dumps(_plain(x), sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def _file_sha(path: str) -> str:
    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


#: An input changed less than this before its record was made is hashed again
#: (a file can change twice within one tick of a coarse file-system clock).
_SAME_TICK_NS = 2 * 10**9


def _input_identity(path: str, before: dict | None, recorded_ns: int) -> dict:
    """A file's path, size, time and content hash; the hash is taken from
    ``before`` (its entry in the last record, made at ``recorded_ns``) when
    path, size and time are unchanged and the file was older than that record."""
    st = os.stat(path)
    ident = {"path": os.path.abspath(path), "size": st.st_size, "mtime_ns": st.st_mtime_ns}
    if (isinstance(before, dict) and all(before.get(k) == v for k, v in ident.items())
            and isinstance(before.get("sha256"), str) and recorded_ns - st.st_mtime_ns > _SAME_TICK_NS):
        ident["sha256"] = before["sha256"]
    else:
        ident["sha256"] = _file_sha(path)
    return ident


class Digests:
    """The hashes of presets, viseme sets and other files named by many
    lines, each taken once (per run)."""

    def __init__(self):
        self._seen: dict[tuple, str] = {}
        self._given: list[tuple[object, str]] = []    # presets given read, with their digests

    def _once(self, key: tuple, make) -> str:
        if key not in self._seen:
            self._seen[key] = make()
        return self._seen[key]

    def preset(self, name: str, folder: str | None = None) -> str:
        """The digest of preset ``name`` as a tag in a transcript in ``folder`` reads it."""
        from .. import presets

        return self._once(("preset", folder, name), lambda: _digest(presets.finder(folder)(name)))

    def given_preset(self, preset) -> str:
        """The digest of a preset given already read (the run's settings'
        emotion), taken once for that preset."""
        for known, digest in self._given:
            if known is preset:
                return digest
        digest = _digest(preset)
        self._given.append((preset, digest))
        return digest

    def viseme_set(self, name: str) -> str:
        from .. import visemes

        return self._once(("viseme_set", name), lambda: _digest(visemes.load(name)))

    def file(self, path: str) -> str:
        return self._once(("file", os.path.abspath(path)), lambda: _file_sha(path))


def produced_by(line: Line, defaults: LineSettings, before: dict | None = None,
                digests: Digests | None = None) -> dict:
    """The record of what a line's outputs are made from, and its
    ``fingerprint`` (a hash of all that): the engine (version, data files,
    this record's layout), the manifest row, the command's options the row
    does not override, the preset, viseme set, emotion-tag presets,
    dictionary and arousal model used (by content, built-in ones included),
    and the line's own files (by content; ``before``, the last record,
    spares hashing a file whose size and time are unchanged).  Raises when
    something cannot be read; the line's own run then says what."""
    from ..emotion_track import split_tags

    digests = digests or Digests()
    now = time.time_ns()
    engine = {"version": engine_version(), "record": RECORD_SCHEMA, "data": _engine_data()}
    settings = {"emotion": None if line.emotion else defaults.emotion_name,
                "viseme_set": None if line.viseme_set else defaults.viseme_set,
                "fps": None if line.fps else defaults.fps_text,
                "coarticulation": defaults.coarticulation, "emotion_fade": float(defaults.emotion_fade)}
    if not defaults.gestures or defaults.gesture_seed:   # as do lines with the gestures as they come
        settings["gestures"] = {"on": defaults.gestures, "seed": defaults.gesture_seed}
    if (line.language or defaults.language or "en") != "en":     # English lines keep the records they had
        settings["language"] = None if line.language else defaults.language
    files = {"preset": digests.preset(line.emotion) if line.emotion else digests.given_preset(defaults.emotion),
             "viseme_set": digests.viseme_set(line.viseme_set or defaults.viseme_set or "default")}
    text = line_text(line)
    if text:
        source = transcript_file(line)
        folder = os.path.dirname(os.path.abspath(source)) if source else None
        for tag in split_tags(text, known=lambda n: bool(digests.preset(n, folder)))[1]:
            files[f"preset {tag.preset}"] = digests.preset(tag.preset, folder)
    if defaults.dictionary:
        files["dictionary"] = digests.file(defaults.dictionary)
    model = os.environ.get("LIPSYNC_AROUSAL_MODEL")
    if model:
        files["arousal_model"] = digests.file(model)
    before = before if isinstance(before, dict) else {}
    old = before.get("inputs") if isinstance(before.get("inputs"), dict) else {}
    stamp = before.get("recorded_ns") if isinstance(before.get("recorded_ns"), int) else 0
    inputs = {role: _input_identity(path, old.get(role), stamp) for role, path in line.inputs().items()}
    fingerprint = _digest({"engine": engine, "row": line.row, "settings": settings, "files": files,
                           "inputs": {k: v["sha256"] for k, v in inputs.items()}})
    return {"fingerprint": fingerprint, "engine": engine, "row": line.row, "settings": settings, "files": files,
            "inputs": inputs, "recorded_ns": now}


_RECORD_HEAD = re.compile(r'\A\s*\{\s*"produced_by"\s*:\s*')


def read_record(fmt: str, path: str) -> dict | None:
    """The record kept with an output (None: none, or unreadable).  A JSON
    output holds it first, so only the file's head is read."""
    try:
        if fmt != "json":
            with open(path + CSV_RECORD_SUFFIX, encoding="utf-8") as fh:
                rec = json.load(fh)
            return rec if isinstance(rec, dict) else None
        with open(path, "rb") as fh:
            head = fh.read(1 << 16).decode("utf-8", "ignore")
            m = _RECORD_HEAD.match(head)
            if m:
                try:
                    rec = json.JSONDecoder().raw_decode(head, m.end())[0]
                    return rec if isinstance(rec, dict) else None
                except ValueError:
                    pass   # longer than the head: read it all
            fh.seek(0)
            doc = json.loads(fh.read().decode("utf-8"))
        rec = doc.get("produced_by") if isinstance(doc, dict) else None
        return rec if isinstance(rec, dict) else None
    except (OSError, ValueError):
        return None


def why_stale(before: dict | None, now: dict) -> str:
    """What differs between the record an output carries and the current one."""
    if not before or "fingerprint" not in before:
        return "no record of what made it"
    if before.get("engine") != now["engine"]:
        return "engine changed"
    old = before.get("inputs") or {}
    if {k: (v or {}).get("sha256") for k, v in old.items()} != {k: v["sha256"] for k, v in now["inputs"].items()}:
        return "input file changed"
    if before.get("row") != now["row"]:
        return "manifest row changed"
    if before.get("settings") != now["settings"]:
        return "settings changed"
    was, files = before.get("files") or {}, now["files"]
    for key, label in (("dictionary", "dictionary changed"), ("arousal_model", "arousal model changed")):
        if was.get(key) != files.get(key):
            return label
    return "preset or viseme set changed"


def freshness(line: Line, defaults: LineSettings, digests: Digests | None = None) -> tuple[bool, str | None]:
    """(whether every output of ``line`` exists and was made from what
    would make it now, why not).  Sets ``line.record`` to the current
    record when it could be made; a line with an output missing is not up
    to date and has no reason."""
    if not line.outputs or not all(os.path.isfile(p) for p in line.outputs.values()):
        return False, None
    records = [read_record(fmt, path) for fmt, path in line.outputs.items()]
    try:
        line.record = produced_by(line, defaults, next((r for r in records if r), None), digests)
    except Exception:  # noqa: BLE001 - the line's own run reports what cannot be read
        line.record = None
        return False, None
    stale = [r for r in records if not r or r.get("fingerprint") != line.record["fingerprint"]]
    return (False, why_stale(stale[0], line.record)) if stale else (True, None)


def up_to_date(line: Line, defaults: LineSettings | None = None) -> bool:
    """True when every output exists and was made from the same files and
    settings (see :func:`produced_by`)."""
    return freshness(line, defaults or LineSettings.of())[0]
