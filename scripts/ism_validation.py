#!/usr/bin/env python3
"""Builds an image-source validation folder for `host-sim eval`: scenes like the eval folder's room and
jump sets (a 6 x 5 x 3 m shoebox, RT60 0.45 s, talker at 1.5 m) at other array and talker positions,
from other noise seeds, so that a change to the method can be checked on many more room scenes than
the eval folder holds (and on scenes it was not tuned on).

Per scene the script places the array and the talker at random in the room, computes the first-order
(AmbiX: ACN W, Y, Z, X, SN3D) room response from pyroomacoustics' image sources (every image's
delay, gain and direction; fractional delays by a Hann-windowed sinc), and hands it to
`host-sim scene`, which convolves the talker with it, adds the exact diffuse pink noise and writes
the CMA1 WAV, its `.pos.csv` and the manifest line:

* static: real speech (../shared/data/src/speech), 0 dB and 10 dB SNR alternating, the scoring
  window `host-sim scene` derives from the speech;
* jump: 12 s of synthetic speech jumping every 2 s between 6 azimuths at least 60 degrees apart,
  3 dB SNR, the room response rotated to each azimuth by `host-sim scene --track`.

Needs Python 3 with numpy, scipy and pyroomacoustics (`pip install numpy scipy pyroomacoustics`) and
a release build of host-sim. Not part of the test suite.

Usage: scripts/ism_validation.py OUT_DIR [--static N] [--jumps N] [--seed S]
then   host-sim eval OUT_DIR
"""

import argparse
import glob
import os
import subprocess
import sys

import numpy as np
import pyroomacoustics as pra
import scipy.io.wavfile as wavfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HOST_SIM = os.environ.get("HS", os.path.join(ROOT, "target", "release", "host-sim"))
SPEECH = os.environ.get("SPEECH", os.path.join(ROOT, "..", "shared", "data", "src", "speech"))
FS = 16000
DIMS = np.array([6.0, 5.0, 3.0])
RT60 = 0.45
DISTANCE = 1.5
RIR_SECONDS = 0.8
HALF_TAPS = 20
SPEED_OF_SOUND = 343.0


def positions(rng):
    """Array and talker positions: the array ≥ 1.2 m from the walls at 1.1–1.6 m height, the talker
    1.5 m away horizontally at 1.2–1.8 m height, ≥ 0.4 m from every wall."""
    while True:
        rx = np.array(
            [
                rng.uniform(1.2, DIMS[0] - 1.2),
                rng.uniform(1.2, DIMS[1] - 1.2),
                rng.uniform(1.1, 1.6),
            ]
        )
        a = np.radians(rng.uniform(0.0, 360.0))
        src = rx + DISTANCE * np.array([np.cos(a), np.sin(a), 0.0])
        src[2] = rng.uniform(1.2, 1.8)
        if np.all(src > 0.4) and np.all(src < DIMS - 0.4):
            return rx, src


def image_sources(dims, rt60, rx, src, max_order=None):
    """The image sources of pyroomacoustics for `src` heard at `rx` in a shoebox `dims` of
    reverberation time `rt60` (up to `max_order` reflections, default the order Sabine's formula
    asks for): each image's offset from `rx` (3 x N), distance and wall damping."""
    e_abs, order = pra.inverse_sabine(rt60, dims)
    room = pra.ShoeBox(dims, fs=FS, materials=pra.Material(e_abs),
                       max_order=order if max_order is None else max_order)
    room.add_source(src)
    room.add_microphone(rx)
    room.image_source_model()
    d = room.sources[0].images - rx[:, None]
    return d, np.linalg.norm(d, axis=0), room.sources[0].damping[0]


def image_source_ambix(dims, rt60, rx, src, divisor):
    """First-order AmbiX (ACN W, Y, Z, X; SN3D) response of RIR_SECONDS from `src` to `rx` in a
    shoebox `dims` of reverberation time `rt60`, from the image sources of pyroomacoustics (delay,
    gain and direction of each image; fractional delays by a Hann-windowed sinc). An image at
    distance r has the gain damping / divisor(r); not normalised."""
    d, r, damping = image_sources(dims, rt60, rx, src)
    length = int(RIR_SECONDS * FS)
    t = r / SPEED_OF_SOUND * FS
    keep = t < length - HALF_TAPS - 1
    d, r, t, gain = d[:, keep], r[keep], t[keep], damping[keep] / divisor(r[keep])
    u = d / r
    encode = np.stack([np.ones_like(r), u[1], u[2], u[0]])
    n0 = np.floor(t).astype(int)
    k = np.arange(-HALF_TAPS, HALF_TAPS + 1)
    x = k[None, :] - (t - n0)[:, None]
    taps = np.sinc(x) * (0.5 + 0.5 * np.cos(np.pi * x / (HALF_TAPS + 1))) * gain[:, None]
    index = (n0[:, None] + k[None, :]).ravel()
    h = np.zeros((length, 4))
    for c in range(4):
        h[:, c] = np.bincount(index, weights=(taps * encode[c][:, None]).ravel(),
                              minlength=length + HALF_TAPS + 1)[:length]
    return h


def ambix_rir(rx, src):
    """First-order AmbiX (ACN, SN3D) response from `src` to `rx`, peak-normalised, and the direct
    sound's azimuth in degrees [0, 360)."""
    h = image_source_ambix(DIMS, RT60, rx, src, lambda r: 4.0 * np.pi * r)
    h /= np.max(np.abs(h)) * 1.01
    direct = src - rx
    return h.astype(np.float32), float(np.degrees(np.arctan2(direct[1], direct[0])) % 360.0)


def wrap180(a):
    return (a + 180.0) % 360.0 - 180.0


def scene(extra):
    """Runs `host-sim scene` with `extra`."""
    subprocess.run([HOST_SIM, "scene"] + extra, check=True, capture_output=True)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out")
    p.add_argument("--static", type=int, default=64, help="static scenes (default 64)")
    p.add_argument("--jumps", type=int, default=10, help="jump scenes (default 10)")
    p.add_argument("--seed", type=int, default=2000)
    args = p.parse_args()
    speech = sorted(glob.glob(os.path.join(SPEECH, "*.wav")))
    if not speech:
        sys.exit(f"no speech in {SPEECH}")
    if not os.access(HOST_SIM, os.X_OK):
        sys.exit(f"no host-sim at {HOST_SIM} (cargo build --release -p host-sim)")
    os.makedirs(args.out, exist_ok=True)
    manifest = os.path.join(args.out, "manifest.csv")
    if os.path.exists(manifest):
        os.remove(manifest)
    rng = np.random.default_rng(args.seed)
    rir = os.path.join(args.out, "rir.wav")
    for s in range(args.static + args.jumps):
        rx, src = positions(rng)
        h, az = ambix_rir(rx, src)
        wavfile.write(rir, FS, h)
        common = ["--rir", rir, "--rir-direct", f"{az:.2f}", "--seed", str(args.seed + s)]
        common += ["--manifest", manifest]
        if s < args.static:
            snr = 0 if s % 2 == 0 else 10
            name = os.path.join(args.out, f"static{s:03d}_snr{snr:+03d}_az{az:05.1f}.wav")
            scene(["--out", name, "--source", speech[s % len(speech)]]
                  + ["--azimuth", f"{az:.2f}", "--snr", str(snr), "--set", f"room_snr{snr:+03d}"]
                  + common)
        else:
            azs = [az]
            while len(azs) < 6:
                c = rng.uniform(0.0, 360.0)
                if abs(wrap180(c - azs[-1])) >= 60.0:
                    azs.append(c)
            track = ",".join(f"{2 * i}:{wrap180(a):.1f}" for i, a in enumerate(azs))
            name = os.path.join(args.out, f"jump{s - args.static:03d}.wav")
            scene(["--out", name, "--synth", "12", "--track", track, "--snr", "3"]
                  + ["--set", "jump"] + common)
        print(name, flush=True)
    os.remove(rir)


if __name__ == "__main__":
    main()
