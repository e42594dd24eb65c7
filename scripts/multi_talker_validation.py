#!/usr/bin/env python3
"""Builds a multi-talker validation folder in image-source rooms, scores it with `host-sim eval`
and writes docs/multi-talker.md's tables from the result (never edit those by hand).

Per scene the script draws a shoebox (4-8 x 3.5-7 x 2.5-3.2 m) with RT60 uniform in 0.3-0.55 s,
places the array >= 1 m from the walls at 1.2-1.6 m height and 2 or 3 talkers 1-2 m away
(horizontally) at 1.2-1.8 m height, >= 0.5 m from the walls, at azimuths >= 60 degrees apart. Each
talker gets its own first-order AmbiX room response from pyroomacoustics' image sources
(scripts/ism_validation.py's `image_source_ambix`, physical 1/r gain), and `host-sim scene
--talkers` renders the conversation (speech clips from shared/data/src/speech, one speaker per
talker) with 3-D diffuse pink noise:

* turns2, turns3: 2 or 3 talkers taking turns (utterances of 1-3 s, gaps 0.2-0.8 s, one in five
  followed by a short overlap), 6 dB diffuse noise, 30 s;
* together2: two talkers speaking at once at equal level, 10 dB, 15 s;
* moving2: turns of 2 talkers, 6 dB, the first circling at 10 degrees/s (its room response is
  rotated with it), 30 s.

Then `host-sim eval OUT_DIR --json` scores the tracks, and the single-talker eval folder is scored
with the stage off and on (the single-azimuth estimate must be identical). As a reference for the
tracks' error, the single-azimuth estimate (`host-sim locate`) is scored on the frames of the turn
scenes where exactly one talker speaks (outside the 0.25 s collar): its mean error within 20° of
that talker is what the room leaves for any track. `--plots DIR` also draws every scene's tracks
(`host-sim eval --plots`). `--imperfect DIR` also renders the same scenes through imperfect arrays
(a draw per scene: cardioid gains within +-1 dB, beta within 0.42-0.58, every second scene a
frequency-dependent beta) into DIR and scores them with the self-calibration on and off.
`--other-rooms DIR` also renders the turn-taking and together kinds with plane-wave talkers and
with every talker through a measured first-order room response (MEASURED_RIR, by default the
3D-MARCo response in shared/data/src/rir, which is not part of the repository) and scores them.
The summary tables go into docs/multi-talker.md and README.md (between their markers).

Needs Python 3 with numpy, scipy and pyroomacoustics and a release build of host-sim. Not part of
the test suite.

Usage: scripts/multi_talker_validation.py OUT_DIR [--seeds N] [--seed S] [--plots DIR]
       [--imperfect DIR] [--other-rooms DIR] [--doc docs/multi-talker.md] [--readme README.md]
"""

import argparse
import csv
import glob
import json
import os
import subprocess
import sys

import numpy as np
import scipy.io.wavfile as wavfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ism_validation as ism  # noqa: E402
import selfcal_validation as scv  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HOST_SIM = os.environ.get("HS", os.path.join(ROOT, "target", "release", "host-sim"))
SPEECH = os.environ.get("SPEECH", os.path.join(ROOT, "..", "shared", "data", "src", "speech"))
EVAL = os.environ.get("EVAL", os.path.join(ROOT, "..", "shared", "data", "eval"))
MEASURED_RIR = os.environ.get("MEASURED_RIR", os.path.join(
    ROOT, "..", "shared", "data", "src", "rir", "marco_p90deg_3m_FOA_ACN_SN3D.wav"))
FS = 16000

# (set, talkers, talk, snr dB, seconds, move deg/s)
KINDS = [
    ("turns2", 2, "turns", 6, 30, None),
    ("turns3", 3, "turns", 6, 30, None),
    ("together2", 2, "together", 10, 15, None),
    ("moving2", 2, "turns", 6, 30, 10.0),
]

# The targets: (set, recall, precision, mean error, purity, switches per minute).
TARGETS = {
    "turns2": (0.90, 0.95, 3.0, 0.95, 1.0),
    "turns3": (0.90, 0.95, 3.0, 0.95, 1.0),
    "together2": (0.80, 0.90, 5.0, 0.90, None),
}


def room(rng):
    """Room dimensions, RT60, array position, and a function placing a talker at an azimuth."""
    while True:
        dims = np.array([rng.uniform(4, 8), rng.uniform(3.5, 7), rng.uniform(2.5, 3.2)])
        rt60 = rng.uniform(0.3, 0.55)
        try:
            ism.pra.inverse_sabine(rt60, dims)
        except ValueError:
            continue
        rx = np.array([rng.uniform(1.0, dims[0] - 1.0), rng.uniform(1.0, dims[1] - 1.0),
                       rng.uniform(1.2, 1.6)])
        return dims, rt60, rx


def talker_positions(rng, dims, rx, n):
    """n talker positions (1-2 m, >= 0.5 m from the walls) at azimuths >= 60 degrees apart."""
    for _ in range(10000):
        az = rng.uniform(0, 360, n)
        if any(abs(ism.wrap180(az[i] - az[j])) < 60 for i in range(n) for j in range(i + 1, n)):
            continue
        pos = []
        for a in az:
            r = rng.uniform(1.0, 2.0)
            p = rx + r * np.array([np.cos(np.radians(a)), np.sin(np.radians(a)), 0.0])
            p[2] = rng.uniform(1.2, 1.8)
            pos.append(p)
        if all(np.all(p > 0.5) and np.all(p < dims - 0.5) for p in pos):
            return az, pos
    raise RuntimeError("no talker placement")


def run(args, **kw):
    return subprocess.run(args, check=True, capture_output=True, text=True, **kw)


def capsule_flags(seed0, s, n):
    """The capsule flags of an imperfect array, drawn as scripts/selfcal_validation.py draws them
    (every second scene with a frequency-dependent beta), per scene apart from the room's draws."""
    rng = np.random.default_rng([seed0, s, n, 77])
    return scv.array_flags(scv.draw_array(rng, with_drift=s % 2 == 1))


def build(out, seeds, seed0, imperfect=False):
    speech = sorted(glob.glob(os.path.join(SPEECH, "*.wav")))
    if not speech:
        sys.exit(f"no speech in {SPEECH}")
    os.makedirs(out, exist_ok=True)
    manifest = os.path.join(out, "manifest.csv")
    if os.path.exists(manifest):
        os.remove(manifest)
    rng = np.random.default_rng(seed0)
    rooms = []
    for kind, n, talk, snr, seconds, move in KINDS:
        for s in range(seeds):
            dims, rt60, rx = room(rng)
            az, pos = talker_positions(rng, dims, rx, n)
            name = os.path.join(out, f"{kind}_{s:02d}.wav")
            cmd = [HOST_SIM, "scene", "--talkers", str(n), "--talk", talk, "--synth", str(seconds),
                   "--snr", str(snr), "--seed", str(seed0 + 100 * s + n), "--out", name,
                   "--azimuths", ",".join(f"{ism.wrap180(a):.1f}" for a in az),
                   "--manifest", manifest, "--set", kind, "--rir-length", "0.8"]
            cmd += ["--talker-rir-direct", ",".join(f"{ism.wrap180(a):.1f}" for a in az)]
            if move is not None:
                cmd += ["--move-first", str(move)]
            voices = rng.permutation(len(speech))
            for k, p in enumerate(pos):
                rir = os.path.join(out, f"rir{k}.wav")
                h = ism.image_source_ambix(dims, rt60, rx, p, lambda r: 4.0 * np.pi * r)
                wavfile.write(rir, FS, h.astype(np.float32))
                cmd += ["--talker-rir", rir, "--talker-source", speech[voices[k]]]
            if imperfect:
                cmd += capsule_flags(seed0, s, n)
            run(cmd)
            for k in range(n):
                os.remove(os.path.join(out, f"rir{k}.wav"))
            rooms.append((kind, rt60))
            print(name, flush=True)
    return rooms


# The kinds of the other rooms (no targets for moving talkers, so no moving2).
OTHER_KINDS = [k for k in KINDS if k[5] is None]
# (folder, label) of the other rooms.
OTHER_ROOMS = [("plane", "plane waves (no room)"),
               ("measured", f"a measured room ({os.path.basename(MEASURED_RIR)}, every talker through "
                            "the same response)")]


def build_other(out, seeds, seed0):
    """The turn-taking and together scenes with plane-wave talkers (no room) and with every talker
    through the measured first-order room response, rotated to his azimuth (drawn by host-sim
    scene, >= 60 degrees apart); one folder per room under OUT."""
    speech = sorted(glob.glob(os.path.join(SPEECH, "*.wav")))
    if not os.path.exists(MEASURED_RIR):
        sys.exit(f"no measured room response at {MEASURED_RIR} (set MEASURED_RIR)")
    rng = np.random.default_rng([seed0, 11])
    for folder, _ in OTHER_ROOMS:
        d = os.path.join(out, folder)
        os.makedirs(d, exist_ok=True)
        manifest = os.path.join(d, "manifest.csv")
        if os.path.exists(manifest):
            os.remove(manifest)
        for kind, n, talk, snr, seconds, _ in OTHER_KINDS:
            for s in range(seeds):
                name = os.path.join(d, f"{kind}_{s:02d}.wav")
                cmd = [HOST_SIM, "scene", "--talkers", str(n), "--talk", talk, "--synth",
                       str(seconds), "--snr", str(snr), "--seed", str(seed0 + 100 * s + n + 50),
                       "--out", name, "--manifest", manifest, "--set", kind, "--rir-length", "0.8"]
                for k in rng.permutation(len(speech))[:n]:
                    cmd += ["--talker-source", speech[k]]
                    if folder == "measured":
                        cmd += ["--talker-rir", MEASURED_RIR]
                run(cmd)
                print(name, flush=True)


def read_truth(path):
    """(times, azimuths, speaking) of a talker truth CSV (`t_s,azimuth_deg,speaking`)."""
    t, az, sp = [], [], []
    with open(path) as f:
        for row in csv.DictReader(f):
            t.append(float(row["t_s"]))
            az.append(float(row["azimuth_deg"]))
            sp.append(row["speaking"] == "1")
    return np.array(t), np.array(az), np.array(sp)


def truth_at(truth, t):
    i = max(int(np.searchsorted(truth[0], t, side="right")) - 1, 0)
    return truth[1][i], bool(truth[2][i])


def single_estimate_error(out, report, collar=0.25, tolerance=20.0):
    """Per set of turn scenes: mean error (within `tolerance`) and share within it of the
    single-azimuth estimate on frames where exactly one talker speaks, outside the collar."""
    per_set = {}
    for s in report["scene_scores"]:
        if not s["set"].startswith("turns"):
            continue
        wav = os.path.join(out, s["file"])
        base = wav[:-4]
        truths, k = [], 1
        while os.path.exists(f"{base}.talker{k}.csv"):
            truths.append(read_truth(f"{base}.talker{k}.csv"))
            k += 1
        est = os.path.join(out, "single-estimate.csv")
        run([HOST_SIM, "locate", wav, "--csv", est, "--quiet"])
        errors, frames = per_set.setdefault(s["set"], ([], [0]))
        with open(est) as f:
            for row in csv.DictReader(f):
                t = float(row["t_s"])
                speaking = [i for i, tr in enumerate(truths) if truth_at(tr, t)[1]]
                if len(speaking) != 1:
                    continue
                tr = truths[speaking[0]]
                if not all(truth_at(tr, t + d)[1] for d in (-collar, collar)):
                    continue
                frames[0] += 1
                e = abs(ism.wrap180(float(row["azimuth_deg"]) - truth_at(tr, t)[0]))
                if e <= tolerance:
                    errors.append(e)
        os.remove(est)
    return {k: (float(np.mean(e)) if e else float("nan"), len(e) / max(n[0], 1))
            for k, (e, n) in per_set.items()}


def pct(v):
    return f"{100 * v:.1f} %"


def summary_table(report):
    lines = ["| set | scenes | recall | precision | mean error | ID switches / min | ID purity | worst ID |",
             "|---|---|---|---|---|---|---|---|"]
    for s in report["sets"]:
        m = s["metrics"]
        lines.append(
            f"| {s['set']} | {s['scenes']} | {pct(m['recall'])} | {pct(m['precision'])} | "
            f"{m['mean_error_deg']:.2f}° | {m['id_switches_per_min']:.2f} | {pct(m['id_purity'])} | "
            f"{pct(m['worst_id_purity'])} |")
    return lines


def span_table(report):
    """Utterance-span metrics (`eval`: speaking from the start to the end of each utterance, collar
    `span_collar_s`) and the share of those frames with a live track near the talker."""
    lines = ["| set | span recall | span precision | a track within 20° (active or not) |",
             "|---|---|---|---|"]
    for s in report["sets"]:
        m = s["metrics"]
        lines.append(f"| {s['set']} | {pct(m['span_recall'])} | {pct(m['span_precision'])} | "
                     f"{pct(m['span_located'])} |")
    return lines


def target_checks(report):
    """Per set of the report with targets: its name and (met, target text) per metric."""
    sets = {s["set"]: s["metrics"] for s in report["sets"]}
    for name, (rec, prec, err, pur, sw) in TARGETS.items():
        if name not in sets:
            continue
        m = sets[name]
        yield name, [
            (m["recall"] >= rec, f"≥ {pct(rec)}"),
            (m["precision"] >= prec, f"≥ {pct(prec)}"),
            (m["mean_error_deg"] <= err, f"≤ {err:.0f}°"),
            (m["id_purity"] >= pur, f"≥ {pct(pur)}"),
            None if sw is None else (m["id_switches_per_min"] <= sw, f"≤ {sw:.0f}"),
        ]


def target_table(report):
    """The targets of the issue against a report's sets (✓ met, ✗ missed)."""
    lines = ["| set | recall | precision | mean error | ID purity | switches / min |",
             "|---|---|---|---|---|---|"]
    for name, checks in target_checks(report):
        cells = ["—" if c is None else f"{'✓' if c[0] else '✗'} {c[1]}" for c in checks]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines


def room_line(label, report):
    """One line for the README: the mean error per set in a room, and whether every target holds."""
    errors = ", ".join(f"{s['set']} {s['metrics']['mean_error_deg']:.2f}°" for s in report["sets"]
                       if s["set"] in TARGETS)
    met = all(c is None or c[0] for _, checks in target_checks(report) for c in checks)
    return (f"With {label}: mean error {errors}; "
            + ("every target met." if met else "**not every target met** (docs/multi-talker.md)."))


def write_readme(readme, report, rooms, seeds, seed0, other=None):
    begin = "<!-- multi-talker:begin (written by scripts/multi_talker_validation.py; do not edit by hand) -->"
    end = "<!-- multi-talker:end -->"
    text = open(readme).read()
    if begin not in text or end not in text:
        sys.exit(f"{readme}: no multi-talker markers")
    lines = [begin,
             f"Measured in image-source rooms (RT60 {min(r for _, r in rooms):.2f}–"
             f"{max(r for _, r in rooms):.2f} s, {seeds} scenes per kind, seed {seed0}; matched within "
             f"{report['tolerance_deg']:.0f}°):", ""] + summary_table(report)
    if other is not None:
        lines += [""] + [room_line(label, rep) for (_, label), rep in zip(OTHER_ROOMS, other)]
    lines += [end]
    head, rest = text.split(begin, 1)
    tail = rest.split(end, 1)[1]
    with open(readme, "w") as f:
        f.write(head + "\n".join(lines) + tail)


def write_doc(doc, report, rooms, seeds, seed0, single_same, single, imperfect=None, other=None):
    lines = [
        "<!-- generated by scripts/multi_talker_validation.py — do not edit -->",
        "## Measured (generated)",
        "",
        f"{seeds} scenes per kind (seed {seed0}), image-source rooms with RT60 "
        f"{min(r for _, r in rooms):.2f}–{max(r for _, r in rooms):.2f} s, talkers 1–2 m away and "
        "≥ 60° apart; matched within "
        f"{report['tolerance_deg']:.0f}°, collar {report['collar_s']} s "
        f"(`scripts/multi_talker_validation.py OUT --seed {seed0} --seeds {seeds}"
        + (" --imperfect DIR" if imperfect is not None else "")
        + (" --other-rooms DIR" if other is not None else "") + "`).",
        "",
    ] + summary_table(report) + [
        "", f"Over whole utterance spans (speaking from the start to the end of each utterance, "
        f"collar {report['span_collar_s']} s; `eval`'s span metrics):", ""] + span_table(report)
    if imperfect is not None:
        on, off = imperfect
        lines += ["", "The same scenes through imperfect arrays (`--imperfect DIR`: per scene cardioid "
                  "gains within ±1 dB, β within 0.42–0.58, every second scene a frequency-dependent β "
                  "within ±0.1), each a cold start of the self-calibration:", "",
                  "| set | self-calibration | recall | precision | mean error | ID switches / min "
                  "| ID purity |", "|---|---|---|---|---|---|---|"]
        for a, b in zip(on["sets"], off["sets"]):
            for label, m in (("on (default)", a["metrics"]), ("off", b["metrics"])):
                lines.append(f"| {a['set']} | {label} | {pct(m['recall'])} | {pct(m['precision'])} | "
                             f"{m['mean_error_deg']:.2f}° | {m['id_switches_per_min']:.2f} | "
                             f"{pct(m['id_purity'])} |")
    lines += ["", "The single-azimuth estimate on the same turn scenes, on frames where exactly one "
              "talker speaks (outside the collar): the room's bias that any track inherits.", "",
              "| set | single estimate: mean error within 20° | frames within 20° |", "|---|---|---|"]
    for name, (err, share) in sorted(single.items()):
        lines.append(f"| {name} | {err:.2f}° | {pct(share)} |")
    lines += ["", "Against the targets (✓ met, ✗ missed):", ""] + target_table(report)
    if other is not None:
        lines += ["", "### Other rooms", "",
                  f"The turn-taking and together kinds again ({seeds} scenes each, same noise and "
                  "lengths, talkers ≥ 60° apart at azimuths drawn by `host-sim scene`), with "
                  "plane-wave talkers and with every talker through one measured first-order room "
                  "response rotated to his azimuth (`--other-rooms DIR`; the response is "
                  f"`{os.path.basename(MEASURED_RIR)}` (MEASURED_RIR), not part of the "
                  "repository). The image-source rooms above put the talkers 1–2 m from the array "
                  "in small rooms, where the early reflections bias every direction (the single "
                  "estimate's error above); here they do not.", ""]
        for (_, label), rep in zip(OTHER_ROOMS, other):
            lines += [f"{label[0].upper()}{label[1:]}:", ""] + summary_table(rep) + [""] \
                + target_table(rep) + [""]
    lines += ["", "Per scene:", "",
              "| scene | recall | precision | mean error | switches / min | ID purity |",
              "|---|---|---|---|---|---|"]
    for s in report["scene_scores"]:
        m = s["metrics"]
        lines.append(f"| {s['file']} | {pct(m['recall'])} | {pct(m['precision'])} | "
                     f"{m['mean_error_deg']:.2f}° | {m['id_switches_per_min']:.2f} | "
                     f"{pct(m['id_purity'])} |")
    lines += ["", "Single-talker eval folder with the stage on: the `eval --json` report is "
              + ("identical to the one with the stage off." if single_same
                 else "**different** from the one with the stage off."), ""]
    text = open(doc).read() if os.path.exists(doc) else ""
    marker = "<!-- generated by scripts/multi_talker_validation.py — do not edit -->"
    head = text.split(marker)[0] if marker in text else text
    with open(doc, "w") as f:
        f.write(head + "\n".join(lines))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out")
    p.add_argument("--seeds", type=int, default=4, help="scenes per kind (default 4)")
    p.add_argument("--seed", type=int, default=3000)
    p.add_argument("--doc", default=os.path.join(ROOT, "docs", "multi-talker.md"))
    p.add_argument("--no-build", action="store_true", help="score an existing folder")
    p.add_argument("--readme", default=os.path.join(ROOT, "README.md"))
    p.add_argument("--plots", help="also draw every scene's tracks into this folder")
    p.add_argument("--imperfect", help="also build (or with --no-build score) the same scenes through "
                   "imperfect arrays in this folder")
    p.add_argument("--other-rooms", help="also build (or with --no-build score) the turn-taking and "
                   "together kinds with plane-wave talkers and through a measured room response "
                   "(MEASURED_RIR) in this folder")
    args = p.parse_args()
    if not os.access(HOST_SIM, os.X_OK):
        sys.exit(f"no host-sim at {HOST_SIM} (cargo build --release -p host-sim)")
    if args.no_build:
        rooms = json.load(open(os.path.join(args.out, "rooms.json")))
    else:
        rooms = build(args.out, args.seeds, args.seed)
        json.dump(rooms, open(os.path.join(args.out, "rooms.json"), "w"))
    report = json.loads(run([HOST_SIM, "eval", args.out, "--json"]).stdout)
    json.dump(report, open(os.path.join(args.out, "report.json"), "w"), indent=1)
    off = run([HOST_SIM, "eval", EVAL, "--json"]).stdout
    on = run([HOST_SIM, "eval", EVAL, "--json", "--multi-talker", "on"]).stdout
    single = single_estimate_error(args.out, report)
    imperfect = None
    if args.imperfect:
        if not args.no_build:
            build(args.imperfect, args.seeds, args.seed, imperfect=True)
        imperfect = tuple(json.loads(run([HOST_SIM, "eval", args.imperfect, "--json"] + extra).stdout)
                          for extra in ([], ["--selfcal", "off"]))
    other = None
    if args.other_rooms:
        if not args.no_build:
            build_other(args.other_rooms, args.seeds, args.seed)
        other = [json.loads(run([HOST_SIM, "eval", os.path.join(args.other_rooms, folder),
                                 "--json"]).stdout) for folder, _ in OTHER_ROOMS]
    write_doc(args.doc, report, rooms, args.seeds, args.seed, off == on, single, imperfect, other)
    write_readme(args.readme, report, rooms, args.seeds, args.seed, other)
    if args.plots:
        run([HOST_SIM, "eval", args.out, "--plots", args.plots])
    print(run([HOST_SIM, "eval", args.out]).stdout)


if __name__ == "__main__":
    main()
