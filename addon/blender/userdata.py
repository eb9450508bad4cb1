"""The user's own data: the extension's user folder and what it holds.

Blender gives each extension a folder for its user's data
(``bpy.utils.extension_path_user``); loaded as a plain add-on (from a script,
as the sample job does) it is ``emotive_lipsync`` under Blender's user
scripts folder.  In it:

* ``presets/``: emotion presets saved from the panel (``+``) or learned from
  animation, one JSON file each, named after the preset (a learned preset's
  training report lies beside it as ``NAME.report.json``);
* ``conventions/``: a studio's shape-key naming conventions, read with the
  built-in ones by Auto-Map and Generate.

A preset is named the same way everywhere: in the panel, an operator's
``emotion``, ``--command lipsync --emotion``, a manifest's ``emotion`` column,
an ``emotion:NAME`` timeline marker and an ``[angry]`` tag in a transcript.
The name is a built-in preset's, else one of the user's presets, else a
.json file (``//`` relative to the .blend file).  Every problem with a name,
a file or its contents is a :class:`LipSyncError` saying what is wrong.
"""

from __future__ import annotations

import json
import os
import stat

import bpy

from ..engine import presets
from ..engine.errors import LipSyncError

_PACKAGE = __package__.rpartition(".")[0]
PRESETS = "presets"
CONVENTIONS = "conventions"
REPORT_SUFFIX = ".report.json"

#: Characters a file name cannot hold on some system.
_FORBIDDEN = '/\\:*?"<>|'
#: Names Windows keeps for devices, with any extension.
_RESERVED = {"con", "prn", "aux", "nul"} | {f"{d}{i}" for d in ("com", "lpt") for i in range(1, 10)}
#: Bytes of a preset's name: with ".report.json" the file name stays within the 255 of every file system.
MAX_NAME_BYTES = 200


def folder(kind: str = PRESETS, create: bool = False) -> str:
    """The user's folder of ``kind`` (:data:`PRESETS`, :data:`CONVENTIONS`).
    ``create``: make it if it is missing (a clear error if that fails)."""
    try:
        try:
            return bpy.utils.extension_path_user(_PACKAGE, path=kind, create=create)
        except ValueError:
            # Loaded as a plain add-on (not an extension), e.g. from a script.
            return bpy.utils.user_resource("SCRIPTS", path=os.path.join(kind, "emotive_lipsync"), create=create)
    except OSError as exc:
        raise LipSyncError(f"cannot make the folder for your {kind}: {exc.strerror or exc}") from None


def conventions_folder() -> str | None:
    """The folder where a studio keeps its own naming conventions (None if none)."""
    return folder(CONVENTIONS) or None


# --- names --------------------------------------------------------------------------

def check_name(name: str) -> str:
    """``name`` without surrounding spaces, if it can name one of the user's
    presets (a file name on every system); else a :class:`LipSyncError`
    saying why not."""
    clean = name.strip()
    if not clean:
        raise LipSyncError("a preset needs a name: type one")
    why = ""
    if any(c in clean for c in _FORBIDDEN):
        why = 'holds one of the characters / \\ : * ? " < > |'
    elif any(ord(c) < 32 or ord(c) == 127 for c in clean):
        why = "holds a control character (a tab or a line break)"
    elif clean.startswith("."):
        why = "starts with a dot"
    elif clean.lower().endswith(".json"):
        why = "ends in .json: give the name alone"
    elif clean.split(".")[0].lower() in _RESERVED:
        why = "is a name Windows keeps for a device"
    elif len(clean.encode("utf-8")) > MAX_NAME_BYTES:
        why = f"is longer than {MAX_NAME_BYTES} bytes"
    if why:
        raise LipSyncError(f"{_short(clean)!r} cannot be a preset name: it {why}")
    return clean


def _short(text: str, n: int = 60) -> str:
    return text if len(text) <= n else text[:n] + "..."


def _saved_file(name: str, where: str) -> str | None:
    """The file of the user's preset ``name`` in ``where``, if there is one."""
    try:
        clean = check_name(name)
    except LipSyncError:
        return None
    path = os.path.join(where, clean + ".json") if where else ""
    return path if path and os.path.isfile(path) else None


def preset_names() -> list[str]:
    """The user's saved presets, by name."""
    return _names_in(folder())


def _names_in(where: str) -> list[str]:
    """The presets in the folder ``where`` (a learned preset's report is not one)."""
    try:
        files = set(os.listdir(where)) if where and os.path.isdir(where) else set()
    except OSError:
        return []
    names = [f[:-5] for f in files if f.endswith(".json") and _saved_file(f[:-5], where)
             and not (f.endswith(REPORT_SUFFIX) and f[:-len(REPORT_SUFFIX)] + ".json" in files)]
    return sorted(names, key=str.lower)


def _looks_like_path(name: str) -> bool:
    return name.lower().endswith(".json") or name.startswith("//") or any(s in name for s in "/\\") \
        or os.path.isabs(name)


def _blend_folder() -> str:
    return os.path.dirname(bpy.data.filepath) if bpy.data.filepath else ""


def _source(name: str, where: str, blend_folder: str) -> str:
    """What the engine loads for the preset ``name``: a built-in's name, else
    a file's path.  No Blender data is read here (it may run in the engine's
    thread): ``where`` is the user's presets folder, ``blend_folder`` the
    .blend file's ("" if unsaved)."""
    if not isinstance(name, str) or not name.strip():
        raise LipSyncError(f"no preset given: name a built-in preset ({', '.join(presets.builtin_names())}), "
                           "one of yours, or a .json file")
    name = name.strip()
    if name in presets.builtin_names():
        return name
    saved = _saved_file(name, where)
    if saved:
        return saved
    if not _looks_like_path(name):
        yours = _names_in(where)
        mine = f"yours: {', '.join(yours)}" if yours else "you have saved none"
        raise LipSyncError(f"{_short(name)!r} is not a preset: built-in presets: "
                           f"{', '.join(presets.builtin_names())}; {mine}; or give a .json file")
    if name.startswith("//"):
        if not blend_folder:
            raise LipSyncError(f"the preset file {name!r} is relative to the .blend file (//), which has not been "
                               "saved yet: save it first, or give the file's full path")
        name = os.path.join(blend_folder, name[2:])
    try:
        path = os.path.abspath(name)
    except ValueError:
        raise LipSyncError(f"{_short(name)!r} is not a usable file path") from None
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        raise LipSyncError(f"the preset file {path} does not exist") from None
    except (OSError, ValueError) as exc:   # no permission to look, a name too long ...
        raise LipSyncError(f"cannot read the preset file {path}: {getattr(exc, 'strerror', None) or 'unreadable'}"
                           ) from None
    if stat.S_ISDIR(mode):
        raise LipSyncError(f"{path} is a folder, not a preset file: give a .json file")
    if not stat.S_ISREG(mode):
        raise LipSyncError(f"{path} is not a file but a device, a pipe or a socket: give a .json preset file")
    return path


def _load(source: str):
    """The engine's preset from ``source``, every failure a sentence."""
    try:
        return presets.load(source)
    except LipSyncError:
        raise
    except OSError as exc:
        raise LipSyncError(f"cannot read the preset file {source}: {exc.strerror or 'unreadable'}") from None
    except Exception:  # noqa: BLE001 - a value of a kind the preset reader does not expect
        raise LipSyncError(f"{source} is not a valid preset: one of its fields holds a value of the wrong kind (a "
                           "list or an object where a name or a number belongs)") from None


def source(name: str) -> str:
    """The built-in name or the file the preset ``name`` is read from."""
    return _source(name, folder(), _blend_folder())


def load_preset(name: str):
    """The preset ``name`` (a built-in, one of the user's, or a .json file)."""
    return _load(source(name))


def panel_preset(settings) -> presets.Preset:
    """The preset as edited in the Lip Sync panel (the scene's ``settings``),
    validated; the named preset itself when the panel holds no numbers."""
    if not settings.preset_values:
        return load_preset(settings.emotion)
    flat = {item.path: item.value() for item in settings.preset_values}
    flat.setdefault("name", settings.emotion)
    where = f"preset {settings.emotion!r} (as edited)"
    try:
        doc = presets.from_flat(flat)
        if settings.learned:
            doc["learned"] = json.loads(settings.learned)
        return presets.as_preset(doc, where)
    except LipSyncError:
        raise
    except Exception:  # noqa: BLE001 - numbers the panel cannot put back together
        raise LipSyncError(f"{where}: the panel's numbers do not fit the preset's fields; pick the preset "
                           "from the menu again") from None


def finder():
    """A preset finder for ``[tags]`` and ``emotion:`` markers, resolving as
    :func:`load_preset` does.  The folders are read now (on the main
    thread); the finder may run in the engine's thread."""
    where, blend_folder = folder(), _blend_folder()

    def find(name: str):
        return _load(_source(name, where, blend_folder))

    return find


# --- saving and deleting --------------------------------------------------------------

def saved_preset_path(name: str) -> str | None:
    """The file of the user's preset ``name``, None if it is not one."""
    return _saved_file(name, folder())


def save_preset(preset: presets.Preset | dict, name: str, overwrite: bool = False) -> str:
    """Save ``preset`` as the user's preset ``name``; returns its path.
    Nothing is written when the name, the preset or the folder is wrong."""
    clean = check_name(name)
    if clean in presets.builtin_names():
        raise LipSyncError(f"{clean!r} is a built-in preset: choose another name")
    path = os.path.join(folder(create=True), clean + ".json")
    if os.path.exists(path) and not overwrite:
        raise LipSyncError(f"a preset named {clean!r} exists: tick Overwrite to replace it")
    try:
        presets.save(preset, path)
    except LipSyncError:
        raise
    except OSError as exc:
        raise LipSyncError(f"cannot save the preset to {path}: {exc.strerror or exc}") from None
    return path


def remove_preset(name: str) -> str:
    """Delete the user's preset ``name`` (and a learned preset's report);
    returns the file deleted.  Built-in presets and anything outside the
    user's folder are never touched."""
    if name.strip() in presets.builtin_names():
        raise LipSyncError(f"{name.strip()!r} is a built-in preset, not one of your presets: built-in presets "
                           "cannot be deleted")
    path = saved_preset_path(name)
    if path is None:
        raise LipSyncError(f"{_short(name.strip())!r} is not one of your presets, so there is nothing to delete")
    try:
        os.remove(path)
        report = path[:-5] + REPORT_SUFFIX
        if os.path.isfile(report):
            os.remove(report)
    except OSError as exc:
        raise LipSyncError(f"cannot delete {path}: {exc.strerror or exc}") from None
    return path
