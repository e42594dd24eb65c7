#!/usr/bin/env python3
"""Builds validation folders for capsule self-calibration: long reverberant scenes with one talker
speaking from many places in turn, short scenes, and scenes that check a calibration does not drift,
each rendered through an imperfect CMA1 array (cardioid gains, pattern β, frequency-dependent β) and,
for the long and short scenes, through the ideal array too, so the same scenes can be compared.

Layout of OUT_DIR (each folder is an eval folder: 4-channel 16 kHz PCM16 WAVs, NAME.pos.csv, manifest.csv):

  imperfect/  long00 … (N long scenes, ≥ 100 s)       sets long_late (last 40 s), long_early (first 30 s)
              short000 … (M short scenes, ~3 s, 3 dB)   set short (the window `host-sim scene` writes)
  ideal/      the same files, rendered through the ideal array (same rooms, places, speech, noise)
  drift/      ideal_longNN   hard links to ideal/longNN (ideal array)             set drift_ideal
              staticNN       60 s, one static talker, imperfect array, 6 dB       set drift_static
              dirnoiseNN     60 s static talker + pink noise from another place
                             (0 dB on the omni) + diffuse noise at 20 dB          set drift_dirnoise
              silenceNN      30 s of digital silence, then 20 s of talker, 6 dB   set drift_silence
  selfnoise/imperfect, selfnoise/ideal
              n20_000 …, n10_000 …  the short scenes again, with the capsules' own noise
                             (`host-sim scene --self-noise`: white, independent, equal in the four
                             capsules) 20 or 10 dB below the diffuse noise     sets selfnoise20, selfnoise10

The manifest lists each long scene twice (the same WAV under long_late and long_early; `host-sim eval`
scores every manifest line on its own). Drift scenes are scored over their whole talker time (per-scene
numbers: `host-sim eval --json`). Beside every WAV, NAME.array.json holds the truth a self-calibration
estimate can be compared with: the capsule model (gains_db, betas, beta_drift, drift_corner_hz; the
ideal twin says 0 dB, 0.5, 0), the room (dims, rt60, snr, array position), every place (time, azimuth,
elevation, distance, position, per-segment SNR), the scored windows and, for dirnoise, the noise source.

How a scene is made: the room is a shoebox with random dimensions (4–8 × 3.5–7 × 2.5–3.2 m) and RT60
uniform in 0.3–0.55 s; the array stands ≥ 1 m from the walls at 1.2–1.6 m height; a place is a talker
position 1–2 m away (horizontally) at 1.2–1.8 m height, ≥ 0.5 m from the walls. Each place gets its own
first-order AmbiX room response from pyroomacoustics' image sources (as in scripts/ism_validation.py,
but with the physical 1/r gain kept instead of a per-response peak normalisation, so the talker's
level changes with its distance), and `host-sim scene --rir` renders the talker (speech from
shared/data/src/speech: the clips at equal RMS, shuffled and joined with 0.2–0.8 s pauses) with 3-D
diffuse pink noise (`--snr`) and the capsule flags. A long scene is 10 such segments (~10 s each,
consecutive azimuths ≥ 40° apart) rendered one by one and joined here: only the first keeps the 0.25 s
noise lead-in, every segment's level is brought back from host-sim's peak normalisation to one
common scale (gain fitted on the omni, which is W for any capsule model), and each segment's --snr is
set so that the diffuse noise has the same level in every segment, at the drawn scene SNR relative to
the talker's mean power over the scene. The truth changes when the new place's speech starts. The
rendering is linear, so the directional noise of dirnoise is a second `host-sim scene` (pink noise as
--source, its own room response, same capsule flags) added sample by sample. Imperfect arrays: gains
uniform within ±1 dB, β uniform in 0.42–0.58, and in every second scene a --beta-drift uniform within
±0.1 (corner 500 Hz); a new draw per scene. Every scene draws from its own seed (seed, part, index), so
a scene does not change with --long/--short or --only.

Needs Python 3 with numpy, scipy and pyroomacoustics and a release build of host-sim (env HS; default
/tmp/hs-scene, a copy of target/release/host-sim, because the tree's binary may be rebuilt meanwhile).
Not part of the test suite. Takes a few minutes with the defaults.

Usage: cp target/release/host-sim /tmp/hs-scene
       scripts/selfcal_validation.py OUT_DIR [--long N] [--short M] [--drift K] [--seed S]
                                     [--only long,short,drift,noise]
then   host-sim eval OUT_DIR/imperfect;  host-sim eval OUT_DIR/ideal;  host-sim eval OUT_DIR/drift;
       host-sim eval OUT_DIR/selfnoise/imperfect;  host-sim eval OUT_DIR/selfnoise/ideal
"""

import argparse
import glob
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import pyroomacoustics as pra
import scipy.io.wavfile as wavfile
from scipy.signal import fftconvolve

from ism_validation import FS, image_source_ambix, wrap180

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HOST_SIM = os.environ.get("HS", "/tmp/hs-scene")
SPEECH = os.environ.get("SPEECH", os.path.join(ROOT, "..", "shared", "data", "src", "speech"))
LEAD_S = 0.25
PEAK_DBFS = -3.0
DRIFT_CORNER_HZ = 500.0
PLACES = 10
PLACE_S = 10.0
MIN_STEP_DEG = 40.0
LATE_S = 40.0
EARLY_S = 30.0
PARTS = {"long": 1, "short": 2, "drift": 3, "noise": 4}
# Levels of the capsules' own noise in the noise part, dB relative to the diffuse room noise.
SELF_NOISE_DB = [-20.0, -10.0]


# ---------------------------------------------------------------- geometry and room responses


def draw_room(rng):
    """Random shoebox, RT60 and array position (≥ 1 m from the walls, 1.2–1.6 m high)."""
    dims = np.array([rng.uniform(4.0, 8.0), rng.uniform(3.5, 7.0), rng.uniform(2.5, 3.2)])
    rt60 = rng.uniform(0.3, 0.55)
    rx = np.array([rng.uniform(1.0, dims[0] - 1.0), rng.uniform(1.0, dims[1] - 1.0),
                   rng.uniform(1.2, 1.6)])
    return {"dims": dims, "rt60": rt60, "rx": rx}


def draw_place(rng, room, away_from=(), min_sep=MIN_STEP_DEG):
    """A talker position 1–2 m from the array (horizontally), 1.2–1.8 m high, ≥ 0.5 m from every
    wall, with an azimuth at least `min_sep` degrees from each azimuth in `away_from`."""
    dims, rx = room["dims"], room["rx"]
    for _ in range(10000):
        az = rng.uniform(0.0, 360.0)
        dist = rng.uniform(1.0, 2.0)
        z = rng.uniform(1.2, 1.8)
        if any(abs(wrap180(az - a)) < min_sep for a in away_from):
            continue
        a = np.radians(az)
        src = np.array([rx[0] + dist * np.cos(a), rx[1] + dist * np.sin(a), z])
        if np.all(src > 0.5) and np.all(src < dims - 0.5):
            el = float(np.degrees(np.arctan2(z - rx[2], dist)))
            return {"azimuth_deg": float(az), "elevation_deg": el,
                    "distance_m": float(np.linalg.norm(src - rx)), "pos_m": src}
    raise RuntimeError("no talker position fits the room")


def ambix_rir(room, src):
    """First-order AmbiX (ACN W, Y, Z, X; SN3D) response from `src` to the array (the image-source
    rendering of scripts/ism_validation.py). Physical gain: the direct sound has amplitude 1/r (r in
    metres)."""
    return image_source_ambix(room["dims"], room["rt60"], room["rx"], src, lambda r: r).astype(
        np.float32
    )


# ---------------------------------------------------------------- sources


def load_speech():
    """The speech clips as float64 at equal RMS over their active 10 ms blocks."""
    files = sorted(glob.glob(os.path.join(SPEECH, "*.wav")))
    if not files:
        sys.exit(f"no speech in {SPEECH}")
    clips = []
    for f in files:
        rate, x = wavfile.read(f)
        if rate != FS:
            sys.exit(f"{f}: {rate} Hz, expected {FS}")
        x = x.astype(np.float64)
        if x.ndim > 1:
            x = x.mean(axis=1)
        blocks = x[: len(x) // 160 * 160].reshape(-1, 160)
        p = np.mean(blocks ** 2, axis=1)
        active = p > 1e-3 * p.max()
        clips.append(x / np.sqrt(np.mean(p[active])) * 0.1)
    return clips


def speech_run(rng, clips, seconds):
    """Shuffled clips joined with 0.2–0.8 s pauses until at least `seconds` long."""
    parts, n, order = [], 0, []
    while n < seconds * FS:
        if not order:
            order = list(rng.permutation(len(clips)))
        if parts:
            pause = np.zeros(int(rng.uniform(0.2, 0.8) * FS))
            parts.append(pause)
            n += len(pause)
        c = clips[order.pop()]
        parts.append(c)
        n += len(c)
    return np.concatenate(parts)


def pink(rng, n):
    """Pink (1/f power) Gaussian noise, unit RMS."""
    spec = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n, 1.0 / FS)
    spec *= 1.0 / np.sqrt(np.maximum(f, 20.0))
    spec[0] = 0.0
    x = np.fft.irfft(spec, n)
    return x / np.sqrt(np.mean(x ** 2))


# ---------------------------------------------------------------- arrays


IDEAL = {"gains_db": [0.0, 0.0, 0.0], "betas": [0.5, 0.5, 0.5], "beta_drift": 0.0,
         "drift_corner_hz": DRIFT_CORNER_HZ, "ideal": True}


def draw_array(rng, with_drift):
    return {"gains_db": [round(float(g), 3) for g in rng.uniform(-1.0, 1.0, 3)],
            "betas": [round(float(b), 4) for b in rng.uniform(0.42, 0.58, 3)],
            "beta_drift": round(float(rng.uniform(-0.1, 0.1)), 4) if with_drift else 0.0,
            "drift_corner_hz": DRIFT_CORNER_HZ, "ideal": False}


def array_flags(array):
    if array["ideal"]:
        return []
    g = ",".join(f"{v:.3f}" for v in array["gains_db"])
    b = ",".join(f"{v:.4f}" for v in array["betas"])
    flags = [f"--capsule-gain-db={g}", f"--capsule-beta={b}"]
    if array["beta_drift"] != 0.0:
        flags += [f"--beta-drift={array['beta_drift']:.4f}",
                  f"--drift-corner={array['drift_corner_hz']:g}"]
    return flags


# ---------------------------------------------------------------- rendering


class Renderer:
    """Runs `host-sim scene` in a private temporary folder and returns the scene in physical units
    (host-sim's peak normalisation undone), so that segments and sources can be joined and added."""

    def __init__(self, tmp):
        self.tmp = tmp
        self.calls = 0

    def render(self, src, h, az, arrays, seed, snr=None, lead_s=LEAD_S, self_noise=None):
        """Renders the mono `src` through the response `h` (direct sound at `az`) once per capsule
        model in `arrays` (same noise seed), with the capsules' own noise `self_noise` dB below the
        diffuse noise (`host-sim scene --self-noise`) if given. Returns (list of float64 [n, 4] scenes, host-sim's
        scoring window (from, to) in s, the talker's mean omni power over its active span)."""
        srcf = os.path.join(self.tmp, "src.wav")
        rirf = os.path.join(self.tmp, "rir.wav")
        src32 = src.astype(np.float32)
        wavfile.write(srcf, FS, src32)
        wavfile.write(rirf, FS, h)
        lead = int(round(lead_s * FS))
        talker = fftconvolve(src32.astype(np.float64), h[:, 0].astype(np.float64))
        power = float(np.mean(talker[: len(src)] ** 2))
        outs, window, first = [], None, None
        for array in arrays:
            out = os.path.join(self.tmp, "scene.wav")
            man = os.path.join(self.tmp, "manifest.csv")
            if os.path.exists(man):
                os.remove(man)
            cmd = [HOST_SIM, "scene", "--out", out, "--source", srcf, "--rir", rirf,
                   f"--rir-direct={az:.3f}", f"--azimuth={az:.3f}", f"--seed={seed}",
                   f"--lead-in={lead_s}", "--format", "float", "--manifest", man, "--set", "x"]
            if snr is not None:
                cmd.append(f"--snr={snr:.4f}")
            if self_noise is not None:
                cmd.append(f"--self-noise={self_noise}")
            subprocess.run(cmd + array_flags(array), check=True, capture_output=True)
            self.calls += 1
            rate, x = wavfile.read(out)
            assert rate == FS and x.shape[1] == 4
            x = x.astype(np.float64)
            with open(man) as f:
                fields = f.read().strip().splitlines()[-1].split(",")
            window = (float(fields[2]), float(fields[3]))
            if first is None:
                # Fit host-sim's output gain on the omni (= W for every capsule model): the omni is
                # gain·(talker + noise), the noise independent of the talker.
                ref = np.zeros(len(x))
                m = min(len(x) - lead, len(talker))
                ref[lead : lead + m] = talker[:m]
                gain = np.dot(x[:, 0], ref) / np.dot(ref, ref)
                first = x[:, 0]
                # Check: the rest of the omni is host-sim's diffuse noise, whose power is the
                # talker's power over its active span less the SNR (unit-RMS pink noise).
                want = 0.0 if snr is None else power * 10.0 ** (-snr / 10.0)
                if self_noise is not None:
                    want *= 1.0 + 10.0 ** (self_noise / 10.0)
                got = float(np.mean((x[:, 0] / gain - ref) ** 2))
                if abs(got - want) > 0.1 * want + 1e-9 * power:
                    print(f"warning: noise power {got:.3g}, expected {want:.3g} (seed {seed})",
                          file=sys.stderr)
            else:
                # Same talker, same noise seed: the omni differs from the first render only by
                # host-sim's output gain, which the ratio gives exactly.
                gain = outs[0][1] * np.dot(x[:, 0], first) / np.dot(first, first)
            outs.append((x / gain, gain))
        os.remove(srcf)
        os.remove(rirf)
        return [o for o, _ in outs], window, power


def write_scene(folder, name, x, scale, rows, windows, meta):
    """Writes NAME.wav (PCM16, x·scale), NAME.pos.csv (rows: t, az, el, dist) and NAME.array.json."""
    path = os.path.join(folder, name + ".wav")
    y = np.clip(np.round(x * scale * 32767.0), -32768, 32767).astype(np.int16)
    wavfile.write(path, FS, y)
    with open(os.path.join(folder, name + ".pos.csv"), "w") as f:
        f.write("t_s,azimuth_deg,elevation_deg,distance_m\n")
        for t, az, el, dist in rows:
            f.write(f"{t:.4f},{wrap180(az):.2f},{el:.2f},{dist:.2f}\n")
    meta = dict(meta, score_windows=[{"set": s, "from_s": round(a, 3), "to_s": round(b, 3)}
                                     for s, a, b in windows])
    with open(os.path.join(folder, name + ".array.json"), "w") as f:
        json.dump(meta, f, indent=1, default=jsonable)
        f.write("\n")


def jsonable(v):
    if isinstance(v, np.ndarray):
        return [round(float(a), 4) for a in v]
    if isinstance(v, np.floating):
        return float(v)
    if isinstance(v, np.integer):
        return int(v)
    raise TypeError(type(v))


def common_scale(*scenes):
    """One scale for twin scenes: the loudest of them peaks at PEAK_DBFS."""
    peak = max(np.max(np.abs(s)) for s in scenes)
    return 10.0 ** (PEAK_DBFS / 20.0) / peak


def room_meta(room, snr):
    return {"dims_m": room["dims"], "rt60_s": round(room["rt60"], 4),
            "snr_db": None if snr is None else round(snr, 3), "array_pos_m": room["rx"]}


def place_meta(p, **extra):
    return dict({k: (round(v, 3) if isinstance(v, float) else v) for k, v in p.items()}, **extra)


def clean(folder, prefix):
    for f in glob.glob(os.path.join(folder, prefix + "*")):
        os.remove(f)


# ---------------------------------------------------------------- scene kinds


def multi_place(renderer, rng, clips, room, places, arrays, snr, seconds_per_place):
    """Renders one talker speaking from `places` in turn (each through its own response, each with
    its own noise seed) and joins the segments. Returns (scenes per array, truth rows, speech start,
    speech end, per-place metadata)."""
    sources = [speech_run(rng, clips, seconds_per_place) for _ in places]
    rirs = [ambix_rir(room, p["pos_m"]) for p in places]
    seeds = [int(rng.integers(1, 2 ** 31 - 1)) for _ in places]
    powers = [np.mean(fftconvolve(s.astype(np.float32).astype(np.float64),
                                  h[:, 0].astype(np.float64))[: len(s)] ** 2)
              for s, h in zip(sources, rirs)]
    noise_power = np.mean(powers) * 10.0 ** (-snr / 10.0)
    joined = [[] for _ in arrays]
    rows, meta, t, start, end = [], [], 0.0, None, None
    for k, (p, src, h, seed, pw) in enumerate(zip(places, sources, rirs, seeds, powers)):
        seg_snr = 10.0 * np.log10(pw / noise_power)
        lead_s = LEAD_S if k == 0 else 0.0
        outs, (w0, w1), _ = renderer.render(src, h, p["azimuth_deg"], arrays, seed, seg_snr, lead_s)
        onset = t if k == 0 else t + (w0 - 0.1)
        if k == 0:
            start = t + w0
        end = t + w1
        rows.append((onset, p["azimuth_deg"], p["elevation_deg"], p["distance_m"]))
        meta.append(place_meta(p, t_s=round(onset, 4), snr_db=round(float(seg_snr), 3),
                               seed=seed))
        for j, o in enumerate(outs):
            joined[j].append(o)
        t += len(outs[0]) / FS
    return [np.concatenate(j) for j in joined], rows, start, end, meta


def build_long(out, args, clips, renderer):
    imp, ide = os.path.join(out, "imperfect"), os.path.join(out, "ideal")
    for folder in (imp, ide):
        clean(folder, "long")
    for i in range(args.long):
        rng = np.random.default_rng((args.seed, PARTS["long"], i))
        room = draw_room(rng)
        snr = float(rng.uniform(0.0, 10.0))
        array = draw_array(rng, with_drift=(i % 2 == 1))
        places = []
        for _ in range(PLACES):
            prev = [places[-1]["azimuth_deg"]] if places else []
            places.append(draw_place(rng, room, prev))
        (x_imp, x_ide), rows, start, end, pmeta = multi_place(
            renderer, rng, clips, room, places, [array, IDEAL], snr, PLACE_S)
        windows = [("long_late", max(start, end - LATE_S), end),
                   ("long_early", start, min(end, EARLY_S))]
        scale = common_scale(x_imp, x_ide)
        name = f"long{i:02d}"
        for folder, x, arr in ((imp, x_imp, array), (ide, x_ide, IDEAL)):
            write_scene(folder, name, x, scale, rows, windows,
                        {"kind": "long", "seed": [args.seed, PARTS["long"], i], "array": arr,
                         "room": room_meta(room, snr), "places": pmeta,
                         "duration_s": round(len(x) / FS, 3)})
        print(f"{name}: {len(x_imp) / FS:.1f} s, rt60 {room['rt60']:.2f} s, snr {snr:.1f} dB, "
              f"gains {array['gains_db']}, betas {array['betas']}, drift {array['beta_drift']}",
              flush=True)


def short_draw(args, clips, i):
    """The draws of short scene `i`: room, array, place, clip, noise seed, room response."""
    rng = np.random.default_rng((args.seed, PARTS["short"], i))
    room = draw_room(rng)
    array = draw_array(rng, with_drift=(i % 2 == 1))
    p = draw_place(rng, room)
    clip = clips[int(rng.integers(len(clips)))]
    seed = int(rng.integers(1, 2 ** 31 - 1))
    return room, array, p, clip, seed, ambix_rir(room, p["pos_m"])


def build_short(out, args, clips, renderer, self_noise=None):
    """The short scenes into OUT/imperfect and OUT/ideal; with `self_noise` (dB below the diffuse
    noise) the same scenes with the capsules' own noise into OUT/selfnoise, named nNN_III, set
    selfnoiseNN (NN the level's magnitude)."""
    if self_noise is None:
        imp, ide = os.path.join(out, "imperfect"), os.path.join(out, "ideal")
        prefix, set_name = "short", "short"
    else:
        imp, ide = os.path.join(out, "selfnoise", "imperfect"), os.path.join(out, "selfnoise", "ideal")
        prefix, set_name = f"n{abs(self_noise):.0f}_", f"selfnoise{abs(self_noise):.0f}"
    for folder in (imp, ide):
        os.makedirs(folder, exist_ok=True)
        clean(folder, prefix)
    for i in range(args.short):
        room, array, p, clip, seed, h = short_draw(args, clips, i)
        (x_imp, x_ide), (w0, w1), _ = renderer.render(clip, h, p["azimuth_deg"], [array, IDEAL],
                                                      seed, 3.0, self_noise=self_noise)
        rows = [(0.0, p["azimuth_deg"], p["elevation_deg"], p["distance_m"])]
        scale = common_scale(x_imp, x_ide)
        name = f"{prefix}{i:03d}"
        for folder, x, arr in ((imp, x_imp, array), (ide, x_ide, IDEAL)):
            write_scene(folder, name, x, scale, rows, [(set_name, w0, w1)],
                        {"kind": "short", "seed": [args.seed, PARTS["short"], i], "array": arr,
                         "self_noise_db": self_noise, "room": room_meta(room, 3.0),
                         "places": [place_meta(p, t_s=0.0, snr_db=3.0, seed=seed)],
                         "duration_s": round(len(x) / FS, 3)})
    print(f"{set_name}: {args.short} scenes", flush=True)


def build_noise(out, args, clips, renderer):
    """The short scenes again, with the capsules' own noise at each of SELF_NOISE_DB."""
    for level in SELF_NOISE_DB:
        build_short(out, args, clips, renderer, self_noise=level)


def build_drift(out, args, clips, renderer):
    folder = os.path.join(out, "drift")
    for prefix in ("ideal_long", "static", "dirnoise", "silence"):
        clean(folder, prefix)
    # (a) the ideal long scenes, hard-linked, scored over all their talker time
    ideal_long = sorted(glob.glob(os.path.join(out, "ideal", "long*.wav")))
    if not ideal_long:
        print("drift: no ideal/long*.wav to link (build --only long first)", file=sys.stderr)
    for wav in ideal_long:
        base = wav[:-4]
        name = "ideal_" + os.path.basename(base)
        with open(base + ".array.json") as f:
            meta = json.load(f)
        w = meta.pop("score_windows")
        start = min(v["from_s"] for v in w)
        end = max(v["to_s"] for v in w)
        os.link(wav, os.path.join(folder, name + ".wav"))
        os.link(base + ".pos.csv", os.path.join(folder, name + ".pos.csv"))
        meta["score_windows"] = [{"set": "drift_ideal", "from_s": start, "to_s": end}]
        meta["linked_from"] = os.path.relpath(wav, folder)
        with open(os.path.join(folder, name + ".array.json"), "w") as f:
            json.dump(meta, f, indent=1)
            f.write("\n")
    for i in range(args.drift):
        with_drift = i % 2 == 1
        # (b) 60 s of one static talker, imperfect array, 6 dB
        rng = np.random.default_rng((args.seed, PARTS["drift"], 0, i))
        room = draw_room(rng)
        array = draw_array(rng, with_drift)
        p = draw_place(rng, room)
        src = speech_run(rng, clips, 60.0)
        seed = int(rng.integers(1, 2 ** 31 - 1))
        (x,), (w0, w1), _ = renderer.render(src, ambix_rir(room, p["pos_m"]), p["azimuth_deg"],
                                            [array], seed, 6.0)
        rows = [(0.0, p["azimuth_deg"], p["elevation_deg"], p["distance_m"])]
        write_scene(folder, f"static{i:02d}", x, common_scale(x), rows,
                    [("drift_static", w0, w1)],
                    {"kind": "static", "seed": [args.seed, PARTS["drift"], 0, i], "array": array,
                     "room": room_meta(room, 6.0),
                     "places": [place_meta(p, t_s=0.0, snr_db=6.0, seed=seed)],
                     "duration_s": round(len(x) / FS, 3)})
        # (c) 60 s static talker + pink noise from another place (0 dB on the omni) + diffuse 20 dB
        rng = np.random.default_rng((args.seed, PARTS["drift"], 1, i))
        room = draw_room(rng)
        array = draw_array(rng, with_drift)
        p = draw_place(rng, room)
        q = draw_place(rng, room, [p["azimuth_deg"]], min_sep=60.0)
        src = speech_run(rng, clips, 60.0)
        seed = int(rng.integers(1, 2 ** 31 - 1))
        (xt,), (w0, w1), p_talker = renderer.render(
            src, ambix_rir(room, p["pos_m"]), p["azimuth_deg"], [array], seed, 20.0)
        noise = pink(rng, len(xt))
        h = ambix_rir(room, q["pos_m"])
        (xn,), _, p_noise = renderer.render(noise, h, q["azimuth_deg"], [array], seed + 1, None,
                                            0.0)
        xn = xn[: len(xt)] * np.sqrt(p_talker / p_noise)
        x = xt + xn
        write_scene(folder, f"dirnoise{i:02d}", x, common_scale(x), rows_of(p),
                    [("drift_dirnoise", w0, w1)],
                    {"kind": "dirnoise", "seed": [args.seed, PARTS["drift"], 1, i],
                     "array": array, "room": room_meta(room, 20.0),
                     "places": [place_meta(p, t_s=0.0, snr_db=20.0, seed=seed)],
                     "noise_source": place_meta(q, level_db_re_talker=0.0, kind="pink",
                                                seed=seed + 1),
                     "duration_s": round(len(x) / FS, 3)})
        # (d) 30 s of digital silence, then 20 s of talker (imperfect array, 6 dB)
        rng = np.random.default_rng((args.seed, PARTS["drift"], 2, i))
        room = draw_room(rng)
        array = draw_array(rng, with_drift)
        p = draw_place(rng, room)
        src = speech_run(rng, clips, 20.0)
        seed = int(rng.integers(1, 2 ** 31 - 1))
        (xt,), (w0, w1), _ = renderer.render(src, ambix_rir(room, p["pos_m"]), p["azimuth_deg"],
                                             [array], seed, 6.0)
        silence = 30.0
        x = np.concatenate([np.zeros((int(silence * FS), 4)), xt])
        write_scene(folder, f"silence{i:02d}", x, common_scale(x), rows_of(p),
                    [("drift_silence", silence + w0, silence + w1)],
                    {"kind": "silence", "seed": [args.seed, PARTS["drift"], 2, i],
                     "array": array, "room": room_meta(room, 6.0), "silence_s": silence,
                     "places": [place_meta(p, t_s=0.0, snr_db=6.0, seed=seed)],
                     "duration_s": round(len(x) / FS, 3)})
        print(f"drift {i}: static, dirnoise, silence", flush=True)


def rows_of(p):
    return [(0.0, p["azimuth_deg"], p["elevation_deg"], p["distance_m"])]


def write_manifest(folder):
    """manifest.csv from the score windows of every NAME.array.json in `folder`."""
    lines = ["file,set,score_from_s,score_to_s,note"]
    for js in sorted(glob.glob(os.path.join(folder, "*.array.json"))):
        name = os.path.basename(js)[: -len(".array.json")]
        with open(js) as f:
            meta = json.load(f)
        a, r = meta["array"], meta["room"]
        note = (f"selfcal {meta['kind']} {'ideal' if a['ideal'] else 'imperfect'} array, "
                f"rt60 {r['rt60_s']:.2f} s, snr {r['snr_db']} dB")
        for w in meta["score_windows"]:
            lines.append(f"{name}.wav,{w['set']},{w['from_s']:.3f},{w['to_s']:.3f},\"{note}\"")
    if len(lines) > 1:
        with open(os.path.join(folder, "manifest.csv"), "w") as f:
            f.write("\n".join(lines) + "\n")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out")
    p.add_argument("--long", type=int, default=6, help="long scenes (default 6)")
    p.add_argument("--short", type=int, default=24, help="short scenes (default 24)")
    p.add_argument("--drift", type=int, default=2,
                   help="scenes of each drift kind: static, dirnoise, silence (default 2)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--only", default="long,short,drift,noise",
                   help="comma list of parts to (re)build: long, short, drift, noise")
    args = p.parse_args()
    only = [s.strip() for s in args.only.split(",") if s.strip()]
    if any(s not in PARTS for s in only):
        sys.exit(f"--only: expected a comma list of {', '.join(PARTS)}, got `{args.only}`")
    if not os.access(HOST_SIM, os.X_OK):
        sys.exit(f"no host-sim at {HOST_SIM} (cp target/release/host-sim /tmp/hs-scene, or set HS)")
    clips = load_speech()
    folders = [os.path.join(args.out, d)
               for d in ("imperfect", "ideal", "drift", "selfnoise/imperfect", "selfnoise/ideal")]
    for d in folders:
        os.makedirs(d, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="selfcal-") as tmp:
        renderer = Renderer(tmp)
        for part, build in (("long", build_long), ("short", build_short), ("drift", build_drift),
                            ("noise", build_noise)):
            if part in only:
                build(args.out, args, clips, renderer)
    for d in folders:
        write_manifest(d)
    print(f"{renderer.calls} host-sim scene runs; now: host-sim eval {folders[0]} (and ideal, drift)")


if __name__ == "__main__":
    main()
