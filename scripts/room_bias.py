#!/usr/bin/env python3
"""Writes docs/room-bias.md: where the localizer's error in a reverberant room comes from.

Per scene a static talker in an image-source room (the scenes of scripts/ism_validation.py: a
6 x 5 x 3 m shoebox, RT60 0.45 s, talker 1.5 m away, speech at 0 or 10 dB diffuse noise). For each
scene the script compares the localizer's *bias* (mean signed error over the settled frames,
`host-sim eval --json`, default configuration and with 10 peaks, the thesis's number) with the
direction of the room response's *early field*: the energy-weighted mean of the horizontal unit
vectors of the direct sound and every image source arriving within EARLY_MS of it (pyroomacoustics'
image sources). A first-order coincident array cannot tell apart sound that arrives within a frame
(32 ms) from nearby directions: if the bias is the early reflections' doing, it follows the early
field's direction from scene to scene.

Usage: scripts/room_bias.py OUT_DIR [--scenes N] [--seed S] [--doc docs/room-bias.md]
Needs Python 3 with numpy, scipy and pyroomacoustics and a release build of host-sim
(HS=path/to/host-sim to use another). Exit status 1 when the page's claim (correlation ≥ 0.7) fails.
"""

import argparse
import csv
import json
import os
import subprocess
import sys

import numpy as np
import scipy.io.wavfile as wavfile

import ism_validation as ism

EARLY_MS = 10.0
CLAIM_CORRELATION = 0.7


def early_field_offset(rx, src):
    """Azimuth of the energy-weighted early field relative to the direct sound, degrees, and the
    talker's distance to the nearest wall, m."""
    d, r, damping = ism.image_sources(ism.DIMS, ism.RT60, rx, src, max_order=6)
    g = damping / r
    i0 = np.argmin(r)
    early = (r - r[i0]) / ism.SPEED_OF_SOUND * 1000.0 <= EARLY_MS
    u = d[:2, early] / r[early]
    v = ((g[early] / g[i0]) ** 2 * u).sum(axis=1)
    direct = np.degrees(np.arctan2(d[1, i0], d[0, i0]))
    wall = float(min(np.min(src[:2]), np.min(ism.DIMS[:2] - src[:2])))
    return ism.wrap180(np.degrees(np.arctan2(v[1], v[0])) - direct), wall


def build(out, n, seed):
    """The scenes (as scripts/ism_validation.py makes its static ones) and their early fields."""
    os.makedirs(out, exist_ok=True)
    manifest = os.path.join(out, "manifest.csv")
    if os.path.exists(manifest):
        os.remove(manifest)
    speech = sorted(
        os.path.join(ism.SPEECH, f) for f in os.listdir(ism.SPEECH) if f.endswith(".wav")
    )
    rng = np.random.default_rng(seed)
    rir = os.path.join(out, "rir.wav")
    scenes = []
    for s in range(n):
        rx, src = ism.positions(rng)
        h, az = ism.ambix_rir(rx, src)
        wavfile.write(rir, ism.FS, h)
        snr = 0 if s % 2 == 0 else 10
        name = f"static{s:03d}"
        subprocess.run(
            [ism.HOST_SIM, "scene", "--out", os.path.join(out, name + ".wav"),
             "--source", speech[s % len(speech)], "--azimuth", f"{az:.2f}", "--snr", str(snr),
             "--set", f"room_snr{snr:+03d}", "--rir", rir, "--rir-direct", f"{az:.2f}",
             "--seed", str(seed + s), "--manifest", manifest],
            check=True, capture_output=True)
        offset, wall = early_field_offset(rx, src)
        scenes.append({"name": name, "azimuth": az, "early": offset, "wall": wall, "snr": snr})
    with open(manifest) as f:
        rows = list(csv.DictReader(f))
    for scene, row in zip(scenes, rows):
        scene["others"] = other_estimators(os.path.join(out, row["file"]), scene["azimuth"],
                                           float(row["score_from_s"]), float(row["score_to_s"]))
    os.remove(rir)
    return scenes


def other_estimators(wav, truth, score_from, score_to):
    """Scene biases (degrees) of three estimators that use the same first-order signals: the
    energy-weighted active intensity of the 200-4000 Hz band, the mean of the 16 strongest peaks'
    active-ratio direction vectors Re(V/W), and the principal eigenvector of those peaks'
    covariance of (W, X, Y)/|W|; over the speech frames of the scoring window."""
    fs, x = wavfile.read(wav)
    x = x.astype(np.float64) / 32768.0
    n, hop = 512, 256
    win = np.hanning(n + 1)[:n]
    look = np.radians([0.0, 120.0, 240.0])
    frames = (len(x) - n) // hop
    spec = np.stack([np.fft.rfft(x[i * hop:i * hop + n] * win[:, None], axis=0)
                     for i in range(frames)])
    freq = np.fft.rfftfreq(n, 1.0 / fs)
    band = (freq >= 200) & (freq <= 4000)
    w = spec[:, :, 0]
    dip = 2.0 * spec[:, :, 1:] - w[:, :, None]
    vx = (2.0 / 3.0) * (dip * np.cos(look)).sum(-1)
    vy = (2.0 / 3.0) * (dip * np.sin(look)).sum(-1)
    power = np.abs(w) ** 2
    t = (np.arange(frames) * hop + n / 2) / fs
    energy = power[:, band].sum(1)
    speech = (t >= score_from) & (t <= score_to) & (energy > energy.max() * 10 ** -2.5)
    intensity = np.zeros(2)
    mean = np.zeros(2)
    cov = np.zeros((3, 3))
    for i in np.where(speech)[0]:
        intensity += [np.real(vx[i, band] * np.conj(w[i, band])).sum(),
                      np.real(vy[i, band] * np.conj(w[i, band])).sum()]
        p = power[i] * band
        peaks = np.where((p[1:-1] > p[:-2]) & (p[1:-1] >= p[2:]))[0] + 1
        peaks = peaks[np.argsort(p[peaks])[::-1][:16]]
        a = np.stack([w[i, peaks], vx[i, peaks], vy[i, peaks]], 1) / w[i, peaks][:, None]
        mean += [np.real(a[:, 1]).mean(), np.real(a[:, 2]).mean()]
        cov += np.real(a.T @ a.conj())
    eig = np.linalg.eigh(cov)[1][:, -1]
    eig = eig / eig[0]
    angle = lambda v: ism.wrap180(np.degrees(np.arctan2(v[1], v[0])) - truth)
    return angle(intensity), angle(mean), angle(eig[1:])


def biases(out, flags):
    """Per-scene bias (degrees) of `host-sim eval OUT --json FLAGS`."""
    report = json.loads(subprocess.run([ism.HOST_SIM, "eval", out, "--json"] + flags, check=True,
                                       capture_output=True, text=True).stdout)
    return {s["name"]: (s["settled"]["bias"], s["settled"]["mae"]) for s in report["scenes"]}


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out")
    p.add_argument("--scenes", type=int, default=32)
    p.add_argument("--seed", type=int, default=7100)
    p.add_argument("--doc", default=os.path.join(ism.ROOT, "docs", "room-bias.md"))
    a = p.parse_args()
    if not os.access(ism.HOST_SIM, os.X_OK):
        sys.exit(f"no host-sim at {ism.HOST_SIM} (cargo build --release -p host-sim)")
    scenes = build(a.out, a.scenes, a.seed)
    default = biases(a.out, [])
    ten = biases(a.out, ["--peaks", "10"])
    early = np.array([s["early"] for s in scenes])
    b16 = np.array([default[s["name"]][0] for s in scenes])
    b10 = np.array([ten[s["name"]][0] for s in scenes])
    mae16 = np.array([default[s["name"]][1] for s in scenes])
    others = np.abs(np.array([s["others"] for s in scenes])).mean(axis=0)
    corr = float(np.corrcoef(early, b16)[0, 1])
    slope, icpt = np.polyfit(early, b16, 1)
    resid = b16 - (slope * early + icpt)
    lines = [
        "# Where the error in a room comes from: the early reflections",
        "",
        "<!-- Written by scripts/room_bias.py; do not edit by hand. -->",
        "",
        f"{a.scenes} scenes (`scripts/room_bias.py OUT --scenes {a.scenes} --seed {a.seed}`): a static talker 1.5 m",
        "from the array in a 6 × 5 × 3 m image-source room of RT60 0.45 s (array ≥ 1.2 m and talker ≥ 0.4 m",
        "from the walls, heights 1.1–1.8 m), real speech at 0 or 10 dB diffuse noise. *Bias* is the mean",
        "signed error of the settled frames (`host-sim eval --json`); *early field* is the direction of the",
        f"energy-weighted mean of the horizontal unit vectors of the direct sound and every image source",
        f"arriving within {EARLY_MS:.0f} ms of it, relative to the direct sound (what a first-order array",
        "hears as one sound within an analysis frame of 32 ms).",
        "",
        f"- Correlation of the default configuration's bias with the early field's offset: **{corr:.2f}**;",
        f"  least-squares fit bias ≈ {slope:.2f} × offset {icpt:+.2f}°, residual spread {np.std(resid):.2f}° (bias",
        f"  spread {np.std(b16):.2f}°).",
        f"- Mean |bias| {np.mean(np.abs(b16)):.2f}° (largest {np.max(np.abs(b16)):.2f}°) with the default 16 peaks,",
        f"  {np.mean(np.abs(b10)):.2f}° (largest {np.max(np.abs(b10)):.2f}°) with 10 peaks; mean MAE "
        f"{np.mean(mae16):.2f}°.",
        "",
        "So most of a static talker's error in such a room is a bias that the room's first reflections",
        "put there, the same at every frame: more frames, smoothing or tracking do not remove it, and it",
        "changes with the talker's place (which walls send their reflections, a few milliseconds after",
        "the direct sound, from which side). Other estimators from the same signals, over the same speech frames, carry",
        f"the same kind of bias: mean |bias| {others[0]:.2f}° for the energy-weighted active intensity of",
        f"the band (as FDIV), {others[1]:.2f}° for the mean of the 16 strongest peaks' active-ratio directions,",
        f"{others[2]:.2f}° for the principal eigenvector of those peaks' covariance.",
        "",
        "| scene | SNR dB | talker azimuth ° | talker to nearest wall m | early-field offset ° | bias (16 peaks) ° | bias (10 peaks) ° |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for s, x16, x10 in zip(scenes, b16, b10):
        lines.append(f"| {s['name']} | {s['snr']} | {s['azimuth']:.1f} | {s['wall']:.2f} | "
                     f"{s['early']:+.1f} | {x16:+.2f} | {x10:+.2f} |")
    ok = corr >= CLAIM_CORRELATION
    lines += ["", f"Claim checked by the script: {'✔' if ok else '✘'} the bias follows the early field "
              f"(correlation ≥ {CLAIM_CORRELATION})."]
    with open(a.doc, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines[12:24]))
    if not ok:
        print("CLAIM FAILED: correlation below", CLAIM_CORRELATION, file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
