"""The training report: the learned preset against the starting one on
clips the fit did not see, both through the engine's full synthesis path.

Per held-out clip and per track: correlation with the measured track,
RMSE and peak-timing error (ms between each clear opening or closure of the
measured track and the prediction's), for both presets.  The measured
tracks are read at the capture's estimated delay; proxy and viseme tracks
go through each preset's own calibration (gain and offset per track,
fitted on the training clips).  The learned preset is the one written: the
parts of the fit the held-out check kept (:mod:`.select`), each fold's own.
It is better when, on the held-out clips, its mean correlation over tracks
is higher AND its RMSE is lower; the report says so plainly either way, and
names the parts learned and kept.
"""

from __future__ import annotations

import numpy as np

from .. import visemes
from . import proxies
from .evaluate import rmse_report, track_scores
from .model import synthesise, viseme_curves

WHO = ("learned", "start")


def _predict(setup, preset: dict, clips, train, delay: float, cache: dict) -> list[np.ndarray]:
    """Tracks ``preset`` makes for ``clips``; proxies calibrated on ``train``."""
    learned = preset.get("learned")
    if not setup.calibrated:
        if learned:
            vs, mp = visemes.with_targets(setup.vset, learned["targets"]), learned["targets"]
        else:
            vs, mp = setup.vset, setup.start_map
        return [synthesise(c, preset, vs, setup.channels, setup.fps, mp) for c in clips]

    def raw(c):
        key = (id(preset), c.name)
        if key not in cache:
            cache[key] = viseme_curves(c, preset, setup.vset, setup.fps) @ setup.M0
        return cache[key]

    gain, offset = proxies.calibrate([raw(c) for c in train], [c.aligned(delay) for c in train])
    return [raw(c) * gain + offset for c in clips]


def _mean(values):
    v = [x for x in values if x is not None]
    return round(float(np.mean(v)), 4) if v else None


def build(setup, prepared, results, final, preset, scheme: str, train_i: list[int]) -> dict:
    """The report of :func:`.fit.learn` (without its name and which preset is
    kept); ``train_i``: the clips the final preset was fitted to."""
    channels, fps = setup.channels, setup.fps
    cache: dict = {}
    per_clip, pooled = [], {w: ([], []) for w in WHO}
    for tr, ho, f, fold_preset in results:
        train, hold = [prepared[i] for i in tr], [prepared[i] for i in ho]
        preds = {"learned": _predict(setup, fold_preset, hold, train, f.delay, cache),
                 "start": _predict(setup, setup.base, hold, train, f.delay, cache)}
        for k, c in enumerate(hold):
            y = c.aligned(f.delay)
            tracks = {}
            for j, ch in enumerate(channels):
                tracks[ch] = {w: track_scores(preds[w][k][:, j], y[:, j], fps) for w in WHO}
            per_clip.append({"clip": c.name, "delay_ms": round(1000 * f.delay, 1), "tracks": tracks})
            for w in WHO:
                pooled[w][0].append(preds[w][k])
                pooled[w][1].append(y)

    per_track = {}
    for ch in channels:
        row = {}
        for w in WHO:
            row[w] = {m: _mean([pc["tracks"][ch][w][m] for pc in per_clip])
                      for m in ("correlation", "rmse", "peak_timing_ms")}
        lc, sc = row["learned"]["correlation"], row["start"]["correlation"]
        row["better"] = bool(lc is not None and sc is not None and lc > sc
                             and row["learned"]["rmse"] < row["start"]["rmse"])
        per_track[ch] = row
    summary = {w: {"correlation": _mean([per_track[ch][w]["correlation"] for ch in channels]),
                   "rmse": round(float(np.sqrt(np.mean(np.concatenate(
                       [(p - y) ** 2 for p, y in zip(*pooled[w])])))), 5),
                   "peak_timing_ms": _mean([per_track[ch][w]["peak_timing_ms"] for ch in channels])}
               for w in WHO}
    lc, sc = summary["learned"]["correlation"], summary["start"]["correlation"]
    better = bool(lc is not None and sc is not None and lc > sc
                  and summary["learned"]["rmse"] < summary["start"]["rmse"])
    worse = [ch for ch in channels if per_track[ch]["learned"]["correlation"] is not None
             and per_track[ch]["start"]["correlation"] is not None and not per_track[ch]["better"]]
    if better:
        verdict = (f"The learned preset is better than the starting preset on the held-out clips: correlation "
                   f"{lc:.3f} vs {sc:.3f}, RMSE {summary['learned']['rmse']:.4f} vs {summary['start']['rmse']:.4f}")
    else:
        verdict = (f"The learned preset is NOT better than the starting preset on the held-out clips: correlation "
                   f"{lc if lc is None else round(lc, 3)} vs {sc if sc is None else round(sc, 3)}, RMSE "
                   f"{summary['learned']['rmse']:.4f} vs {summary['start']['rmse']:.4f}")
    if worse:
        verdict += f"; not better on {', '.join(worse[:8])}{' ...' if len(worse) > 8 else ''}"

    train = [prepared[i] for i in train_i]
    held_names = [pc["clip"] for pc in per_clip]
    out = {
        "viseme_set": setup.vset.name, "fps": fps, "channels": channels, "evaluation": scheme,
        "tracks": "proxies (calibrated)" if setup.calibrated else "shape keys (poses learned)",
        "clips": {"train": [c.name for c in train], "heldout": held_names},
        "delay_ms": round(1000 * final.delay, 1),
        "delay_per_fold_ms": [round(1000 * f.delay, 1) for _t, _h, f, _p in results],
        "fit": {"free_parameters": final.free, "iterations": sum(1 for h in final.history if h["iteration"] > 0),
                "best_iteration": final.best_iteration, "stopped": final.stopped,
                "regularisation": setup.regularisation, "closure_weight": setup.closure_weight,
                "history": final.history},
        "per_clip": per_clip, "per_track": per_track, "summary": summary,
        "better_than_builtin": better,
        "better_channels": sorted(ch for ch in channels if per_track[ch]["better"]),
        "verdict": verdict,
        "learned": {"train": rmse_report(_predict(setup, preset, train, train, final.delay, cache),
                                         [c.aligned(final.delay) for c in train], channels),
                    "heldout": rmse_report(pooled["learned"][0], pooled["learned"][1], channels)},
        "builtin": {"train": rmse_report(_predict(setup, setup.base, train, train, final.delay, cache),
                                         [c.aligned(final.delay) for c in train], channels),
                    "heldout": rmse_report(pooled["start"][0], pooled["start"][1], channels)},
    }
    if final.pca is not None:
        out["pca"] = final.pca
        out["poses_clipped"] = final.clipped
    return out


def table(report: dict, channels: list[str] | None = None) -> str:
    """The comparison as text: per held-out clip and track, learned vs start."""
    chans = channels or [ch for ch in report["channels"]
                         if report["per_track"][ch]["start"]["correlation"] is not None][:6]

    def f(v, fmt):
        return "   -  " if v is None else format(v, fmt)

    rows = [(pc["clip"], pc["tracks"]) for pc in report["per_clip"]] + [("mean", report["per_track"])]
    cw = max(len("clip"), *(len(clip) for clip, _t in rows))      # names in full: no two tracks look alike
    tw = max([len("track")] + [len(ch) for ch in chans])
    lines = [f"{'clip':{cw}} {'track':{tw}} {'corr learned/start':>19} {'RMSE learned/start':>19} "
             f"{'peak ms learned/start':>22}"]
    for clip, tracks in rows:
        for ch in chans:
            t = tracks[ch]
            lines.append(f"{clip:{cw}} {ch:{tw}} {f(t['learned']['correlation'], '6.3f'):>9} "
                         f"{f(t['start']['correlation'], '6.3f'):>9} {f(t['learned']['rmse'], '7.4f'):>9} "
                         f"{f(t['start']['rmse'], '7.4f'):>9} {f(t['learned']['peak_timing_ms'], '6.1f'):>10} "
                         f"{f(t['start']['peak_timing_ms'], '6.1f'):>10}")
    return "\n".join(lines)


def summary_text(report: dict) -> str:
    """What ``learn`` prints: how it was evaluated, the comparison table,
    the verdict and which preset was written."""
    r = report
    held = len(r["per_clip"])
    lines = [f"{len(r['clips']['train'])} clips; evaluated on {held} held-out clip{'s' if held != 1 else ''} "
             f"({r['evaluation']}); tracks: {r['tracks']}; capture delay {r['delay_ms']:.1f} ms "
             f"(per fold: {', '.join(f'{d:.1f}' for d in r['delay_per_fold_ms'])})"]
    if "pca" in r:
        lines.append(f"{r['pca']['components']} components keep {100 * r['pca']['variance_kept']:.1f} % of the "
                     f"variance")
    lines.append(f"{r['fit']['iterations']} iterations ({r['fit']['stopped']}) in {r['fit']['seconds']:.1f} s")
    lines.append(table(r))
    for who, label in (("learned", "learned"), ("start", f"start ({r.get('base_preset')})")):
        s = r["summary"][who]
        pt = "-" if s["peak_timing_ms"] is None else f"{s['peak_timing_ms']:.1f} ms"
        c = "-" if s["correlation"] is None else f"{s['correlation']:.3f}"
        lines.append(f"  {label:18} held out: correlation {c}, RMSE {s['rmse']:.4f}, peak timing {pt}")
    lines.append(r["verdict"] + ".")
    parts = r.get("parts")
    if parts:
        lines.append(f"learned: {', '.join(parts['learned']) or 'nothing'}")
        lines.append(f"kept from {r.get('base_preset')}: {', '.join(parts['kept']) or 'nothing'}")
    if r.get("kept") == "start":
        lines.append(f"kept the starting preset {r.get('base_preset')!r} under the new name: no part did better on "
                     "the held-out clips (--keep-learned writes everything learned)")
    elif parts and parts.get("check") is None:
        lines.append("wrote every learned part, as asked")
    return "\n".join(lines)
