//! `host-sim scene`: synthesises CMA1 recordings with ground truth — a talker (mono WAV or a
//! synthetic speech-like source) on an azimuth track (static, jumps or circling), a 3-D diffuse
//! noise field at a given SNR on the omni, and optionally a room: a shoebox by the image-source
//! method, each of the talker's places with its own response (a circling talker's from a 5° grid),
//! or a measured first-order response rotated to the wanted azimuth.
//!
//! Diffuse noise has the exact second-order statistics of an isotropic 3-D field in first-order
//! B-format (SN3D): W, X, Y, Z mutually uncorrelated, E\[X²\] = E\[Y²\] = E\[Z²\] = E\[W²\]/3. The capsules then
//! see omni = W and cardioid_m = ½W + ½(X cos φ_m + Y sin φ_m), so |card|²/|omni|² = ⅓ on average.

use crate::error::{Result, SimError};
use crate::io::ground_truth::{wrap180, Track};
use crate::io::wav_io::{read_four_channels, read_mono, write_atomically, write_frames, OutFormat};
use crate::simulation::array_model::ArrayModel;
use crate::simulation::noise_source::{self, NoiseSource, SourceRoom};
use crate::simulation::signal::{
    convolve, normalize_rms, pink_noise, resample, Rng, SegmentConvolver,
};
use rustfft::num_complex::Complex64;
use std::f64::consts::PI;
use std::path::Path;

/// Where the talker is over time.
#[derive(Debug, Clone, PartialEq)]
pub enum Motion {
    /// Jumps: (start time s, azimuth °) rows, the first at 0.
    Steps(Vec<(f64, f64)>),
    /// Circling at a constant angular speed from a start azimuth.
    Rotate {
        /// Azimuth at t = 0, degrees.
        start_deg: f64,
        /// Angular speed, degrees per second (counter-clockwise positive).
        deg_per_s: f64,
        /// Time from which the talker stands still where he is, seconds (`None`: he never stops).
        until_s: Option<f64>,
    },
}

impl Motion {
    /// Azimuth at time `t`, degrees.
    #[must_use]
    pub fn azimuth_at(&self, t: f64) -> f64 {
        match self {
            Motion::Steps(rows) => {
                let i = rows.partition_point(|r| r.0 <= t);
                wrap180(rows[i.saturating_sub(1)].1)
            }
            Motion::Rotate {
                start_deg,
                deg_per_s,
                until_s,
            } => wrap180(start_deg + deg_per_s * until_s.map_or(t, |u| t.min(u))),
        }
    }

    /// Parses `--track "0:30,2:-160,4:95"` (time s : azimuth °).
    pub fn parse_steps(s: &str) -> Result<Self> {
        let mut rows = Vec::new();
        for part in s.split(',') {
            let (t, a) = part.split_once(':').ok_or_else(|| {
                SimError::Usage(format!(
                    "--track: expected TIME:AZIMUTH pairs, got `{part}`"
                ))
            })?;
            let num = |v: &str| v.trim().parse::<f64>().ok().filter(|x| x.is_finite());
            let (Some(t), Some(a)) = (num(t), num(a)) else {
                return Err(SimError::Usage(format!(
                    "--track: not a number in `{part}`"
                )));
            };
            if rows.last().is_some_and(|r: &(f64, f64)| t <= r.0) || (rows.is_empty() && t != 0.0) {
                return Err(SimError::Usage(
                    "--track: times must start at 0 and increase".into(),
                ));
            }
            rows.push((t, a));
        }
        Ok(Motion::Steps(rows))
    }
}

/// A first-order room response in B-format (W, X, Y), SN3D, at the scene rate.
#[derive(Debug, Clone)]
pub struct RoomResponse {
    w: Vec<f64>,
    x: Vec<f64>,
    y: Vec<f64>,
    /// Azimuth of the direct sound, degrees.
    pub direct_deg: f64,
}

impl RoomResponse {
    /// Reads an AmbiX (ACN W, Y, Z, X) impulse response, resamples it to `rate`, truncates it to
    /// `max_s` seconds and finds its direct-sound azimuth from the intensity of the first 2.5 ms after
    /// the strongest W sample (unless `direct_deg` is given). `n3d` rescales N3D to SN3D.
    pub fn read(
        path: &Path,
        rate: u32,
        n3d: bool,
        max_s: f64,
        direct_deg: Option<f64>,
    ) -> Result<Self> {
        let (spec, data) = read_four_channels(path, "AmbiX W, Y, Z, X")?;
        let g = if n3d { 1.0 / 3f64.sqrt() } else { 1.0 };
        let ch = |i: usize, gain: f64| -> Vec<f64> {
            let v: Vec<f64> = data.chunks_exact(4).map(|c| c[i] as f64 * gain).collect();
            let mut r = resample(&v, spec.sample_rate, rate);
            r.truncate((max_s * rate as f64) as usize);
            r
        };
        let (w, y, x) = (ch(0, 1.0), ch(1, g), ch(3, g));
        let peak = w
            .iter()
            .enumerate()
            .fold(
                (0, 0.0f64),
                |b, (i, v)| if v.abs() > b.1 { (i, v.abs()) } else { b },
            )
            .0;
        let end = (peak + (0.0025 * rate as f64) as usize).min(w.len());
        let start = peak.saturating_sub((0.0005 * rate as f64) as usize);
        let (mut ix, mut iy) = (0.0, 0.0);
        for i in start..end {
            ix += w[i] * x[i];
            iy += w[i] * y[i];
        }
        let measured = iy.atan2(ix).to_degrees();
        Ok(Self {
            w,
            x,
            y,
            direct_deg: direct_deg.unwrap_or(measured),
        })
    }

    /// A response from its (W, X, Y) parts and its direct-sound azimuth.
    #[must_use]
    pub fn from_parts(w: Vec<f64>, x: Vec<f64>, y: Vec<f64>, direct_deg: f64) -> Self {
        Self {
            w,
            x,
            y,
            direct_deg,
        }
    }

    /// The (W, X, Y) parts.
    #[must_use]
    pub fn parts(&self) -> (&[f64], &[f64], &[f64]) {
        (&self.w, &self.x, &self.y)
    }

    /// The (W, X, Y) parts, taken.
    #[must_use]
    pub fn into_parts(self) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        (self.w, self.x, self.y)
    }

    /// (W, X, Y) responses rotated so the direct sound comes from `azimuth_deg`.
    pub(crate) fn rotated(&self, azimuth_deg: f64) -> [Vec<f64>; 3] {
        let a = (azimuth_deg - self.direct_deg).to_radians();
        let (c, s) = (a.cos(), a.sin());
        let x = self
            .x
            .iter()
            .zip(&self.y)
            .map(|(x, y)| x * c - y * s)
            .collect();
        let y = self
            .x
            .iter()
            .zip(&self.y)
            .map(|(x, y)| x * s + y * c)
            .collect();
        [self.w.clone(), x, y]
    }
}

/// The talker's room: where the talker's response at each place comes from.
#[derive(Debug, Clone)]
pub enum TalkerRoom {
    /// One response (a measured one, `--rir`), rotated so that its direct sound comes from each of
    /// the talker's azimuths: the room turns with the talker.
    Rotated(RoomResponse),
    /// A shoebox room (`--room`): each place's response computed by the image-source method where
    /// the talker stands, so that every place has its own reflections.
    ShoeBox(ShoeBoxTalker),
}

/// A talker in a shoebox room: the room, where the array is, and how far and how high the talker
/// stands from it.
#[derive(Debug, Clone, Copy)]
pub struct ShoeBoxTalker {
    /// The room.
    pub room: crate::simulation::room::ShoeBox,
    /// The array's position, m.
    pub array: [f64; 3],
    /// The talker's elevation seen from the array, degrees.
    pub elevation_deg: f64,
    /// The talker's distance from the array, m (shorter where a wall is closer).
    pub distance_m: f64,
    /// Length of each response, s.
    pub length_s: f64,
    /// Scene rate, Hz.
    pub rate: u32,
}

/// Grid of the shoebox responses of a circling talker, degrees: each segment uses the response of
/// the nearest grid place, turned by at most half a step to the segment's azimuth.
const MOVING_GRID_DEG: f64 = 5.0;

impl TalkerRoom {
    /// The response of a talker at `azimuth_deg` (its direct sound from there).
    #[must_use]
    pub fn response(&self, azimuth_deg: f64) -> RoomResponse {
        match self {
            Self::Rotated(r) => r.clone(),
            Self::ShoeBox(t) => {
                let p = t
                    .room
                    .place(t.array, azimuth_deg, t.elevation_deg, t.distance_m);
                t.room.response(t.array, p, t.rate, t.length_s)
            }
        }
    }

    /// Length of the responses (the longest of W, X, Y), samples.
    #[must_use]
    pub fn response_len(&self) -> usize {
        match self {
            Self::Rotated(r) => r.w.len().max(r.x.len()).max(r.y.len()),
            Self::ShoeBox(t) => ((t.length_s * f64::from(t.rate)) as usize).max(1),
        }
    }
}

/// What to synthesise.
#[derive(Debug, Clone)]
pub struct SceneSpec {
    /// Talker signal at `rate` (already resampled).
    pub source: Vec<f64>,
    /// Output rate, Hz.
    pub rate: u32,
    /// Noise-only time before the talker starts, s.
    pub lead_in_s: f64,
    /// Where the talker is.
    pub motion: Motion,
    /// SNR on the omni (talker power over its active part vs noise power), dB; `None`: no noise.
    pub snr_db: Option<f64>,
    /// Optional room response.
    pub room: Option<TalkerRoom>,
    /// Peak level of the written file, dBFS.
    pub peak_dbfs: f64,
    /// Seed of the noise.
    pub seed: u64,
    /// Capsule model (ideal by default); applied to talker and noise alike.
    pub array: ArrayModel,
    /// Directional noise sources (levels relative to the talker's power).
    pub noise_sources: Vec<NoiseSource>,
    /// The room the noise sources are rendered through.
    pub source_room: SourceRoom,
}

/// A synthesised scene: CMA1 sample frames and truth.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Sample frames (omni, card 0°, 120°, 240°).
    pub frames: Vec<[f32; 4]>,
    /// Rate, Hz.
    pub rate: u32,
    /// Truth track (times relative to the file start).
    pub track: Track,
    /// Interval where the talker is active, s.
    pub active_s: (f64, f64),
}

/// Renders W, X, Y of the talker (plane wave, or through the room) for the whole timeline.
pub(crate) fn render_talker(spec: &SceneSpec, total: usize, lead: usize) -> [Vec<f64>; 3] {
    let mut out = [vec![0.0; total], vec![0.0; total], vec![0.0; total]];
    let rate = spec.rate as f64;
    match (&spec.room, &spec.motion) {
        (None, motion) => {
            for (n, s) in spec.source.iter().enumerate() {
                let t = (n + lead) as f64 / rate;
                let a = motion.azimuth_at(t).to_radians();
                out[0][n + lead] += s;
                out[1][n + lead] += s * a.cos();
                out[2][n + lead] += s * a.sin();
            }
        }
        (Some(room), Motion::Steps(rows)) => {
            for (i, (t0, az)) in rows.iter().enumerate() {
                let t1 = rows.get(i + 1).map_or(f64::INFINITY, |r| r.0);
                // The source samples heard at this place: n with t0 ≤ (n + lead)/rate < t1.
                let inside = |n: &usize| {
                    let t = (n + lead) as f64 / rate;
                    t >= *t0 && t < t1
                };
                let Some(first) = (0..spec.source.len()).find(inside) else {
                    continue;
                };
                let end = (first..spec.source.len())
                    .find(|n| !inside(n))
                    .unwrap_or(spec.source.len());
                let seg = &spec.source[first..end];
                if seg.iter().all(|v| *v == 0.0) {
                    continue;
                }
                for (o, h) in out.iter_mut().zip(room.response(*az).rotated(*az)) {
                    for (k, v) in convolve(seg, &h).into_iter().enumerate() {
                        if let Some(d) = o.get_mut(first + k + lead) {
                            *d += v;
                        }
                    }
                }
            }
        }
        (Some(room), Motion::Rotate { .. }) => {
            // A moving source in a room: render short overlapping segments (50 ms, Hann cross-fade)
            // each with the response turned to the segment's centre azimuth (a shoebox's computed
            // at the nearest place of a 5° grid). Turning mixes X and Y, so each segment is
            // convolved with the place's unturned W, X, Y (their spectra computed once per place)
            // and the results are turned.
            let hop = (0.025 * rate) as usize;
            let win = 2 * hop;
            let n_out = win + room.response_len() - 1;
            let conv = SegmentConvolver::new(win, room.response_len());
            let window: Vec<f64> = (0..win)
                .map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / win as f64).cos())
                .collect();
            let mut places: std::collections::HashMap<i64, ([Vec<Complex64>; 3], f64)> =
                std::collections::HashMap::new();
            let mut start = 0usize;
            while start < spec.source.len() {
                let centre_t = (start + lead + hop) as f64 / rate;
                let az = spec.motion.azimuth_at(centre_t);
                let cell = match room {
                    TalkerRoom::Rotated(_) => 0,
                    TalkerRoom::ShoeBox(_) => (wrap180(az) / MOVING_GRID_DEG).round() as i64,
                };
                let (spectra, direct_deg) = places.entry(cell).or_insert_with(|| {
                    let response = room.response(cell as f64 * MOVING_GRID_DEG);
                    let (w, x, y) = response.parts();
                    (
                        [conv.spectrum(w), conv.spectrum(x), conv.spectrum(y)],
                        response.direct_deg,
                    )
                });
                let seg: Vec<f64> = window
                    .iter()
                    .enumerate()
                    .map(|(i, w)| spec.source.get(start + i).copied().unwrap_or(0.0) * w)
                    .collect();
                let seg = conv.spectrum(&seg);
                let [w, x, y] = spectra.each_ref().map(|h| conv.convolve(&seg, h, n_out));
                let turn = (az - *direct_deg).to_radians();
                let (c, s) = (turn.cos(), turn.sin());
                for k in 0..n_out {
                    let i = start + k + lead;
                    if i >= total {
                        break;
                    }
                    out[0][i] += w[k];
                    out[1][i] += x[k] * c - y[k] * s;
                    out[2][i] += x[k] * s + y[k] * c;
                }
                start += hop;
            }
        }
    }
    out
}

/// First and last sample of the talker's activity: the span of 10 ms blocks whose RMS is within
/// 30 dB of the loudest block (so leading and trailing silence of a recording is not scored).
#[must_use]
pub fn talker_activity(source: &[f64], rate: u32) -> (usize, usize) {
    let block = (rate as usize / 100).max(1);
    let rms: Vec<f64> = source
        .chunks(block)
        .map(|c| (c.iter().map(|v| v * v).sum::<f64>() / c.len() as f64).sqrt())
        .collect();
    let peak = rms.iter().fold(0.0f64, |m, v| m.max(*v));
    let active = |r: &&f64| **r > 0.0316 * peak && peak > 0.0;
    let first = rms.iter().position(|r| active(&r)).unwrap_or(0);
    let last = rms
        .iter()
        .rposition(|r| active(&r))
        .map_or(source.len(), |i| ((i + 1) * block).min(source.len()));
    (first * block, last)
}

impl Scene {
    /// The interval `eval` scores, s: the talker's activity without its first 0.1 s (the time the
    /// localizer needs to hear it). `scene --manifest` writes it into the manifest.
    #[must_use]
    pub fn score_window(&self) -> (f64, f64) {
        (self.active_s.0 + 0.1, self.active_s.1)
    }
}

/// Synthesises a scene.
#[must_use]
pub fn synthesize(spec: &SceneSpec) -> Scene {
    let parts = synthesize_parts(spec, None);
    let rate = spec.rate as f64;
    let lead = (spec.lead_in_s * rate).round() as usize;
    let total = parts.talker.len();
    let frames = parts
        .talker
        .iter()
        .zip(&parts.noise)
        .map(|(t, n)| [t[0] + n[0], t[1] + n[1], t[2] + n[2], t[3] + n[3]])
        .collect();
    let t_end = total as f64 / rate;
    let track = match &spec.motion {
        Motion::Steps(rows) => Track { rows: rows.clone() },
        Motion::Rotate { .. } => Track {
            rows: (0..=((t_end / 0.05).ceil() as usize))
                .map(|i| (i as f64 * 0.05, spec.motion.azimuth_at(i as f64 * 0.05)))
                .collect(),
        },
    };
    let (first, last) = talker_activity(&spec.source, spec.rate);
    Scene {
        frames,
        rate: spec.rate,
        track,
        active_s: ((lead + first) as f64 / rate, (lead + last) as f64 / rate),
    }
}

/// A deterministic speech-like source: voiced syllables (harmonics of a gliding f0 through two
/// formant resonances) of 120–300 ms separated by 50–250 ms pauses, with occasional noise bursts.
#[must_use]
pub fn synthetic_speech(rate: u32, seconds: f64, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed.wrapping_add(1));
    let fs = rate as f64;
    let n = (seconds * fs) as usize;
    let mut out = vec![0.0; n];
    let mut t = 0usize;
    while t < n {
        let syl = ((0.12 + 0.18 * rng.uniform()) * fs) as usize;
        let f0 = 100.0 + 120.0 * rng.uniform();
        let glide = 0.8 + 0.4 * rng.uniform();
        let formants = [
            300.0 + 600.0 * rng.uniform(),
            900.0 + 1600.0 * rng.uniform(),
        ];
        let fricative = rng.uniform() < 0.25;
        let mut phase = 0.0f64;
        for i in 0..syl.min(n - t) {
            let env = (PI * i as f64 / syl as f64).sin().powi(2);
            let f = f0 * (1.0 + (glide - 1.0) * i as f64 / syl as f64);
            phase += 2.0 * PI * f / fs;
            let mut v = 0.0;
            let mut h = 1.0;
            while h * f < 0.45 * fs && h * f < 5000.0 {
                let fh = h * f;
                let g: f64 = formants
                    .iter()
                    .map(|fc| 1.0 / (1.0 + ((fh - fc) / (0.15 * fc)).powi(2)))
                    .sum();
                v += g * (h * phase).sin() / h.sqrt();
                h += 1.0;
            }
            if fricative {
                v = 0.3 * v + 0.7 * rng.gaussian();
            }
            out[t + i] = v * env;
        }
        t += syl + ((0.05 + 0.2 * rng.uniform()) * fs) as usize;
    }
    normalize_rms(&mut out);
    out
}

/// Header of a single-talker manifest (the one `host-sim scene --manifest` writes).
pub const MANIFEST_HEADER: &str = "file,set,score_from_s,score_to_s,note";

/// Writes a scene's WAV and `.pos.csv` (atomically), and optionally appends it to a manifest.
pub fn write_scene(
    scene: &Scene,
    out: &Path,
    format: OutFormat,
    manifest: Option<(&Path, &str)>,
) -> Result<()> {
    write_frames(out, scene.rate, &scene.frames, format)?;
    let pos = out.with_extension("pos.csv");
    write_atomically(&pos, |tmp| {
        let mut s = String::from("t_s,azimuth_deg,elevation_deg,distance_m\n");
        for (t, a) in &scene.track.rows {
            s.push_str(&format!("{t:.4},{a:.2},0.0,1.50\n"));
        }
        std::fs::write(tmp, s).map_err(|e| SimError::io(tmp, e))
    })?;
    if let Some((manifest, set)) = manifest {
        let (from, to) = scene.score_window();
        let row = format!(
            "{},{set},{from:.3},{to:.3},\"host-sim scene\"",
            crate::io::manifest::scene_path(manifest, out).display()
        );
        crate::io::manifest::append_row(manifest, MANIFEST_HEADER, &row)?;
    }
    Ok(())
}

/// The line `host-sim scene` prints on stderr once the files are written: what went where, how
/// long, and the talker's active interval (the window `eval` scores).
#[must_use]
pub fn written_line(scene: &Scene, out: &Path, manifest: Option<&Path>) -> String {
    let mut line = format!(
        "scene: wrote {} ({:.2} s, {} Hz, 4 channels) and {}; scoring window {:.3}–{:.3} s \
         (talker active, first 0.1 s left out)",
        out.display(),
        scene.frames.len() as f64 / f64::from(scene.rate),
        scene.rate,
        out.with_extension("pos.csv").display(),
        scene.score_window().0,
        scene.score_window().1
    );
    if let Some(m) = manifest {
        line.push_str(&format!("; listed in {}", m.display()));
    }
    line
}

/// Loads the talker: a mono WAV resampled to `rate`, or a synthetic source of `synth_s` seconds.
pub fn load_source(
    path: Option<&Path>,
    synth_s: Option<f64>,
    rate: u32,
    seed: u64,
) -> Result<Vec<f64>> {
    match (path, synth_s) {
        (_, Some(s)) if !(s > 0.0 && s.is_finite()) => Err(SimError::Usage(format!(
            "--synth: expected a positive duration, got {s}"
        ))),
        (Some(p), length) => {
            let (r, x) = read_mono(p)?;
            let x: Vec<f64> = x.iter().map(|v| *v as f64).collect();
            let x = resample(&x, r, rate);
            Ok(match length {
                Some(s) => repeated(&x, rate, s, seed),
                None => x,
            })
        }
        (None, Some(s)) => Ok(synthetic_speech(rate, s, seed)),
        (None, None) => Err(SimError::Usage(
            "give --source FILE.wav, --synth SECONDS, or both (the recording repeated to that length)"
                .into(),
        )),
    }
}

/// `x` repeated to `seconds` at `rate`, with a pause of 0.2–0.8 s (drawn from `seed`) before each
/// repeat after the first; the last repeat is cut at the end.
#[must_use]
pub fn repeated(x: &[f64], rate: u32, seconds: f64, seed: u64) -> Vec<f64> {
    let n = (seconds * f64::from(rate)) as usize;
    let mut out = Vec::with_capacity(n);
    let mut rng = Rng::new(seed.wrapping_add(7));
    if x.is_empty() {
        out.resize(n, 0.0);
        return out;
    }
    while out.len() < n {
        if !out.is_empty() {
            let pause = ((0.2 + 0.6 * rng.uniform()) * f64::from(rate)) as usize;
            out.resize((out.len() + pause).min(n), 0.0);
        }
        let take = x.len().min(n - out.len());
        out.extend_from_slice(&x[..take]);
    }
    out
}

/// A scene rendered as separate talker and noise sample frames (same scaling, sum = the scene), for
/// measurements that need both (beamformer SNR gain, `host-sim beam-report`).
#[derive(Debug, Clone)]
pub struct SceneParts {
    /// Talker only (omni, card 0°, 120°, 240°).
    pub talker: Vec<[f32; 4]>,
    /// Diffuse noise and noise sources (all zero without either).
    pub noise: Vec<[f32; 4]>,
    /// Rate, Hz.
    pub rate: u32,
    /// Interval where the talker is active, s.
    pub active_s: (f64, f64),
}

/// Near-field gradient response (thesis eq. 3.10–3.12): the figure-8 components of a point source at
/// `distance_m` carry the factor (1 + jkr)/(jkr) = 1 + c/(jωr). The integrator term is realised as a
/// leaky integrator (corner 10 Hz, far below the analysis band) so that it stays stable.
#[must_use]
pub fn proximity_filter(x: &[f64], rate: u32, distance_m: f64) -> Vec<f64> {
    const C: f64 = 343.0;
    let fs = rate as f64;
    let leak = (-2.0 * PI * 10.0 / fs).exp();
    let g = C / (distance_m * fs);
    let mut acc = 0.0;
    x.iter()
        .map(|v| {
            acc = leak * acc + g * v;
            v + acc
        })
        .collect()
}

/// Like [`synthesize`], but returns talker and noise separately; `near_field_m` renders the talker
/// as a point source at that distance (proximity effect on X and Y, eq. 3.14) instead of a plane wave.
#[must_use]
pub fn synthesize_parts(spec: &SceneSpec, near_field_m: Option<f64>) -> SceneParts {
    let rate = spec.rate as f64;
    let lead = (spec.lead_in_s * rate).round() as usize;
    let tail = spec.room.as_ref().map_or(0, TalkerRoom::response_len);
    let total = lead + spec.source.len() + tail.min((0.3 * rate) as usize);
    let [w, mut x, mut y] = render_talker(spec, total, lead);
    if let Some(r) = near_field_m.filter(|r| *r > 0.0 && r.is_finite()) {
        x = proximity_filter(&x, spec.rate, r);
        y = proximity_filter(&y, spec.rate, r);
    }
    let active = (lead, lead + spec.source.len());
    let talker_power = w[active.0..active.1].iter().map(|v| v * v).sum::<f64>()
        / (active.1 - active.0).max(1) as f64;
    let talker: Vec<[f64; 4]> = spec.array.render(&w, &x, &y, spec.rate);
    let noise: Vec<[f64; 4]> = match spec.snr_db {
        Some(snr) => {
            let mut rng = Rng::new(spec.seed);
            let nw = pink_noise(&mut rng, total);
            let nx = pink_noise(&mut rng, total);
            let ny = pink_noise(&mut rng, total);
            let g = (talker_power * 10f64.powf(-snr / 10.0)).sqrt();
            let gd = g / 3f64.sqrt();
            let scaled = |v: &[f64], k: f64| v.iter().map(|s| k * s).collect::<Vec<f64>>();
            spec.array.render(
                &scaled(&nw, g),
                &scaled(&nx, gd),
                &scaled(&ny, gd),
                spec.rate,
            )
        }
        None => vec![[0.0; 4]; total],
    };
    let mut noise = noise;
    if !spec.noise_sources.is_empty() {
        let [sw, sx, sy] = noise_source::render(
            &spec.noise_sources,
            &spec.source_room,
            spec.rate,
            total,
            talker_power,
            spec.seed,
        );
        for (n, s) in noise
            .iter_mut()
            .zip(spec.array.render(&sw, &sx, &sy, spec.rate))
        {
            for c in 0..4 {
                n[c] += s[c];
            }
        }
    }
    let reference = talker_power * spec.snr_db.map_or(1.0, |snr| 10f64.powf(-snr / 10.0));
    spec.array.add_self_noise(&mut noise, reference, spec.seed);
    let peak = talker
        .iter()
        .zip(&noise)
        .flat_map(|(t, n)| (0..4).map(move |c| (t[c] + n[c]).abs()))
        .fold(0.0f64, f64::max)
        .max(1e-12);
    let gain = 10f64.powf(spec.peak_dbfs / 20.0) / peak;
    let scale = |v: Vec<[f64; 4]>| v.iter().map(|f| f.map(|s| (s * gain) as f32)).collect();
    SceneParts {
        talker: scale(talker),
        noise: scale(noise),
        rate: spec.rate,
        active_s: (active.0 as f64 / rate, active.1 as f64 / rate),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulation::room::ShoeBox;

    #[test]
    fn a_recording_is_repeated_with_pauses_to_the_length() {
        let x: Vec<f64> = (0..1000).map(|i| 1.0 + f64::from(i)).collect();
        let y = repeated(&x, 1000, 5.0, 3);
        assert_eq!(y.len(), 5000);
        assert_eq!(&y[..1000], &x[..]);
        // A pause of 0.2–0.8 s, then the recording again from its start.
        let resume = 1000 + y[1000..].iter().position(|v| *v != 0.0).unwrap();
        assert!((1200..=1800).contains(&resume), "{resume}");
        assert_eq!(&y[resume..resume + 1000], &x[..]);
        assert!(repeated(&[], 1000, 1.0, 0).iter().all(|v| *v == 0.0));
        // With no length the recording is used as it is.
        assert!(load_source(None, None, 16000, 0).is_err());
        assert!(load_source(None, Some(-1.0), 16000, 0).is_err());
    }

    /// Each place of a talker in a shoebox has its own reflections: the response at 90° is not the
    /// response at 0° turned by 90° (the room does not turn with the talker), while its direct sound
    /// comes from 90°.
    #[test]
    fn each_place_in_a_shoebox_has_its_own_reflections() {
        let room = ShoeBox::parse("5x4x3:0.4").unwrap();
        let talker = TalkerRoom::ShoeBox(ShoeBoxTalker {
            room,
            array: room.array_position(3),
            elevation_deg: 0.0,
            distance_m: 1.5,
            length_s: 0.3,
            rate: 16_000,
        });
        let at0 = talker.response(0.0);
        let at90 = talker.response(90.0);
        assert!((at0.direct_deg - 0.0).abs() < 1e-9);
        assert!((at90.direct_deg - 90.0).abs() < 1e-9);
        assert_eq!(talker.response_len(), at0.parts().0.len());
        // Turned back to 0°, the 90° response would equal the 0° one if the room turned with the
        // talker; its reflections (after the first 5 ms) differ by a large part of their energy.
        let [w0, x0, y0] = at0.rotated(0.0);
        let [w9, x9, y9] = at90.rotated(0.0);
        let late = (0.005 * 16_000.0) as usize + (1.5 / 343.0 * 16_000.0) as usize;
        let energy = |v: &[f64]| v[late..].iter().map(|s| s * s).sum::<f64>();
        let diff = |a: &[f64], b: &[f64]| {
            a[late..]
                .iter()
                .zip(&b[late..])
                .map(|(p, q)| (p - q) * (p - q))
                .sum::<f64>()
        };
        let total = energy(&w0) + energy(&x0) + energy(&y0);
        let changed = diff(&w0, &w9) + diff(&x0, &x9) + diff(&y0, &y9);
        assert!(changed > 0.2 * total, "changed {changed} of {total}");
        // A measured response is one place only: it is turned.
        let turned = TalkerRoom::Rotated(at0.clone());
        assert_eq!(turned.response(90.0).rotated(90.0), at0.rotated(90.0));
    }
}
