"""The face beside speech: blinks, gaze, head and neck motion, brow raises.

Computed from what a run already knows (the words and phones, the pauses
between them, the voice's pitch and loudness) with the numbers of the
emotion preset's ``gestures`` section (:class:`.presets.Gestures`), and the
fixed numbers and channel names of ``data/gestures.json``:

* **Blinks.**  Due now and then at ``blink_rate`` a minute (intervals drawn
  around the mean, never closer than ``min_blink_gap`` s); a due blink is
  moved, with chance ``blink_at_pauses``, to the nearest pause (a gap of at
  least ``pause`` s between words) or else to an accented syllable.  A blink
  closes in a third of its time and opens in the rest (``blink_duration``,
  varied); now and then (``double_blink``) a second follows.  Both lids move
  together, and they follow the gaze down (``lid_follow``).
* **Gaze.**  Fixations held for ``gaze_interval`` s on average, spread
  ``gaze_range`` degrees around a point ``gaze_down`` degrees below level,
  joined by saccades of ``saccade`` s; at a phrase start the eyes look away
  (chance ``look_away``, ``look_away_angle`` degrees) and come back.  Both
  eyes point the same way, within ``eye_limit`` degrees of rest.
* **Head and neck.**  Smooth motion of ``head_range`` degrees whose size
  follows the voice's loudness (``head_follow_voice``), a nod of ``nod``
  degrees on each accented syllable, a slow ``sway``; in pauses the motion
  falls to ``pause_calm`` of its size in speech.
* **Brows** rise on accented syllables (``brow_raise``).

The motion is deterministic: the same line (its words and length) and
``seed`` give the same motion; another seed varies it.  Angles are in
degrees in the character's frame: yaw to the character's left, pitch of the
head downwards (a nod) and of the gaze upwards, roll towards the left
shoulder.  :func:`match` finds the channels a character has for it.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from . import pauses as pauses_mod
from .alignment import Alignment
from .datafile import read_object
from .errors import PresetError
from .language.phonemes import phone_class
from .presets import Gestures

DATA = Path(__file__).parent / "data" / "gestures.json"
#: The grid the motion is made on before it is sampled at the line's frames (s),
#: so that a line gives the same motion at any frame rate.
STEP = 0.01


@lru_cache(maxsize=1)
def table() -> dict:
    """``data/gestures.json``."""
    return read_object(DATA)


@dataclass
class Motion:
    """The gesture layer of one line, on its frames (``times``, s)."""

    times: np.ndarray
    blink: np.ndarray            # per frame: how closed the lids are, 0-1 (both eyes)
    gaze: np.ndarray             # (frames, 2): yaw (left +) and pitch (up +), degrees
    head: np.ndarray             # (frames, 3): pitch (down +), yaw (left +), roll (left +), degrees
    brow: np.ndarray             # per frame: brow raise, 0-1
    blinks: list[tuple[float, float]] = field(default_factory=list)   # (start, duration) s
    accents: list[float] = field(default_factory=list)                # accented syllables, s
    pauses: list[tuple[float, float]] = field(default_factory=list)   # gaps between words, s
    seed: int = 0

    TRACKS = ("blink", "gaze_yaw", "gaze_pitch", "head_pitch", "head_yaw", "head_roll", "brow_raise")

    def tracks(self) -> dict[str, np.ndarray]:
        """Each track by its name in the JSON and CSV (:data:`TRACKS`)."""
        return dict(zip(self.TRACKS, (self.blink, self.gaze[:, 0], self.gaze[:, 1], self.head[:, 0],
                                      self.head[:, 1], self.head[:, 2], self.brow)))

    def to_dict(self) -> dict:
        out = {name: np.round(v, 4).tolist() for name, v in self.tracks().items()}
        out["blinks"] = [{"start": round(a, 4), "duration": round(d, 4)} for a, d in self.blinks]
        out["accents"] = [round(t, 4) for t in self.accents]
        out["seed"] = self.seed
        return out


def _speech(al: Alignment) -> list[tuple[float, float]]:
    """The spoken words' spans, in order, joined where they touch."""
    spans = sorted((w.start, w.end) for w in al.words if w.spoken and w.end > w.start)
    spans += [(a, b) for a, b, _ in al.unscripted]
    out: list[list[float]] = []
    for a, b in sorted(spans):
        if out and a <= out[-1][1] + 1e-6:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return [(a, b) for a, b in out]


def pauses(al: Alignment, min_pause: float | None = None) -> list[tuple[float, float]]:
    """Gaps of at least ``min_pause`` s (``pause`` in ``data/gestures.json``)
    with no word spoken, before the first word and after the last included."""
    return pauses_mod.gaps(_speech(al), al.duration, table()["pause"] if min_pause is None else min_pause)


def accents(al: Alignment, times: np.ndarray, pitch: np.ndarray, intensity: np.ndarray) -> list[float]:
    """The accented syllables: vowels that stand out by loudness and pitch
    (together at least one standard deviation above the line's vowels), at
    most one a 0.5 s, as the vowels' starts."""
    vowels = []
    for p in al.phones:
        if phone_class(p.phone) != "vowel" or p.end <= p.start:
            continue
        i = (times >= p.start) & (times < p.end)
        if not i.any():
            continue
        f = pitch[i][np.isfinite(pitch[i]) & (pitch[i] > 0)]
        vowels.append((p.start, float(np.max(intensity[i])), float(12 * np.log2(np.max(f))) if len(f) else np.nan))
    if len(vowels) < 3:
        return []
    loud = np.array([v[1] for v in vowels])
    semis = np.array([v[2] for v in vowels])
    score = (loud - loud.mean()) / (loud.std() + 1e-9)
    voiced = np.isfinite(semis)
    if voiced.sum() >= 3:
        z = (semis - np.nanmean(semis)) / (np.nanstd(semis) + 1e-9)
        score = score + np.where(voiced, z, 0.0)
    out: list[float] = []
    for k in np.argsort(-score):
        if score[k] < 1.0:
            break
        t = vowels[k][0]
        if all(abs(t - u) >= 0.5 for u in out):
            out.append(t)
    return sorted(out)


def _rng(al: Alignment, seed: int) -> np.random.Generator:
    """The line's own random numbers: its words, its length and ``seed``."""
    words = " ".join(w.text for w in al.words)
    return np.random.default_rng([int(seed) & 0xFFFFFFFF, zlib.crc32(words.encode("utf-8")),
                                  int(round(al.duration * 1000))])


def _near(t: float, spots: list[float], lo: float, hi: float) -> float | None:
    inside = [s for s in spots if lo <= s <= hi]
    return min(inside, key=lambda s: abs(s - t)) if inside else None


def blink_times(al: Alignment, g: Gestures, accents_at: list[float], gaps: list[tuple[float, float]],
                rng: np.random.Generator) -> list[tuple[float, float]]:
    """(start, duration) of each blink (module docstring).  The next blink
    falls due an interval after the last one (drawn around 60 /
    ``blink_rate`` s); the first pause from 0.6 of a mean interval before
    that time to 0.8 after it takes it (with chance ``blink_at_pauses``),
    else it comes on an accented syllable near its time, or when due."""
    if g.blink_rate <= 0 or al.duration <= 0:
        return []
    least = table()["min_blink_gap"]
    mean = 60.0 / g.blink_rate
    # A blink in a pause starts soon after the last word (or, in the
    # silence before the line, shortly before the first word).
    spots = sorted(min(a + 0.08, b - 0.1) if a > 0 else max(0.0, b - 0.35) for a, b in gaps)
    out: list[tuple[float, float]] = []
    last = -np.inf
    due = mean * rng.uniform(0.1, 1.0)
    while True:
        # The first blink is not brought far forward: a line does not open on one by rule.
        early = max(last + least, due - 0.6 * mean if out else 0.6 * due)
        at = None
        pause = next((s for s in spots if s >= early), None)
        take = rng.random() < g.blink_at_pauses
        if take and pause is not None and pause <= due + 0.8 * mean:
            at = pause
        else:
            at = _near(due, accents_at, max(early, due - 0.3), due + 0.6) if rng.random() < 0.5 else None
            at = max(due, last + least) if at is None else at
        length = float(np.clip(g.blink_duration * rng.lognormal(0.0, 0.2), 0.16, 0.5))
        if at + length > al.duration:
            break
        out.append((at, length))
        last = at
        if rng.random() < g.double_blink and at + 2.2 * length < al.duration:
            again = at + length + 0.06
            out.append((again, length * 0.9))
            last = again
        due = last + max(least, mean * rng.gamma(4.0, 0.25))
    return out


def _blink_shape(t: np.ndarray, blinks: list[tuple[float, float]]) -> np.ndarray:
    """The lids over ``t``: each blink closes over its first 30 % (easing
    in), stays shut for 15 %, opens over the rest (easing out)."""
    out = np.zeros(len(t))
    for start, length in blinks:
        x = (t - start) / length
        close = np.sin(np.clip(x / 0.3, 0, 1) * np.pi / 2) ** 2
        open_ = np.sin(np.clip((1 - x) / 0.55, 0, 1) * np.pi / 2) ** 1.5
        shape = np.where(x < 0.3, close, np.where(x < 0.45, 1.0, open_))
        np.maximum(out, np.where((x >= 0) & (x <= 1), shape, 0.0), out=out)
    return out


def _gaze(grid: np.ndarray, g: Gestures, gaps: list[tuple[float, float]], rng: np.random.Generator,
          duration: float) -> np.ndarray:
    """(points, 2) yaw, pitch of the gaze on ``grid``: fixations joined by
    saccades, a look away at phrase starts."""
    cfg = table()
    limit, saccade = cfg["eye_limit"], cfg["saccade"]
    # (start s, yaw, pitch) of each fixation.
    fix: list[tuple[float, float, float]] = [(0.0, 0.0, -g.gaze_down)]
    t = 0.0
    starts = sorted(b for a, b in gaps if b < duration - 0.3 and b - a >= 0.4)
    while True:
        t += float(np.clip(rng.exponential(g.gaze_interval), 0.35, 3.0 * g.gaze_interval))
        t = min(t, fix[-1][0] + 6.0)
        if t >= duration:
            break
        fix.append((t, rng.normal(0, g.gaze_range), -g.gaze_down + rng.normal(0, g.gaze_range * 0.5)))
    for s in starts:
        if rng.random() >= g.look_away:
            continue
        # Looking away as the phrase starts, back to the face within a second or so.
        away = max(0.0, s - rng.uniform(0.1, 0.3))
        side = rng.choice([-1.0, 1.0])
        back = away + rng.uniform(0.6, 1.4)
        before = [f for f in fix if f[0] < away]
        after = [f for f in fix if f[0] > back]
        resume = before[-1] if before else fix[0]
        fix = before + [(away, side * g.look_away_angle, -g.gaze_down - 0.4 * g.look_away_angle),
                        (back, resume[1], resume[2])] + after
    fix.sort()
    yaw = np.zeros(len(grid))
    pitch = np.zeros(len(grid))
    prev_y, prev_p = fix[0][1], fix[0][2]
    yaw[:] = prev_y
    pitch[:] = prev_p
    for s, y, p in fix[1:]:
        x = np.clip((grid - s) / saccade, 0, 1)
        ease = x * x * (3 - 2 * x)
        on = grid >= s
        yaw[on] = (prev_y + (y - prev_y) * ease)[on]
        pitch[on] = (prev_p + (p - prev_p) * ease)[on]
        prev_y, prev_p = y, p
    out = np.stack([yaw, pitch], axis=1)
    return np.clip(out, -limit, limit)


def _smooth_noise(n: int, sigma: float, rng: np.random.Generator, axes: int) -> np.ndarray:
    """(n, axes) noise smoothed over ``sigma`` s (Gaussian), unit spread."""
    pad = int(4 * sigma / STEP)
    raw = rng.standard_normal((n + 2 * pad, axes))
    k = np.exp(-0.5 * (np.arange(-pad, pad + 1) * STEP / sigma) ** 2)
    k /= k.sum()
    out = np.stack([np.convolve(raw[:, j], k, mode="same")[pad:pad + n] for j in range(axes)], axis=1)
    return out / (out.std(axis=0, keepdims=True) + 1e-12)


def _envelope(grid: np.ndarray, spans: list[tuple[float, float]], ramp: float) -> np.ndarray:
    """1 inside ``spans``, 0 far from them, easing over ``ramp`` s."""
    d = np.full(len(grid), np.inf)
    for a, b in spans:
        d = np.minimum(d, np.maximum(np.maximum(a - grid, grid - b), 0.0))
    x = np.clip(1 - d / ramp, 0, 1)
    return x * x * (3 - 2 * x)


def _bump(grid: np.ndarray, centre: float, before: float, after: float) -> np.ndarray:
    x = np.where(grid < centre, (grid - centre) / before, (grid - centre) / after)
    return np.where(np.abs(x) < 1, 0.5 * (1 + np.cos(np.pi * x)), 0.0)


#: How long the head takes to drift back towards rest (s).
DRIFT = 0.7


def _leaky(v: np.ndarray) -> np.ndarray:
    """The running sum of ``v`` (points, axes) over :data:`STEP` s, each
    point's share fading with time constant :data:`DRIFT`."""
    keep = np.exp(-np.arange(int(5 * DRIFT / STEP)) * STEP / DRIFT)
    return np.stack([np.convolve(v[:, j], keep)[:len(v)] * STEP for j in range(v.shape[1])], axis=1)


@lru_cache(maxsize=1)
def _unit_spread() -> float:
    """The spread (degrees per unit) of the head's motion in speech at its
    usual loudness, made the way :func:`_head` makes it, over 10 minutes."""
    rng = np.random.default_rng(0)
    n = int(600 / STEP)
    way = _smooth_noise(n, 0.12, rng, 3)
    way /= np.linalg.norm(way, axis=1, keepdims=True) + 1e-9
    pace = 0.75 + 0.25 * np.abs(_smooth_noise(n, 0.3, rng, 1)[:, 0])
    return float(_leaky(way * pace[:, None]).std(axis=0).mean())


def _head(grid: np.ndarray, g: Gestures, speech: list[tuple[float, float]], loud: np.ndarray,
          accents_at: list[float], rng: np.random.Generator) -> np.ndarray:
    """(points, 3) pitch, yaw, roll of the head on ``grid``.  The head's
    angular speed is smooth noise scaled by the voice (loudness in speech,
    ``pause_calm`` in pauses); the angle is its leaky sum, so that it drifts
    back towards rest, scaled to ``head_range`` degrees in speech."""
    talking = _envelope(grid, speech, 0.15)
    level = loud[talking > 0.5].mean() if (talking > 0.5).any() else 1.0
    follow = g.head_follow_voice * np.clip(loud / max(level, 1e-6), 0, 2) + (1 - g.head_follow_voice)
    drive = g.pause_calm + (np.where(talking > 0, follow, 1.0) - g.pause_calm) * talking
    # The direction wanders smoothly; the speed is the voice's, a little varied.
    way = _smooth_noise(len(grid), 0.12, rng, 3)
    way /= np.linalg.norm(way, axis=1, keepdims=True) + 1e-9
    pace = 0.75 + 0.25 * np.abs(_smooth_noise(len(grid), 0.3, rng, 1)[:, 0])
    # Scaled so that speech at its usual loudness moves head_range degrees,
    # the same on a short line as on a long one, and a line with little
    # speech stays as calm as the pauses of any other.
    head = _leaky(way * (drive * pace)[:, None]) * (g.head_range * np.array([1.0, 0.8, 0.5]) / _unit_spread())
    freqs = rng.uniform(0.06, 0.18, 3)
    phases = rng.uniform(0, 2 * np.pi, 3)
    head += g.sway * np.sin(2 * np.pi * freqs[None, :] * grid[:, None] + phases[None, :]) * np.array([0.6, 1, 0.6])
    for t in accents_at:
        head[:, 0] += g.nod * _bump(grid, t + 0.05, 0.15, 0.3)
        head[:, 2] += g.nod * 0.25 * rng.choice([-1.0, 1.0]) * _bump(grid, t + 0.05, 0.15, 0.35)
    return head


def compute(al: Alignment, times: np.ndarray, voice_times: np.ndarray, pitch: np.ndarray, intensity: np.ndarray,
            g: Gestures, seed: int = 0) -> Motion:
    """The gesture layer of a line on its frames ``times``, from its
    alignment and the voice's pitch (Hz, NaN unvoiced) and intensity (dB)
    tracks on ``voice_times`` (module docstring)."""
    rng = _rng(al, seed)
    cfg = table()
    duration = max(al.duration, float(times[-1]) if len(times) else 0.0)
    grid = np.arange(0.0, duration + STEP, STEP)
    voice_times = np.asarray(voice_times, dtype=float)
    intensity = np.asarray(intensity, dtype=float)
    if len(voice_times):
        db = np.interp(grid, voice_times, intensity)
        f0 = np.asarray(pitch, dtype=float)
    else:
        db, f0 = np.zeros(len(grid)), np.zeros(0)
    top = np.percentile(db, 95) if len(db) else 0.0
    loud = np.clip(1 - (top - db) / 25.0, 0, 1)
    speech = _speech(al)
    gaps = pauses(al)
    accents_at = accents(al, voice_times, f0, intensity) if len(voice_times) else []
    # Each part draws from its own stream, so tuning one leaves the others as they were.
    r_blink, r_gaze, r_head = (np.random.default_rng(s) for s in rng.integers(0, 2**32, 3))
    blinks = blink_times(al, g, accents_at, gaps, r_blink)
    gaze = _gaze(grid, g, gaps, r_gaze, duration)
    head = _head(grid, g, speech, loud, accents_at, r_head)
    lids = _blink_shape(grid, blinks)
    follow = g.lid_follow * cfg["lid_follow_limit"] * np.clip(-gaze[:, 1] / cfg["look_range"]["vertical"] * 2, 0, 1)
    lids = np.maximum(lids, follow)
    brow = np.zeros(len(grid))
    for t in accents_at:
        np.maximum(brow, g.brow_raise * _bump(grid, t + 0.02, 0.12, 0.35), out=brow)

    def sample(v):
        v = np.asarray(v)
        if v.ndim == 1:
            return np.interp(times, grid, v)
        return np.stack([np.interp(times, grid, v[:, j]) for j in range(v.shape[1])], axis=1)

    return Motion(np.asarray(times, dtype=float), sample(lids), sample(gaze), sample(head), sample(brow),
                  blinks=blinks, accents=accents_at, pauses=gaps, seed=seed)


# --- a character's channels -------------------------------------------------------


@dataclass
class Channels:
    """The channels a character has for the gesture layer: shape keys by
    role (``blink_L``, ``look_up_R`` ...: :data:`SHAPE_ROLES`) and bones by
    role (``head``, ``neck``, ``eye_L``, ``eye_R``)."""

    shape_keys: dict[str, str] = field(default_factory=dict)
    bones: dict[str, str] = field(default_factory=dict)
    #: Why the bones cannot be keyed, where they cannot (an armature linked from a library).
    bones_locked: str = ""

    def missing(self, head_elsewhere: bool = False) -> list[str]:
        """What the character lacks, in words: blinks, gaze, head."""
        out = []
        if not any(r.startswith("blink") for r in self.shape_keys):
            out.append("blinks (no eyeBlink or Fcl_EYE_Close keys)")
        if self.bones_locked:
            return out + [self.bones_locked]
        if not any(r.startswith("look") for r in self.shape_keys) and \
                not {"eye_L", "eye_R"} & set(self.bones):
            out.append("gaze (no eyeLook keys or eye bones)")
        if not head_elsewhere and not {"head", "neck"} & set(self.bones):
            out.append("head (no Head or Neck bone)")
        return out


def check_table(doc: dict, source: str) -> dict:
    """A studio's own channel table (``gestures.json``: ``shape_keys`` and
    ``bones``, each role -> list of names), checked: a malformed field is a
    :class:`.errors.PresetError` naming the file and the field."""
    roles = {"shape_keys": set(table()["shape_keys"]), "bones": set(table()["bones"])}
    for kind in doc:
        if kind not in roles:
            raise PresetError(source, kind, "is not a field of a gestures table (expected shape_keys, bones)")
        if not isinstance(doc[kind], dict):
            raise PresetError(source, kind, "must map roles (blink_L, head ...) to lists of names")
        for role, names in doc[kind].items():
            if role not in roles[kind]:
                raise PresetError(source, f"{kind}.{role}",
                                  f"is not a role (expected one of: {', '.join(sorted(roles[kind]))})")
            if not isinstance(names, list) or not all(isinstance(n, str) and n for n in names):
                raise PresetError(source, f"{kind}.{role}", "must be a list of names")
    return doc


def _plain(name: str) -> str:
    return name.rsplit(":", 1)[-1].lower()


def match(shape_keys: list[str], bones: list[str] = (), extra: dict | None = None) -> Channels:
    """The gesture channels among a character's ``shape_keys`` and
    ``bones``, by the names of ``data/gestures.json`` (and ``extra``, a
    studio's own table of the same shape: its names come first)."""
    found = Channels()
    tables = [t for t in (extra, table()) if t]
    for kind, names, out in (("shape_keys", shape_keys, found.shape_keys), ("bones", bones, found.bones)):
        by_plain: dict[str, str] = {}
        for n in names:
            by_plain.setdefault(_plain(n), n)
        for t in tables:
            for role, candidates in t.get(kind, {}).items():
                if role in out:
                    continue
                hit = next((by_plain[_plain(c)] for c in candidates if _plain(c) in by_plain), None)
                if hit is not None:
                    out[role] = hit
    if "blink" in found.shape_keys and ("blink_L" in found.shape_keys or "blink_R" in found.shape_keys):
        del found.shape_keys["blink"]   # the eyes' own keys, not the one closing both
    return found


def shape_key_curves(motion: Motion, channels: Channels) -> dict[str, np.ndarray]:
    """The shape keys' values: blinks on the blink keys, the gaze on the
    look keys (full at ``look_range`` degrees)."""
    rng = table()["look_range"]
    yaw, up = motion.gaze[:, 0], motion.gaze[:, 1]
    h, v = rng["horizontal"], rng["vertical"]
    roles = {
        "blink_L": motion.blink, "blink_R": motion.blink, "blink": motion.blink,
        "look_up_L": np.clip(up / v, 0, 1), "look_up_R": np.clip(up / v, 0, 1),
        "look_down_L": np.clip(-up / v, 0, 1), "look_down_R": np.clip(-up / v, 0, 1),
        # Yaw to the character's left: the left eye looks out, the right eye in.
        "look_out_L": np.clip(yaw / h, 0, 1), "look_in_R": np.clip(yaw / h, 0, 1),
        "look_in_L": np.clip(-yaw / h, 0, 1), "look_out_R": np.clip(-yaw / h, 0, 1),
    }
    out: dict[str, np.ndarray] = {}
    for role, key in channels.shape_keys.items():
        out[key] = np.maximum(out[key], roles[role]) if key in out else np.clip(roles[role], 0, 1)
    return out


def _axis_angle(axis: np.ndarray, degrees: np.ndarray) -> np.ndarray:
    """Quaternions (w, x, y, z) turning ``degrees`` about a unit ``axis``."""
    half = np.radians(degrees) / 2
    return np.concatenate([np.cos(half)[:, None], np.sin(half)[:, None] * axis[None, :]], axis=1)


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=1)


def character_turns(pitch_down: np.ndarray, yaw_left: np.ndarray, roll_left: np.ndarray) -> np.ndarray:
    """Quaternions (frames, 4) in the character's frame (Blender's: facing
    -Y, up +Z, its left +X): a yaw about +Z, then a pitch about +X (down for
    a positive angle), then a roll about +Y."""
    x, y, z = np.eye(3)
    return _qmul(_qmul(_axis_angle(z, yaw_left), _axis_angle(x, pitch_down)), _axis_angle(y, roll_left))


def in_bone_frame(turns: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """``turns`` (quaternions in the character's frame) as a bone's own
    rotation, for a bone whose rest orientation in the character's frame is
    the 3x3 matrix ``rest`` (its columns the bone's axes): R' = restᵀ R rest."""
    rest = np.asarray(rest, dtype=float)
    w, v = turns[:, :1], turns[:, 1:]
    return np.concatenate([w, v @ rest], axis=1)


def bone_turns(motion: Motion, channels: Channels) -> dict[str, np.ndarray]:
    """Each found bone's turn in the character's frame (quaternions): the
    head's shared between neck and head (``neck_share``), the gaze on both
    eyes alike."""
    share = table()["neck_share"] if "neck" in channels.bones and "head" in channels.bones else \
        (1.0 if "neck" in channels.bones else 0.0)
    pitch, yaw, roll = motion.head.T
    out = {}
    if "neck" in channels.bones:
        out[channels.bones["neck"]] = character_turns(share * pitch, share * yaw, share * roll)
    if "head" in channels.bones:
        out[channels.bones["head"]] = character_turns((1 - share) * pitch, (1 - share) * yaw, (1 - share) * roll)
    for eye in ("eye_L", "eye_R"):
        if eye in channels.bones:
            out[channels.bones[eye]] = character_turns(-motion.gaze[:, 1], motion.gaze[:, 0],
                                                       np.zeros(len(motion.times)))
    return out


__all__ = ["Channels", "Motion", "accents", "blink_times", "bone_turns", "character_turns", "check_table", "compute",
           "in_bone_frame", "match", "pauses", "shape_key_curves", "table"]
