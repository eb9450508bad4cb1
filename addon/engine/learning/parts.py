"""The parts of a preset that learning judges one at a time.

Each part is learned from the clips or kept from the starting preset by the
held-out check (:mod:`.select`).  The groups are data,
``data/articulation/groups.json``:

* timing: the dominance parameters of a group of phoneme classes, the
  onset/offset rates (theta, phi) apart from strength and shape (alpha,
  c);
* poses (shape-key tracks only): every viseme's pose on a group of tracks,
  one articulator each (jaw, lip aperture and closure, rounding,
  spreading); a track no group names, such as a rig's viseme key, is a part
  of its own.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from ..conventions import canonical
from ..language import CLASSES
from .model import PARAMS

GROUPS = Path(__file__).resolve().parent.parent / "data" / "articulation" / "groups.json"


@dataclass(frozen=True)
class Part:
    kind: str                    # "timing" or "poses"
    name: str                    # "lips onset/offset", "jaw poses"
    cells: tuple                 # timing: ((class index, parameter index), ...); poses: track indices


def _groups() -> dict:
    return json.loads(GROUPS.read_text(encoding="utf-8"))


def _matches(pattern: str, name: str) -> bool:
    if pattern.endswith("*"):
        return canonical(name).startswith(canonical(pattern[:-1]))
    return canonical(name) == canonical(pattern)


def track_group(channel: str) -> str:
    """The articulator group a track belongs to; the track's own name when
    no group names it."""
    for group, patterns in _groups()["tracks"].items():
        if any(_matches(p, channel) for p in patterns):
            return group
    return channel


def timing_parts(free: list[tuple[int, int]]) -> list[Part]:
    """The timing parts among the free (class, parameter) cells of a fit."""
    g = _groups()["timing"]
    out = []
    for cname, classes in g["classes"].items():
        ks = {CLASSES.index(c) for c in classes}
        for pname, params in g["parameters"].items():
            ps = {PARAMS.index(p) for p in params}
            cells = tuple((k, p) for k, p in free if k in ks and p in ps)
            if cells:
                out.append(Part("timing", f"{cname} {pname}", cells))
    return out


def pose_parts(channels: list[str]) -> list[Part]:
    """The pose parts of shape-key tracks, by articulator, in track order."""
    order, members = [], {}
    for j, ch in enumerate(channels):
        g = track_group(ch)
        if g not in members:
            order.append(g)
            members[g] = []
        members[g].append(j)
    return [Part("poses", f"{g} poses", tuple(members[g])) for g in order]
