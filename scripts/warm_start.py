#!/usr/bin/env python3
"""How much a board's stored self-calibration estimate helps short recordings: scores the short
scenes of scripts/selfcal_validation.py folders started cold (the ideal capsule) and started from the
estimate the same array learned in an earlier session, and writes docs/warm-start.md (never edit it
by hand).

The earlier session stands for what the board heard before it was switched off and on again: per
short scene, `host-sim scene` renders 60 s of a synthetic talker jumping between six places (no
room) with 3-D diffuse pink noise at 6 dB through the same capsules (gains, β, β drift of the
scene's NAME.array.json); `host-sim locate --selfcal-out` saves what the self-calibration learned,
and `host-sim locate --selfcal-in` starts the short scene from it, as the firmware starts from its
estimate store. Every short scene is localized with the default settings both ways and scored with
`host-sim score` on the window of its manifest line (the window `host-sim eval` scores); the table
pools the scored frames. The ideal twins (ideal/shortNNN, earlier session through the ideal array)
show that a stored estimate costs an ideal array nothing. A second table looks at the drift/dirnoiseNN
scenes (a directional noise source from the first sample on): the final estimate's capsule errors
started cold and started from an earlier session's estimate.

Needs Python 3 and a release build of host-sim (env HS; default target/release/host-sim). Not part
of the test suite. Takes a few minutes per validation folder.

Usage: scripts/warm_start.py SCVAL_DIR [SCVAL_DIR ...] [--out docs/warm-start.md]
"""

import argparse
import concurrent.futures
import csv
import json
import math
import os
import random
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HS = os.environ.get("HS", os.path.join(ROOT, "target", "release", "host-sim"))


def run(args):
    r = subprocess.run([HS] + args, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"warm_start.py: host-sim {' '.join(args)} failed:\n{r.stderr}")
    return r.stdout


def score(wav, window, start, work):
    """(frames, frames within 10°, sum of absolute errors) of `wav` in `window`, from `start`."""
    est = os.path.join(work, "est.csv")
    flags = ["--selfcal-in", start] if start else []
    with open(est, "w") as f:
        f.write(run(["locate", wav, "-q"] + flags))
    rep = json.loads(run(["score", est, wav[:-4] + ".pos.csv", "--json",
                          "--from", str(window[0]), "--to", str(window[1])]))
    s = rep["sets"][0]["settled"]
    n = s["frames"]
    return n, s["acc"][9] / 100.0 * n, (s["mae"] or 0.0) * n


def earlier_session(array, seed, work):
    """Renders the earlier session for the capsules `array` in `work`, localizes it and returns the
    path of the estimate it saved."""
    rng = random.Random(seed)
    azimuths = []
    while len(azimuths) < 6:
        a = rng.uniform(-180, 180)
        if all(abs((a - b + 180) % 360 - 180) >= 40 for b in azimuths[-1:]):
            azimuths.append(a)
    track = ",".join(f"{10 * i}:{a:.1f}" for i, a in enumerate(azimuths))
    earlier = os.path.join(work, "earlier.wav")
    flags = ["scene", "--synth", "60", "--track", track, "--snr", "6",
             "--seed", str(seed), "--out", earlier]
    if not array["ideal"]:
        flags += ["--capsule-gain-db", ",".join(str(g) for g in array["gains_db"]),
                  "--capsule-beta", ",".join(str(b) for b in array["betas"])]
        if array["beta_drift"]:
            flags += ["--beta-drift", str(array["beta_drift"]),
                      "--drift-corner", str(array["drift_corner_hz"])]
    run(flags)
    saved = os.path.join(work, "earlier.selfcal")
    run(["locate", earlier, "-q", "--selfcal-out", saved])
    return saved


def scene_job(folder, name, window, seed):
    """Cold and warm scores of one short scene."""
    wav = os.path.join(folder, name)
    with open(wav[:-4] + ".array.json") as f:
        array = json.load(f)["array"]
    with tempfile.TemporaryDirectory() as work:
        saved = earlier_session(array, seed, work)
        return score(wav, window, None, work), score(wav, window, saved, work)


def capsule_errors(path, array):
    """Mean absolute error, over bands and cardioids, of the saved estimate at `path` against the
    scene's capsules: relative gain (each gain minus the three's mean, dB: a common gain is not
    observable) and, for scenes without β drift, β."""
    gains, betas = [], []
    with open(path) as f:
        for line in f:
            if not line[:1].isdigit():
                continue
            v = [float(x) for x in line.split(",")]
            a, b = v[4:7], v[7:10]
            g = [20 * math.log10(a[m] + b[m]) for m in range(3)]
            truth = array["gains_db"]
            gains += [abs((g[m] - sum(g) / 3) - (truth[m] - sum(truth) / 3)) for m in range(3)]
            if not array["beta_drift"]:
                betas += [abs(b[m] / (a[m] + b[m]) - array["betas"][m]) for m in range(3)]
    return gains, betas


def held_job(folder, name, seed):
    """Capsule errors of a directional-noise scene's final estimate, started cold and from an
    earlier session's estimate, and of that earlier estimate."""
    wav = os.path.join(folder, name)
    with open(wav[:-4] + ".array.json") as f:
        array = json.load(f)["array"]
    with tempfile.TemporaryDirectory() as work:
        earlier = earlier_session(array, seed, work)
        cold, warm = os.path.join(work, "cold.selfcal"), os.path.join(work, "warm.selfcal")
        run(["locate", wav, "-q", "--selfcal-out", cold])
        run(["locate", wav, "-q", "--selfcal-in", earlier, "--selfcal-out", warm])
        return [capsule_errors(p, array) for p in (earlier, cold, warm)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+", help="output folders of scripts/selfcal_validation.py")
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "warm-start.md"))
    args = ap.parse_args()

    # (row label, folder, manifest set).
    kinds = [("short, imperfect", "imperfect", "short"), ("short, ideal", "ideal", "short")]
    jobs = []
    for d in args.dirs:
        for label, sub, wanted in kinds:
            folder = os.path.join(d, sub)
            with open(os.path.join(folder, "manifest.csv")) as f:
                for row in csv.DictReader(f):
                    if row["set"] == wanted:
                        seed = 7919 * len(jobs) + 17
                        window = (float(row["score_from_s"]), float(row["score_to_s"]))
                        jobs.append((label, (folder, row["file"], window, seed)))
    if not jobs:
        sys.exit("warm_start.py: no short scenes in the folders given")
    held = []
    for d in args.dirs:
        with open(os.path.join(d, "drift", "manifest.csv")) as f:
            for row in csv.DictReader(f):
                if row["set"] == "drift_dirnoise":
                    seed = 7919 * (len(jobs) + len(held)) + 17
                    held.append((os.path.join(d, "drift"), row["file"], seed))
    totals = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
        futures = [(label, pool.submit(scene_job, *job)) for label, job in jobs]
        held_futures = [pool.submit(held_job, *job) for job in held]
        for label, fut in futures:
            for start, (n, ok, err) in zip(("cold", "warm"), fut.result()):
                t = totals.setdefault((label, start), [0, 0.0, 0.0, 0])
                t[0] += n
                t[1] += ok
                t[2] += err
                t[3] += 1
        held_errors = [f.result() for f in held_futures]

    names = " ".join(os.path.basename(os.path.normpath(d)) for d in args.dirs)
    lines = [
        "# Short recordings: cold start and a stored estimate",
        "",
        "Written by `scripts/warm_start.py` (never edit by hand). The firmware keeps its",
        "self-calibration's estimate in flash and starts from it after a power cycle",
        "([firmware/README.md](../firmware/README.md), estimate store); `host-sim --selfcal-in` does",
        "the same with a saved estimate. This page measures what that is worth on the short scenes",
        "(3 s of speech in a room at 3 dB, see [self-calibration.md](self-calibration.md)) of the",
        f"validation folders {names} of `scripts/selfcal_validation.py`.",
        "",
        "Per scene, the earlier session is 60 s of a synthetic talker jumping between six places, with",
        "diffuse noise at 6 dB, through the same capsules (no room); its saved estimate starts the",
        "short scene. Default settings; frames pooled over the scenes, each scored on its manifest",
        "window (`host-sim score`, the window `host-sim eval` scores).",
        "",
        "| scenes | start | count | frames | ACC10 | MAE |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for label, _, _ in kinds:
        for start, how in (("cold", "cold (ideal capsule)"),
                           ("warm", "from the earlier session's estimate")):
            if (label, start) not in totals:
                continue
            n, ok, err, scenes = totals[(label, start)]
            lines.append(f"| {label} | {how} | {scenes} | {n} | {100 * ok / n:.1f} % | "
                         f"{err / n:.2f}° |")
    if held_errors:
        lines += [
            "",
            "## A noise source present from power-on",
            "",
            "The validation folders' drift/dirnoiseNN scenes: 60 s of a static talker with a pink-noise",
            "source elsewhere in the room from the first sample on (0 dB on the omni, diffuse noise at",
            "20 dB), through an imperfect array. Started cold, the self-calibration cannot tell that",
            "source from a capsule error; started from an estimate learned in an earlier session (as",
            "above), it may hold it. Mean absolute error of the final estimate against the scene's",
            "capsules, over bands and cardioids: the gains relative to their mean (a common gain is not",
            "observable) over every scene, β over the scenes without β drift.",
            "",
            "| estimate | scenes | relative gain error | β error (scenes) |",
            "|---|---:|---:|---:|",
        ]
        for i, what in enumerate(("the earlier session's (the start of the warm run)",
                                  "after the scene, started cold",
                                  "after the scene, started from the earlier session's")):
            gains = [g for e in held_errors for g in e[i][0]]
            betas = [b for e in held_errors for b in e[i][1]]
            beta = (f"{sum(betas) / len(betas):.3f} ({len(betas) // 12})" if betas else "–")
            lines.append(f"| {what} | {len(held_errors)} | {sum(gains) / len(gains):.2f} dB | "
                         f"{beta} |")
    page = "\n".join(lines) + "\n"
    print(page)
    with open(args.out, "w") as f:
        f.write(page)


if __name__ == "__main__":
    main()
