"""A scene localized from a stored self-calibration estimate, for `validate` and
`other_simulator.py`: the estimate is what the self-calibration learned on the scene's twin
rendered without its noise sources (the same array, room and talker), saved with `host-sim locate
--selfcal-out` and read with `--selfcal-in`, as a board starts from its estimate store; each
scoring window is scored with `host-sim score`."""

import json
import os
import subprocess
import sys
import tempfile


def _run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{os.path.basename(sys.argv[0])}: {' '.join(cmd)} failed:\n{r.stderr}")
    return r.stdout


def score_from_stored(hs, folder, scene, twin, windows, flags=()):
    """`scene` (a WAV in `folder`, its truth NAME.pos.csv beside it) localized from the estimate
    learned on `twin` (a WAV in `folder`), with the extra localizer `flags`; per window (set name,
    from, to; times as text) a `{"set", "settled"}` entry as `host-sim eval --json` gives it."""
    flags = list(flags)
    truth = os.path.join(folder, os.path.splitext(scene)[0] + ".pos.csv")
    with tempfile.TemporaryDirectory() as tmp:
        est, rows = os.path.join(tmp, "estimate.bin"), os.path.join(tmp, "scene.csv")
        _run([hs, "locate", os.path.join(folder, twin), "--quiet", "--csv",
              os.path.join(tmp, "twin.csv"), "--selfcal-out", est] + flags)
        _run([hs, "locate", os.path.join(folder, scene), "--quiet", "--csv", rows,
              "--selfcal-in", est] + flags)
        return [{"set": name,
                 "settled": json.loads(_run([hs, "score", rows, truth, "--from", lo, "--to", hi,
                                             "--json"]))["sets"][0]["settled"]}
                for name, lo, hi in windows]
