"""``python -m addon arousal AUDIO [AUDIO ...]``: one line per file,
``PATH<TAB>AROUSAL`` (three decimals), or with ``--json`` one JSON object per
line holding the value, the features and the track.  A file that cannot be
read is a one-line error on stderr; the others are still printed and the
exit status is 1."""

from __future__ import annotations

import json
import sys

from . import arousal
from .errors import LipSyncError


def run(paths: list[str], as_json: bool = False) -> int:
    try:
        model = arousal.load_model()
    except LipSyncError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    status = 0
    for path in paths:
        try:
            est = arousal.estimate_file(path, model)
        except LipSyncError as exc:
            print(f"error: {exc}", file=sys.stderr)
            status = 1
            continue
        if as_json:
            print(json.dumps({"path": path, **est.to_dict()}, separators=(",", ":")))
        else:
            print(f"{path}\t{est.value:.3f}")
        sys.stdout.flush()
    return status
