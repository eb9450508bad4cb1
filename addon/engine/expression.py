"""The emotion on the whole face: an expression layer beside the articulation.

A preset's ``expression`` field names FACS action units and their strengths
(happy ``{"AU6": 0.5, "AU12": 0.6}``: cheeks raised, lip corners pulled),
after the EMFACS prototypes.  :func:`unit_curves` turns them into one curve
per unit over the line, alive rather than a mask:

* it eases in before the first phoneme and out after the last
  (``lead``, ``ease_in``, ``ease_out`` seconds);
* it follows the voice: the arousal track (-1 calm to +1 excited) scales it
  by 1 + ``follow_voice`` x arousal;
* the brows (AU1, AU2) rise on pitch accents, vowels ``accent_semitones`` or
  more above the line's median pitch, by up to ``accent_brows`` of the
  preset's strongest unit (neutral, with no units, keeps its face still);
* it is smoothed over ``smoothing`` seconds, so it never jitters;
* units of the lower face give way on /p b m/: each is scaled by
  1 - ``closure_yield`` x the closure track, so the lips can meet.

The numbers are in ``data/expression.json``.  Emotion tags and markers
cross-fade the units as they do the articulation (:func:`mix`).

On a rig, each unit drives the shape keys its naming convention names
(:func:`.conventions.expression_match`, :func:`key_curves`).  Where speech
and expression drive one key (ARKit's ``mouthSmile*``, ``mouthFrown*``,
``mouthStretch*``, ``mouthPress*``, ``jawOpen``), :func:`combine` adds them
as 1 - (1 - speech)(1 - expression): either alone is unchanged, together
they never pass 1, and the rig's closure rule applied afterwards still
closes the lips.  On /p b m/ the closing pose's own pressing keys
(``mouthPress*``, ``mouthRoll*``) give way to a mouth the expression
already holds closed (:func:`seal`): a smile or a tightened mouth pressed
again by the closure would push the lips through each other.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

from . import conventions
from .datafile import read_object
from .language import phone_class
from .smoothing import gaussian

DATA = Path(__file__).parent / "data" / "expression.json"
BROW_RAISERS = ("AU1", "AU2")


@lru_cache(maxsize=1)
def _data() -> dict:
    return read_object(DATA)


def units() -> dict[str, dict]:
    """The action units: name -> {name, region ("upper"/"lower"), closure_yield}."""
    return _data()["units"]


def dynamics() -> dict[str, float]:
    return _data()["dynamics"]


def lower_face(unit: str) -> bool:
    return units().get(unit, {}).get("region") == "lower"


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def envelope(times: np.ndarray, phones: list[tuple[str, float, float]]) -> np.ndarray:
    """0 to 1: the expression easing in before the line's first phoneme and
    out after its last (silences at the ends do not count)."""
    d = dynamics()
    spoken = [(s, e) for ph, s, e in phones if phone_class(ph) != "silence"]
    if not spoken or len(times) == 0:
        return np.zeros(len(times))
    start, end = spoken[0][0], spoken[-1][1]
    rise = _smoothstep((times - (start - d["lead"])) / max(d["ease_in"], 1e-6))
    fall = _smoothstep(((end + d["lead"]) - times) / max(d["ease_out"], 1e-6))
    return rise * fall


def accents(times: np.ndarray, phones: list[tuple[str, float, float]], pitch: np.ndarray) -> np.ndarray:
    """0 to 1 per frame: the pitch accents.  A vowel ``accent_semitones``
    above the median of the line's voiced vowels is an accent, full at twice
    that; it shows as a raised-cosine bump ``accent_span`` s either side of
    the vowel's centre."""
    d = dynamics()
    out = np.zeros(len(times))
    pitch = np.asarray(pitch, dtype=float)
    vowels = [(s, e, f) for (ph, s, e), f in zip(phones, pitch) if phone_class(ph) == "vowel" and np.isfinite(f)
              and f > 0]
    if len(vowels) < 2 or len(times) == 0:
        return out
    median = np.median([f for _, _, f in vowels])
    thr, span = d["accent_semitones"], d["accent_span"]
    for s, e, f in vowels:
        st = 12.0 * np.log2(f / median)
        if st < thr:
            continue
        amount = min(1.0, st / (2.0 * thr))
        x = (times - (s + e) / 2) / span
        bump = np.where(np.abs(x) < 1.0, 0.5 * (1.0 + np.cos(np.pi * x)), 0.0)
        np.maximum(out, amount * bump, out=out)
    return out


def closing(times: np.ndarray, phones: list[tuple[str, float, float]]) -> np.ndarray:
    """Per frame, how much the lower face must give way to closed lips: 1
    over every /p b m/ from its first instant to its last (as the speech's
    other visemes are suppressed there), falling to 0 over ``closure_ramp``
    seconds either side."""
    ramp = dynamics()["closure_ramp"]
    out = np.zeros(len(times))
    for ph, s, e in phones:
        if phone_class(ph) == "bilabial":
            distance = np.maximum(np.maximum(s - times, times - e), 0.0)
            np.maximum(out, 1.0 - np.minimum(distance / ramp, 1.0), out=out)
    return out


def unit_curves(strengths: dict[str, float], times: np.ndarray, phones: list[tuple[str, float, float]],
                pitch: np.ndarray, fps: float, arousal: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Per action unit, its value on every frame, in [0, 1] (module
    docstring).  ``strengths`` is a preset's ``expression``; ``pitch`` is
    per phoneme (Hz, NaN unvoiced); ``arousal`` per frame, -1 to 1 (None:
    the voice is not followed).  A preset with no units gives none."""
    strengths = {u: float(s) for u, s in strengths.items() if s > 0}
    if not strengths:
        return {}
    d = dynamics()
    times = np.asarray(times, dtype=float)
    env = envelope(times, phones)
    gain = np.ones(len(times))
    if arousal is not None:
        gain = np.clip(1.0 + d["follow_voice"] * np.asarray(arousal, dtype=float), 0.0, 2.0)
    lift = d["accent_brows"] * max(strengths.values()) * accents(times, phones, pitch)
    closure = closing(times, phones)
    sigma = d["smoothing"] * fps
    out = {}
    raised = set(BROW_RAISERS) if lift.any() else set()
    for unit in sorted(set(strengths) | raised, key=lambda u: int(u[2:])):
        value = strengths.get(unit, 0.0) * gain
        if unit in BROW_RAISERS:
            value = value + lift
        value = gaussian(np.clip(value * env, 0.0, 1.0), sigma)
        value = value * (1.0 - units()[unit]["closure_yield"] * closure)
        value[value < 1e-3] = 0.0      # the smoothing's far tails: still is exactly still
        out[unit] = np.clip(value, 0.0, 1.0)
    return out


def mix(per_preset: list[dict[str, np.ndarray]], shares: np.ndarray) -> dict[str, np.ndarray]:
    """The presets' unit curves cross-faded by ``shares`` (frames, presets),
    as :func:`.emotion_track.mix` gives them; a unit a preset lacks is 0 there."""
    names = sorted({u for curves in per_preset for u in curves}, key=lambda u: int(u[2:]))
    out = {}
    for unit in names:
        value = sum(shares[:, k] * curves[unit] for k, curves in enumerate(per_preset) if unit in curves)
        out[unit] = np.clip(value, 0.0, 1.0)
    return out


def key_curves(curves: dict[str, np.ndarray], mapping: dict[str, dict[str, float]], frames: int
               ) -> tuple[list[str], np.ndarray]:
    """Unit curves -> shape-key names and (frames, keys) values: a key
    several units drive takes their weighted sum, clipped to 1.  Units with
    no key in ``mapping`` are left out."""
    keys: list[str] = []
    for unit in curves:
        for k in mapping.get(unit, {}):
            if k not in keys:
                keys.append(k)
    out = np.zeros((frames, len(keys)))
    for unit, value in curves.items():
        for k, w in mapping.get(unit, {}).items():
            out[:, keys.index(k)] += w * np.asarray(value, dtype=float)[:frames]
    return keys, np.clip(out, 0.0, 1.0)


def give_way(names: list[str], values: np.ndarray, lower: set[str], times: np.ndarray,
             phones: list[tuple[str, float, float]]) -> np.ndarray:
    """``values`` (frames, keys) with the keys in ``lower`` scaled by
    1 - :func:`closing`: on a rig whose basis shows closed lips (VRoid,
    viseme rigs) a mouth expression shape, whatever else it does, must not
    hold the lips apart on /p b m/."""
    values = np.array(values, dtype=float, copy=True)
    cols = [j for j, k in enumerate(names) if k in lower]
    if cols and len(values):
        values[:, cols] *= (1.0 - closing(np.asarray(times, dtype=float), phones))[:, None]
    return values


def combine(names: list[str], values: np.ndarray, ex_names: list[str], ex_values: np.ndarray
            ) -> tuple[list[str], np.ndarray]:
    """Speech keys and expression keys in one table: a key both drive takes
    1 - (1 - speech)(1 - expression), bounded by 1 and equal to either one
    where the other is 0; the expression's other keys are appended."""
    names = list(names)
    values = np.asarray(values, dtype=float)
    extra, cols = [], []
    values = values.copy()
    for j, k in enumerate(ex_names):
        if k in names:
            i = names.index(k)
            values[:, i] = 1.0 - (1.0 - values[:, i]) * (1.0 - ex_values[:, j])
        else:
            extra.append(k)
            cols.append(j)
    if extra:
        values = np.hstack([values.reshape(len(ex_values), -1), ex_values[:, cols]])
    return names + extra, np.clip(values, 0.0, 1.0)


def seal(names: list[str], values: np.ndarray, pressing: set[str], ex_names: list[str], ex_values: np.ndarray,
         lower: set[str], times: np.ndarray, phones: list[tuple[str, float, float]]) -> np.ndarray:
    """The speech's ``values`` (frames, keys) with the closing pose's own
    pressing keys (``pressing``: ARKit's ``mouthPress*``, ``mouthRoll*``)
    giving way, on /p b m/, to the mouth's expression: lips a smile, a frown
    or a tightener already holds together need less pressing, and pressed
    by both they pass through each other.  Each is scaled by 1 - closure x
    hold (closure: :func:`closing`), where hold is the strongest of the expression's mouth keys
    (``lower``, among ``ex_names``) on that frame over ``seal_hold``, at
    most 1: a mouth key at ``seal_hold`` or more holds the closed lips on
    its own."""
    values = np.array(values, dtype=float, copy=True)
    cols = [j for j, k in enumerate(names) if k in pressing]
    held = [j for j, k in enumerate(ex_names) if k in lower]
    if cols and held and len(values):
        hold = dynamics()["seal_hold"]
        level = np.clip(np.asarray(ex_values, dtype=float)[:, held].max(axis=1) / hold, 0.0, 1.0)
        c = closing(np.asarray(times, dtype=float), phones)
        values[:, cols] *= (1.0 - c * level)[:, None]
    return values


def fit(clips, channels: list[str], fps: float, floor: float = 0.05) -> dict[str, dict]:
    """Each action unit's strength as a capture shows it (an ARKit capture
    carries the brows, cheeks and eyes): per unit, the channels the naming
    conventions name for it, averaged by their weights, less their value
    at rest (where the unit's curve is 0, outside the line), fitted by least
    squares to the unit's curve at strength 1 (:func:`unit_curves`, without
    the voice).  ``clips`` holds (frame times, (frames, channels) values,
    phones as (phone, start, end), pitch per phone).  Returns {unit:
    {"strength": 0-1, "channels": [...]}} for the units the channels show;
    a strength below ``floor`` is 0.  No expression channel: {}."""
    face = conventions.expression_match([""] + list(channels), conventions.load_all())
    out = {}
    for unit, mix in face.mapping.items():
        cols = [channels.index(k) for k in mix]
        w = np.array([mix[k] for k in mix]) / sum(mix.values())
        num = den = 0.0
        for times, y, phones, pitch in clips:
            model = unit_curves({unit: 1.0}, times, phones, pitch, fps)[unit]
            c = np.asarray(y, dtype=float)[:, cols] @ w
            rest = float(np.median(c[model == 0])) if (model == 0).any() else 0.0
            num += float((c - rest) @ model)
            den += float(model @ model)
        strength = min(max(num / den, 0.0), 1.0) if den > 0 else 0.0
        out[unit] = {"strength": round(strength, 3) if strength >= floor else 0.0, "channels": list(mix)}
    return out
