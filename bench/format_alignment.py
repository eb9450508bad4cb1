"""How far a line's alignment moves when the line is stored in another format.

Each line is written as FLAC, Ogg Vorbis, Ogg Opus, MP3 and M4A (AAC), and
as a WAV through a noise gate (every 10 ms frame 45 dB under the line's loud
frames set to zero), read back by the engine's reader and aligned with its
transcript; every phone boundary is compared with the alignment of the
original file.  Printed per
format: the share of boundaries within 10 ms and within 20 ms of the
original's, and the largest move.

Lines: the project's sample (``sample_rigs/speech/hello.wav``, synthetic
speech with pauses of exact digital silence) and, when ``../shared/data``
is here, the hand-labelled TIMIT sentences (``timit_nltk``, every
``--every``-th one).  A lossy codec changes the sound by tens of dB below
the speech; the aligner decides some boundaries (a pause inserted or not
between two words, where a fricative fades out) on differences that small;
it hears every clip over a fixed noise floor (``audio.FLOOR_DB``) so that
they do not reach it.

    .venv/bin/python bench/format_alignment.py
    LIPSYNC_DATA=/work/shared/data .venv/bin/python bench/format_alignment.py --every 3
    .venv/bin/python bench/format_alignment.py --floor-db -300      # without the floor
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import soundfile

from common import DATA, ROOT
from addon.engine.pipeline import analyze

#: name -> (suffix, libsndfile format and subtype, or None for AAC through av)
FORMATS = {
    "flac": (".flac", ("FLAC", "PCM_16")),
    "ogg-vorbis": (".ogg", ("OGG", "VORBIS")),
    "ogg-opus": (".opus", ("OGG", "OPUS")),
    "mp3": (".mp3", ("MP3", "MPEG_LAYER_III")),
    "m4a-aac": (".m4a", None),
    "noise-gate": (".wav", "gate"),
}

#: The gate: every 10 ms frame this far (dB) under the line's loud frames is set to zero.
GATE_DB = -45.0


def gate(x: np.ndarray, rate: int) -> np.ndarray:
    """The line through a noise gate, as an editor's or a recorder's."""
    size = rate // 100
    n = len(x) // size * size
    rms = np.sqrt((x[:n].reshape(-1, size).astype(np.float64) ** 2).mean(axis=1))
    y = x.copy()
    y[:n] *= np.repeat(rms > np.percentile(rms, 95) * 10 ** (GATE_DB / 20), size)
    return y


def write(path: Path, x: np.ndarray, rate: int, how) -> None:
    if how is not None:
        fmt, subtype = how
        if fmt == "OGG" and subtype == "OPUS" and rate not in (8000, 12000, 16000, 24000, 48000):
            from addon.engine.resampling import resample

            x, rate = resample(x, rate, 48000), 48000
        with soundfile.SoundFile(str(path), "w", rate, 1, subtype, format=fmt) as f:
            for i in range(0, len(x), 1 << 15):
                f.write(x[i:i + (1 << 15)])
        return
    import av

    with av.open(str(path), "w", format="ipod") as c:
        s = c.add_stream("aac", rate=rate, layout="mono")
        for i in range(0, len(x), 1024):
            frame = av.AudioFrame.from_ndarray(np.ascontiguousarray(x[None, i:i + 1024]), format="fltp",
                                               layout="mono")
            frame.sample_rate, frame.pts = rate, i
            for packet in s.encode(frame):
                c.mux(packet)
        for packet in s.encode(None):
            c.mux(packet)


def boundaries(result) -> np.ndarray:
    return np.array([[p.start, p.end] for p in result.alignment.phones]).ravel()


def lines(every: int) -> list[tuple[str, Path, str]]:
    hello = ROOT / "sample_rigs" / "speech" / "hello.wav"
    out = [("hello", hello, hello.with_suffix(".txt").read_text(encoding="utf-8"))]
    timit = DATA / "timit_nltk"
    if timit.is_dir():
        for wav in sorted(timit.glob("*/*.wav"))[::every]:
            text = " ".join(wav.with_suffix(".txt").read_text().split()[2:])
            out.append((f"timit {wav.parent.name}/{wav.stem}", wav, text))
    else:
        print(f"({timit} is not here: the sample line only)")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--every", type=int, default=2, help="every N-th TIMIT sentence (default 2)")
    ap.add_argument("--floor-db", type=float, default=None,
                    help="the aligner's noise floor, dB under the loud frames (default: the engine's; -300: none)")
    args = ap.parse_args()
    if args.floor_db is not None:
        from addon.engine import audio

        audio.FLOOR_DB = args.floor_db
    moves: dict[str, dict[str, list[np.ndarray]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, wav, text in lines(args.every):
            original = boundaries(analyze(str(wav), text))
            x, rate = soundfile.read(str(wav), dtype="float32", always_2d=True)
            x = x.mean(axis=1)
            group = "sample (hello.wav)" if name == "hello" else "TIMIT sentences"
            for fmt, (suffix, how) in FORMATS.items():
                path = Path(tmp) / f"line{suffix}"
                if how == "gate":
                    soundfile.write(str(path), gate(x, rate), rate, subtype="FLOAT")
                else:
                    write(path, x, rate, how)
                got = boundaries(analyze(str(path), text))
                if len(got) != len(original):
                    raise SystemExit(f"{name} as {fmt}: {len(got)} boundaries against {len(original)}")
                moves.setdefault(group, {}).setdefault(fmt, []).append(np.abs(got - original))
    for group, per in moves.items():
        n = len(next(iter(per.values())))
        print(f"\n{group}: {n} line(s); phone boundaries against the original file's alignment")
        print(f"{'format':12s} {'boundaries':>10s} {'<=10 ms':>8s} {'<=20 ms':>8s} {'largest':>8s}")
        for fmt, d in per.items():
            d = np.round(np.concatenate(d), 4)
            print(f"{fmt:12s} {len(d):10d} {np.mean(d <= 0.010):8.3f} {np.mean(d <= 0.020):8.3f} "
                  f"{1000 * d.max():6.0f} ms")


if __name__ == "__main__":
    main()
