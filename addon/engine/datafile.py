"""Reading the JSON files a studio writes to extend the add-on: emotion
presets, viseme sets, shape-key naming conventions and the arousal model.

Every problem with the file as a whole is a :class:`PresetError` naming the
file and the ``(file)`` or ``(top level)`` field; the loaders then name the
field inside it.  A byte-order mark (as Windows Notepad saves UTF-8) is
accepted."""

from __future__ import annotations

import json
from pathlib import Path

from .errors import PresetError


def read_object(path: Path) -> dict:
    """The JSON object in ``path``."""
    if not path.is_file():
        raise PresetError(str(path), "(file)", "does not exist")
    try:
        doc = json.loads(path.read_text(encoding="utf-8-sig"))
    except UnicodeDecodeError as exc:
        raise PresetError(str(path), "(file)", f"is not UTF-8 text (byte {exc.start}); save it as UTF-8") from None
    except json.JSONDecodeError as exc:
        raise PresetError(str(path), "(file)",
                          f"is not valid JSON: line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
    except OSError as exc:
        raise PresetError(str(path), "(file)", f"cannot be read: {exc.strerror or exc}") from None
    if not isinstance(doc, dict):
        raise PresetError(str(path), "(top level)", "must be a JSON object")
    return doc
