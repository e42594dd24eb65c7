//! `host-sim scene --talkers N`: scenes of 2–3 talkers — taking turns, speaking at once, one of them
//! moving — with one truth file per talker.
//!
//! Each talker is rendered like the single-talker scene (plane wave, or through its own first-order
//! room response rotated to its azimuth), scaled to the same power over its speaking time, summed,
//! and the exact 3-D diffuse pink noise is added at `--snr` below one talker's power.
//!
//! # Truth files
//! Beside `NAME.wav`, one `NAME.talkerK.csv` per talker (K = 1, 2, …), CSV with the header
//! `t_s,azimuth_deg,speaking`: each row holds from its `t_s` until the next row; `azimuth_deg` is
//! where the talker is (counter-clockwise from cardioid 1), `speaking` is 1 inside one of its
//! utterances (from its first to its last sample above −30 dB of its loudest 10 ms, so the pauses
//! between syllables count as speaking) and 0 otherwise. A moving talker has a row every 50 ms.
//!
//! # Manifest
//! `--manifest DIR/manifest.csv` appends `file,set,talkers,note` rows (the header `host-sim eval`
//! recognises as a multi-talker folder; a folder holds either kind, not both).

use crate::error::{Result, SimError};
use crate::io::wav_io::{read_mono, write_atomically, write_frames, OutFormat};
use crate::simulation::scene::{self, Motion, RoomResponse, SceneSpec};
use crate::simulation::signal::{pink_noise, Rng};
use std::path::{Path, PathBuf};

/// A finite angular speed (`--move-first`), degrees per second.
fn finite_speed(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!(
            "expected a finite speed in degrees per second, got `{s}`"
        )),
    }
}

/// Most talkers a scene holds (`--talkers`).
pub const MAX_TALKERS: u8 = 3;

/// Header of a talker's truth file (`NAME.talkerK.csv`).
const TRUTH_HEADER: &str = "t_s,azimuth_deg,speaking";

/// Header of a multi-talker manifest.
pub const MANIFEST_HEADER: &str = "file,set,talkers,note";

/// How the talkers share the time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Talk {
    /// Utterances of 1–3 s in turn, gaps of 0.2–0.8 s, one in five followed by a short overlap
    /// (0.2–0.5 s) instead of a gap.
    Turns,
    /// Every talker speaks the whole time, at equal level.
    Together,
}

/// The multi-talker flags of `host-sim scene`.
#[derive(Debug, Clone, clap::Args)]
pub struct MultiTalkerArgs {
    /// Several talkers (2 or 3): makes a multi-talker scene with one truth file per talker
    /// (NAME.talkerK.csv); --synth is then the length of the conversation.
    #[arg(long, value_parser = clap::value_parser!(u8).range(2..=MAX_TALKERS as i64))]
    pub talkers: Option<u8>,
    /// How the talkers share the time.
    #[arg(long, value_enum, default_value_t = Talk::Turns)]
    pub talk: Talk,
    /// Talker azimuths, degrees, comma-separated (default: drawn from --seed, at least 60° apart).
    #[arg(long, allow_hyphen_values = true)]
    pub azimuths: Option<String>,
    /// The first talker circles at this angular speed, degrees per second.
    #[arg(long, allow_hyphen_values = true, value_parser = finite_speed)]
    pub move_first: Option<f64>,
    /// Per-talker first-order room response (AmbiX W, Y, Z, X; SN3D), once per talker in order;
    /// each is rotated to its talker's azimuth (--rir-n3d, --rir-length apply).
    #[arg(long)]
    pub talker_rir: Vec<PathBuf>,
    /// Direct-sound azimuths of the --talker-rir responses, degrees, comma-separated (default:
    /// measured from each response's intensity, which early reflections can bias).
    #[arg(long, allow_hyphen_values = true)]
    pub talker_rir_direct: Option<String>,
    /// Per-talker speech (mono WAV), once per talker in order or once for all; utterances are cut
    /// from it at random places (default: synthetic speech).
    #[arg(long)]
    pub talker_source: Vec<PathBuf>,
}

/// One talker of a multi-talker scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Talker {
    /// Where the talker is.
    pub motion: Motion,
    /// Utterances (start, end) in s from the file start.
    pub utterances: Vec<(f64, f64)>,
}

impl Talker {
    /// Whether the talker speaks at `t` s.
    #[must_use]
    pub fn speaking_at(&self, t: f64) -> bool {
        self.utterances.iter().any(|(a, b)| t >= *a && t < *b)
    }

    /// The truth file's rows (t_s, azimuth, speaking): a row at every change (every 50 ms when moving).
    #[must_use]
    pub fn truth_rows(&self, duration_s: f64) -> Vec<(f64, f64, bool)> {
        let mut times = vec![0.0];
        for (a, b) in &self.utterances {
            times.push(*a);
            times.push(*b);
        }
        if let Motion::Rotate { .. } = self.motion {
            let n = (duration_s / 0.05).ceil() as usize;
            times.extend((0..=n).map(|i| i as f64 * 0.05));
        }
        times.retain(|t| *t <= duration_s);
        times.sort_by(f64::total_cmp);
        times.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        let mut rows: Vec<(f64, f64, bool)> = Vec::new();
        for t in times {
            let row = (t, self.motion.azimuth_at(t), self.speaking_at(t));
            if rows.last().is_some_and(|r| {
                r.1 == row.1 && r.2 == row.2 && !matches!(self.motion, Motion::Rotate { .. })
            }) {
                continue;
            }
            rows.push(row);
        }
        rows
    }
}

/// Everything a multi-talker scene needs.
#[derive(Debug, Clone)]
pub struct MultiTalkerSpec {
    /// Output rate, Hz.
    pub rate: u32,
    /// Length of the conversation, s (after the lead-in).
    pub seconds: f64,
    /// Noise-only time before the first utterance, s.
    pub lead_in_s: f64,
    /// How the talkers share the time.
    pub talk: Talk,
    /// Talker azimuths, degrees.
    pub azimuths: Vec<f64>,
    /// Angular speed of the first talker, degrees per second (`None`: static).
    pub move_first: Option<f64>,
    /// Per-talker room responses (empty: plane waves).
    pub rooms: Vec<RoomResponse>,
    /// Speech per talker (cycled; empty: synthetic speech).
    pub sources: Vec<Vec<f64>>,
    /// SNR of the diffuse noise below one talker's power, dB (`None`: no noise).
    pub snr_db: Option<f64>,
    /// Peak level of the file, dBFS.
    pub peak_dbfs: f64,
    /// Seed of the schedule, the synthetic speech and the noise.
    pub seed: u64,
    /// The capsules of the simulated array (`--capsule-gain-db`, `--capsule-beta`, `--beta-drift`).
    pub array: crate::simulation::array_model::ArrayModel,
    /// Directional noise sources (levels relative to one talker's power).
    pub noise_sources: Vec<crate::simulation::noise_source::NoiseSource>,
    /// The room the noise sources are rendered through.
    pub source_room: crate::simulation::noise_source::SourceRoom,
}

/// A synthesised multi-talker scene.
#[derive(Debug, Clone)]
pub struct MultiTalkerScene {
    /// Sample frames (omni, card 0°, 120°, 240°).
    pub frames: Vec<[f32; 4]>,
    /// Rate, Hz.
    pub rate: u32,
    /// The talkers.
    pub talkers: Vec<Talker>,
}

/// Azimuths for `n` talkers at least 60° apart, drawn from `rng`.
#[must_use]
pub fn random_azimuths(n: usize, rng: &mut Rng) -> Vec<f64> {
    loop {
        let az: Vec<f64> = (0..n)
            .map(|_| (rng.uniform() * 360.0 - 180.0).round())
            .collect();
        let apart = az.iter().enumerate().all(|(i, a)| {
            az[i + 1..]
                .iter()
                .all(|b| crate::io::ground_truth::wrap180(a - b).abs() >= 60.0)
        });
        if apart {
            return az;
        }
    }
}

/// The utterance schedule: per talker a list of (start, end) in s, from `t0` for `seconds`.
fn schedule(talk: Talk, n: usize, t0: f64, seconds: f64, rng: &mut Rng) -> Vec<Vec<(f64, f64)>> {
    let mut out = vec![Vec::new(); n];
    match talk {
        Talk::Together => {
            for u in out.iter_mut() {
                u.push((t0, t0 + seconds));
            }
        }
        Talk::Turns => {
            let mut t = t0;
            let mut last = usize::MAX;
            while t < t0 + seconds - 0.5 {
                let mut k = (rng.uniform() * n as f64) as usize % n;
                if k == last {
                    k = (k + 1 + (rng.uniform() * (n - 1) as f64) as usize % (n - 1)) % n;
                }
                let dur = (1.0 + 2.0 * rng.uniform()).min(t0 + seconds - t);
                out[k].push((t, t + dur));
                last = k;
                t += dur
                    + if rng.uniform() < 0.2 {
                        -(0.2 + 0.3 * rng.uniform())
                    } else {
                        0.2 + 0.6 * rng.uniform()
                    };
            }
        }
    }
    out
}

/// A speech signal of `len` samples: synthetic, or cut from `source` at a random place.
fn utterance(source: Option<&[f64]>, rate: u32, len: usize, rng: &mut Rng) -> Vec<f64> {
    match source {
        Some(s) if !s.is_empty() => {
            let (a, b) = scene::talker_activity(s, rate);
            let active = &s[a..b.max(a)];
            if active.is_empty() {
                return vec![0.0; len];
            }
            // The clip's speech from a random place, repeated after pauses of 0.1–0.3 s when it is
            // shorter than the utterance.
            let mut v = Vec::with_capacity(len + active.len());
            let mut from = (rng.uniform() * active.len() as f64 * 0.5) as usize;
            while v.len() < len {
                v.extend_from_slice(&active[from.min(active.len())..]);
                from = 0;
                let pause = ((0.1 + 0.2 * rng.uniform()) * f64::from(rate)) as usize;
                v.extend(std::iter::repeat_n(0.0, pause));
            }
            v.truncate(len);
            v
        }
        _ => {
            let seed = (rng.uniform() * 1e9) as u64;
            scene::synthetic_speech(rate, len as f64 / f64::from(rate), seed)
        }
    }
}

/// Synthesises a multi-talker scene.
pub fn synthesize(spec: &MultiTalkerSpec) -> Result<MultiTalkerScene> {
    let n = spec.azimuths.len();
    if !(2..=MAX_TALKERS as usize).contains(&n) {
        return Err(SimError::Usage(format!(
            "--azimuths: 2 or 3 talkers, got {n}"
        )));
    }
    if !spec.rooms.is_empty() && spec.rooms.len() != n {
        return Err(SimError::Usage(format!(
            "--talker-rir: one per talker ({n}), got {}",
            spec.rooms.len()
        )));
    }
    let rate = f64::from(spec.rate);
    let mut rng = Rng::new(spec.seed.wrapping_mul(0x9E37_79B9).wrapping_add(7));
    let plan = schedule(spec.talk, n, spec.lead_in_s, spec.seconds, &mut rng);
    let tail = 0.3;
    let total = ((spec.lead_in_s + spec.seconds + tail) * rate).ceil() as usize;
    let mut mix = [vec![0.0f64; total], vec![0.0; total], vec![0.0; total]];
    let mut talkers = Vec::with_capacity(n);
    for (k, utterances) in plan.into_iter().enumerate() {
        let source =
            (!spec.sources.is_empty()).then(|| spec.sources[k % spec.sources.len()].as_slice());
        let mut signal = vec![0.0f64; total];
        let mut spoken = Vec::new();
        for (a, b) in utterances {
            let start = (a * rate).round() as usize;
            let len = ((b - a) * rate).round() as usize;
            let u = utterance(source, spec.rate, len, &mut rng);
            let (first, last) = scene::talker_activity(&u, spec.rate);
            if last <= first {
                continue;
            }
            for (i, v) in u.iter().enumerate() {
                if let Some(d) = signal.get_mut(start + i) {
                    *d += v;
                }
            }
            spoken.push(((start + first) as f64 / rate, (start + last) as f64 / rate));
        }
        let motion = match spec.move_first {
            Some(speed) if k == 0 => Motion::Rotate {
                start_deg: spec.azimuths[0],
                deg_per_s: speed,
                until_s: None,
            },
            _ => Motion::Steps(vec![(0.0, spec.azimuths[k])]),
        };
        let one = SceneSpec {
            source: signal,
            rate: spec.rate,
            lead_in_s: 0.0,
            motion: motion.clone(),
            snr_db: None,
            room: spec.rooms.get(k).cloned().map(scene::TalkerRoom::Rotated),
            peak_dbfs: 0.0,
            seed: spec.seed,
            array: crate::simulation::array_model::ArrayModel::default(),
            noise_sources: Vec::new(),
            source_room: crate::simulation::noise_source::SourceRoom::Free,
        };
        let [w, x, y] = scene::render_talker(&one, total, 0);
        // Equal power over the talker's speaking time.
        let (mut p, mut count) = (0.0f64, 0usize);
        for (a, b) in &spoken {
            let (a, b) = ((a * rate) as usize, ((b * rate) as usize).min(total));
            p += w[a..b].iter().map(|v| v * v).sum::<f64>();
            count += b.saturating_sub(a);
        }
        let g = if p > 0.0 {
            (count as f64 / p).sqrt()
        } else {
            0.0
        };
        for (m, s) in mix.iter_mut().zip([w, x, y]) {
            for (d, v) in m.iter_mut().zip(s) {
                *d += g * v;
            }
        }
        talkers.push(Talker {
            motion,
            utterances: spoken,
        });
    }
    if let Some(snr) = spec.snr_db {
        let mut noise_rng = Rng::new(spec.seed);
        let g = 10f64.powf(-snr / 20.0);
        let gd = g / 3f64.sqrt();
        for (m, gain) in mix.iter_mut().zip([g, gd, gd]) {
            for (d, v) in m.iter_mut().zip(pink_noise(&mut noise_rng, total)) {
                *d += gain * v;
            }
        }
    }
    if !spec.noise_sources.is_empty() {
        let sources = crate::simulation::noise_source::render(
            &spec.noise_sources,
            &spec.source_room,
            spec.rate,
            total,
            1.0,
            spec.seed,
        );
        for (m, s) in mix.iter_mut().zip(sources) {
            for (d, v) in m.iter_mut().zip(s) {
                *d += v;
            }
        }
    }
    let mut rendered = spec.array.render(&mix[0], &mix[1], &mix[2], spec.rate);
    // Every talker has unit power over his speaking time, the diffuse noise is below that.
    let reference = spec.snr_db.map_or(1.0, |snr| 10f64.powf(-snr / 10.0));
    spec.array
        .add_self_noise(&mut rendered, reference, spec.seed);
    let peak = rendered
        .iter()
        .flat_map(|f| f.iter().map(|v| v.abs()))
        .fold(1e-12f64, f64::max);
    let gain = 10f64.powf(spec.peak_dbfs / 20.0) / peak;
    Ok(MultiTalkerScene {
        frames: rendered
            .iter()
            .map(|f| f.map(|v| (v * gain) as f32))
            .collect(),
        rate: spec.rate,
        talkers,
    })
}

/// Path of talker `k`'s truth file (k from 0): `NAME.talker{k+1}.csv`.
#[must_use]
pub fn truth_path(wav: &Path, k: usize) -> PathBuf {
    wav.with_extension(format!("talker{}.csv", k + 1))
}

/// Writes the WAV, the truth files and (optionally) the manifest row.
pub fn write(
    scene: &MultiTalkerScene,
    out: &Path,
    format: OutFormat,
    manifest: Option<(&Path, &str)>,
) -> Result<()> {
    write_frames(out, scene.rate, &scene.frames, format)?;
    let duration = scene.frames.len() as f64 / f64::from(scene.rate);
    for (k, t) in scene.talkers.iter().enumerate() {
        let path = truth_path(out, k);
        write_atomically(&path, |tmp| {
            let mut s = format!("{TRUTH_HEADER}\n");
            for (t, a, on) in t.truth_rows(duration) {
                s.push_str(&format!("{t:.4},{a:.2},{}\n", u8::from(on)));
            }
            std::fs::write(tmp, s).map_err(|e| SimError::io(tmp, e))
        })?;
    }
    for k in scene.talkers.len()..usize::from(MAX_TALKERS) {
        crate::io::manifest::remove_stale(&truth_path(out, k), TRUTH_HEADER)?;
    }
    if let Some((manifest, set)) = manifest {
        let row = format!(
            "{},{set},{},\"host-sim scene --talkers\"",
            crate::io::manifest::scene_path(manifest, out).display(),
            scene.talkers.len()
        );
        crate::io::manifest::append_row(manifest, MANIFEST_HEADER, &row)?;
    }
    Ok(())
}

/// `host-sim scene --talkers N`.
pub fn run(a: &crate::commands::scene::SceneArgs, n: u8) -> Result<()> {
    let n = usize::from(n);
    let mut rng = Rng::new(a.seed ^ 0xA5A5);
    let numbers = |flag: &str, s: &str| {
        s.split(',')
            .map(|v| {
                v.trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| SimError::Usage(format!("{flag}: not a number: `{v}`")))
            })
            .collect::<Result<Vec<f64>>>()
    };
    let azimuths = match &a.multi.azimuths {
        Some(s) => numbers("--azimuths", s)?,
        None => random_azimuths(n, &mut rng),
    };
    let directs = match &a.multi.talker_rir_direct {
        Some(s) => {
            let d = numbers("--talker-rir-direct", s)?;
            if d.len() != a.multi.talker_rir.len() {
                return Err(SimError::Usage(format!(
                    "--talker-rir-direct: one azimuth per --talker-rir ({}), got {}",
                    a.multi.talker_rir.len(),
                    d.len()
                )));
            }
            d.into_iter().map(Some).collect()
        }
        None => vec![None; a.multi.talker_rir.len()],
    };
    if azimuths.len() != n {
        return Err(SimError::Usage(format!(
            "--azimuths: {n} talkers need {n} azimuths, got {}",
            azimuths.len()
        )));
    }
    if a.source.is_some()
        || a.rir.is_some()
        || a.azimuth.is_some()
        || a.track.is_some()
        || a.rotate.is_some()
    {
        return Err(SimError::Usage(
            "--talkers: use --talker-source, --talker-rir, --azimuths and --move-first instead of \
             --source, --rir, --azimuth, --track and --rotate"
                .into(),
        ));
    }
    if a.room.is_some() && !a.multi.talker_rir.is_empty() {
        return Err(SimError::Usage(
            "--talkers: give either --room or --talker-rir".into(),
        ));
    }
    let noise_sources = a
        .noise_sources
        .iter()
        .map(|s| crate::simulation::noise_source::NoiseSource::parse(s))
        .collect::<Result<Vec<_>>>()?;
    let (rooms, source_room) = if a.room.is_some() {
        let mut rooms = Vec::with_capacity(n);
        let mut source_room = crate::simulation::noise_source::SourceRoom::Free;
        for az in &azimuths {
            let (r, s) = crate::commands::scene::rooms(a)?;
            rooms.extend(r.map(|r| r.response(*az)));
            source_room = s;
        }
        (rooms, source_room)
    } else {
        let rooms = a
            .multi
            .talker_rir
            .iter()
            .zip(directs)
            .map(|(p, d)| RoomResponse::read(p, a.rate, a.rir_n3d, a.rir_length, d))
            .collect::<Result<Vec<_>>>()?;
        let source_room = match rooms.first() {
            Some(r) => crate::simulation::noise_source::SourceRoom::Measured(r.clone()),
            None => crate::simulation::noise_source::SourceRoom::Free,
        };
        (rooms, source_room)
    };
    let sources = a
        .multi
        .talker_source
        .iter()
        .map(|p| {
            let (r, x) = read_mono(p)?;
            let x: Vec<f64> = x.iter().map(|v| f64::from(*v)).collect();
            Ok(crate::simulation::signal::resample(&x, r, a.rate))
        })
        .collect::<Result<Vec<_>>>()?;
    let spec = MultiTalkerSpec {
        rate: a.rate,
        seconds: a.synth.unwrap_or(20.0),
        lead_in_s: a.lead_in,
        talk: a.multi.talk,
        azimuths,
        move_first: a.multi.move_first,
        rooms,
        sources,
        snr_db: a.snr,
        peak_dbfs: a.peak_dbfs,
        seed: a.seed,
        array: a.array.model()?,
        noise_sources,
        source_room,
    };
    let s = synthesize(&spec)?;
    write(
        &s,
        &a.out,
        a.format,
        a.manifest.as_deref().map(|m| (m, a.set.as_str())),
    )?;
    crate::commands::scene::write_noise_truth(&a.out, &spec.noise_sources)?;
    eprintln!(
        "scene: wrote {} ({:.2} s, {} Hz, {} talkers) and {} truth files ({})",
        a.out.display(),
        s.frames.len() as f64 / f64::from(s.rate),
        s.rate,
        s.talkers.len(),
        s.talkers.len(),
        truth_path(&a.out, 0).display()
    );
    Ok(())
}
