"""Decode time and peak memory of the engine's audio reader on long files of
the formats games and phones ship, and what each decoder package adds.

A recording of ``--minutes`` (30) of speech is made from the project's own
clips (as ``bench/long_audio.py`` does) and encoded as Ogg Vorbis (44.1 kHz
stereo) and Ogg Opus (48 kHz stereo), and with ``--formats`` also as MP3,
FLAC and M4A (AAC).  Each file is read by a fresh process:

* ``load``: the engine's reader (``audio.load``, decoded a block at a time,
  resampled to 16 kHz into a temporary file), then every sample read back a
  minute at a time: wall time, CPU time, peak resident memory;
* ``soundfile`` and ``av``: the decoder alone, the whole file decoded a block
  at a time and mixed to mono (no resampling), for the speed of each package
  on the same file.

Then the installed size of each decoder package (its files and the native
libraries its wheel bundles).  With ``--analyze`` the full command line
(``python -m addon analyze``) also runs on each file, measured as in
``bench/long_audio.py`` (whole process tree).  Target: under 500 MB.

    .venv/bin/python bench/decode_formats.py
    .venv/bin/python bench/decode_formats.py --minutes 10 --formats ogg opus mp3 flac m4a --analyze
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import subprocess
import sys
import tempfile
import time
import wave

import numpy as np

from common import ROOT
from long_audio import make_recording, measure

from addon.engine.resampling import StreamResampler

#: name -> (extension, rate, how it is written)
FORMATS = {
    "ogg": ("ogg", 44100, "Ogg Vorbis, 44.1 kHz stereo"),
    "opus": ("opus", 48000, "Ogg Opus, 48 kHz stereo"),
    "mp3": ("mp3", 44100, "MP3, 44.1 kHz stereo"),
    "flac": ("flac", 44100, "FLAC 16-bit, 44.1 kHz stereo"),
    "m4a": ("m4a", 44100, "M4A (AAC), 44.1 kHz stereo"),
}
_SF = {"ogg": ("OGG", "VORBIS"), "opus": ("OGG", "OPUS"), "mp3": ("MP3", "MPEG_LAYER_III"), "flac": ("FLAC", "PCM_16")}


def _blocks(wav: str, rate: int, size: int = 1 << 16):
    """The WAV's samples at ``rate``, stereo (the right channel a little
    quieter), a block at a time."""
    with wave.open(wav) as w:
        src = w.getframerate()
        resampler = StreamResampler(src, rate)
        while True:
            raw = w.readframes(size)
            x = np.frombuffer(raw, "<i2").astype(np.float32) / 32768.0
            y = resampler.push(x) if raw else resampler.finish()
            if len(y):
                yield np.stack([y, 0.8 * y], axis=1)
            if not raw:
                return


def encode(wav: str, name: str, folder: str) -> str:
    ext, rate, _ = FORMATS[name]
    path = os.path.join(folder, f"long.{ext}")
    if name in _SF:
        import soundfile

        fmt, subtype = _SF[name]
        with soundfile.SoundFile(path, "w", rate, 2, subtype, format=fmt) as f:
            for block in _blocks(wav, rate):
                f.write(block)
        return path
    import av

    with av.open(path, "w", format="ipod") as c:
        s = c.add_stream("aac", rate=rate, layout="stereo")
        pts = 0
        for block in _blocks(wav, rate):
            for i in range(0, len(block), 1024):
                part = np.ascontiguousarray(block[i:i + 1024].T)
                frame = av.AudioFrame.from_ndarray(part, format="fltp", layout="stereo")
                frame.sample_rate, frame.pts = rate, pts
                pts += part.shape[1]
                for packet in s.encode(frame):
                    c.mux(packet)
        for packet in s.encode(None):
            c.mux(packet)
    return path


_CHILD = r"""
import json, sys, time
import numpy as np
sys.path.insert(0, {root!r})
path, how = sys.argv[1], sys.argv[2]
t0, c0 = time.perf_counter(), time.process_time()
if how == "load":
    from addon.engine import audio
    snd = audio.load(path)
    n, total, step = len(snd.samples), 0.0, 60 * snd.rate
    for a in range(0, n, step):
        total += float(np.square(snd.samples[a:a + step], dtype=np.float64).sum())
    seconds = n / snd.rate
else:
    from addon.engine import decoders
    blocks = decoders.DECODERS[how](path)
    n = 0
    for x in blocks:
        n += len(x)
    seconds = n / blocks.rate
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
with open("/proc/self/status") as fh:   # this process's peak (ru_maxrss would count the parent's before exec)
    peak = next(int(l.split()[1]) for l in fh if l.startswith("VmHWM:")) / 1024.0
print(json.dumps({{"wall": wall, "cpu": cpu, "seconds": seconds, "peak": peak}}))
"""


def run_child(path: str, how: str) -> dict | str:
    r = subprocess.run([sys.executable, "-c", _CHILD.format(root=str(ROOT)), path, how], capture_output=True,
                       text=True)
    if r.returncode != 0:
        return (r.stderr.strip().splitlines() or ["failed"])[-1]
    return json.loads(r.stdout.strip().splitlines()[-1])


def installed_mb(dist: str) -> float:
    """Installed size (MB) of a distribution: its files, the native
    libraries its wheel bundles among them."""
    files = importlib.metadata.distribution(dist).files or []
    return sum(os.path.getsize(f.locate()) for f in files if os.path.isfile(f.locate())) / 2**20


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=30)
    ap.add_argument("--formats", nargs="+", default=["ogg", "opus"], choices=sorted(FORMATS))
    ap.add_argument("--analyze", action="store_true", help="also run the full command line on each file")
    args = ap.parse_args()
    for dist in ("soundfile", "av"):
        try:
            version = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            print(f"{dist}: not installed")
            continue
        print(f"{dist} {version}: {installed_mb(dist):.1f} MB installed")
    worst = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        wav, txt = make_recording(tmp, args.minutes)
        print(f"\n{'file':<32} {'reader':<10} {'wall s':>7} {'x real':>7} {'CPU s':>7} {'peak MB':>8}")
        for name in args.formats:
            t0 = time.perf_counter()
            path = encode(wav, name, tmp)
            size = os.path.getsize(path) / 2**20
            label = f"{FORMATS[name][2]} ({size:.0f} MB)"
            print(f"{label}: encoded in {time.perf_counter() - t0:.0f} s", flush=True)
            for how in ("load", "soundfile", "av"):
                if how == "soundfile" and name == "m4a":
                    continue
                m = run_child(path, how)
                if isinstance(m, str):
                    print(f"{'':<32} {how:<10} {m}")
                    continue
                if how == "load":
                    worst = max(worst, m["peak"])
                print(f"{'':<32} {how:<10} {m['wall']:7.1f} {m['wall'] / m['seconds']:7.4f} {m['cpu']:7.1f} "
                      f"{m['peak']:8.0f}", flush=True)
            if args.analyze:
                seconds, cpu, peak, tree, status, last = measure(path, txt, os.path.join(tmp, "out.json"))
                worst = max(worst, peak, tree)
                print(f"{'':<32} {'analyze':<10} {seconds:7.1f} {seconds / (args.minutes * 60):7.4f} {cpu:7.1f} "
                      f"{peak:8.0f}  (all processes {tree:.0f} MB; status {status}: {last[:60]})", flush=True)
            os.remove(path)
    print("\n(load: the engine's reader, 16 kHz mono kept in a temporary file, every sample read back;"
          "\n soundfile/av: the decoder alone, mixed to mono, not resampled; x real: seconds per second of audio)")
    print(f"peak memory target 500 MB: {'met' if worst < 500 else 'NOT met'} (worst {worst:.0f} MB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
