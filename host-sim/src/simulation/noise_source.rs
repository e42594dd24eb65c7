//! Directional noise sources of real rooms — fans, projectors, air vents, mains hum, a white-noise
//! loudspeaker, the babble of a distant group — for `host-sim scene --noise-source`: each with a
//! direction, a distance, a level relative to the talker and switch-on/off times, rendered as a point
//! source through the same room as the talker (a shoebox room, a measured response rotated to its
//! azimuth, or free field).

use crate::error::{Result, SimError};
use crate::simulation::room::ShoeBox;
use crate::simulation::scene::{synthetic_speech, RoomResponse};
use crate::simulation::signal::{convolve, normalize_rms, pink_noise, Rng};
use std::f64::consts::PI;

/// What a noise source sounds like.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseKind {
    /// A desk or ceiling fan: broadband noise falling with frequency, blade-pass harmonics
    /// (90–150 Hz) and a slow wobble of its level.
    Fan,
    /// A projector or laptop: a small fan's hiss, its blade tone (180–300 Hz) and a weak
    /// high-frequency whine (2–4 kHz).
    Projector,
    /// An air-conditioning vent: low rumble and airy hiss.
    Vent,
    /// Mains hum of a power supply: harmonics of 50 or 60 Hz (strongest at 100/120 Hz) over a
    /// faint noise floor.
    Hum,
    /// A loudspeaker playing white noise.
    White,
    /// A distant group talking: six speech-like voices from one direction.
    Babble,
    /// An air handler or a server rack: broadband noise falling 3 dB an octave from 100 Hz up
    /// (as loud in each octave of 1–4 kHz, where speech is weak, as in each below), with mains-hum
    /// harmonics of 100 or 120 Hz.
    Tilted,
}

impl NoiseKind {
    /// Every kind, in the order of [`NoiseKind::name`].
    pub const ALL: [Self; 7] = [
        Self::Fan,
        Self::Projector,
        Self::Vent,
        Self::Hum,
        Self::White,
        Self::Babble,
        Self::Tilted,
    ];

    /// The name used on the command line and in truth files.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Fan => "fan",
            Self::Projector => "projector",
            Self::Vent => "vent",
            Self::Hum => "hum",
            Self::White => "white",
            Self::Babble => "babble",
            Self::Tilted => "tilted",
        }
    }

    /// The source signal: `n` samples at `rate`, unit RMS, from `seed`.
    #[must_use]
    pub fn signal(self, rate: u32, n: usize, seed: u64) -> Vec<f64> {
        let fs = rate as f64;
        let mut rng = Rng::new(seed ^ 0x4e4f_4953);
        let tones = |rng: &mut Rng, f0: f64, count: usize, fall: f64| -> Vec<f64> {
            let phases: Vec<f64> = (0..count).map(|_| 2.0 * PI * rng.uniform()).collect();
            (0..n)
                .map(|i| {
                    let t = i as f64 / fs;
                    (1..=count)
                        .zip(&phases)
                        .filter(|(h, _)| (*h as f64) * f0 < 0.45 * fs)
                        .map(|(h, p)| {
                            (2.0 * PI * h as f64 * f0 * t + p).sin() * fall.powi(h as i32 - 1)
                        })
                        .sum()
                })
                .collect()
        };
        let mut out: Vec<f64> = match self {
            Self::Fan => {
                let body = lowpass(&pink_noise(&mut rng, n), rate, 800.0);
                let f0 = 90.0 + 60.0 * rng.uniform();
                let blade = tones(&mut rng, f0, 6, 0.6);
                let wobble_hz = 0.5 + rng.uniform();
                mix(&[(&body, 1.0), (&blade, 0.35)])
                    .iter()
                    .enumerate()
                    .map(|(i, v)| v * (1.0 + 0.1 * (2.0 * PI * wobble_hz * i as f64 / fs).sin()))
                    .collect()
            }
            Self::Projector => {
                let hiss = pink_noise(&mut rng, n);
                let (f0, f1) = (
                    180.0 + 120.0 * rng.uniform(),
                    2000.0 + 2000.0 * rng.uniform(),
                );
                let blade = tones(&mut rng, f0, 4, 0.5);
                let whine = tones(&mut rng, f1, 1, 1.0);
                mix(&[(&hiss, 1.0), (&blade, 0.3), (&whine, 0.08)])
            }
            Self::Vent => {
                let rumble = lowpass(&pink_noise(&mut rng, n), rate, 300.0);
                let hiss: Vec<f64> = (0..n).map(|_| rng.gaussian()).collect();
                mix(&[(&rumble, 1.0), (&hiss, 0.15)])
            }
            Self::Hum => {
                let mains = if rng.uniform() < 0.5 { 50.0 } else { 60.0 };
                let mut h = tones(&mut rng, mains, 20, 0.8);
                // Rectifier hum: the even harmonics dominate (100/120 Hz strongest).
                let even = tones(&mut rng, 2.0 * mains, 10, 0.7);
                let floor = pink_noise(&mut rng, n);
                h = mix(&[(&h, 0.3), (&even, 1.0), (&floor, 0.1)]);
                h
            }
            Self::White => (0..n).map(|_| rng.gaussian()).collect(),
            Self::Tilted => {
                // Pink noise above 100 Hz (a one-pole high-pass): its power is in the audible band,
                // not in the few-hertz swell of a pink generator.
                let pink = pink_noise(&mut rng, n);
                let low = lowpass(&pink, rate, 100.0);
                let body: Vec<f64> = pink.iter().zip(&low).map(|(p, l)| p - l).collect();
                let mains = if rng.uniform() < 0.5 { 100.0 } else { 120.0 };
                let hum = tones(&mut rng, mains, 10, 0.7);
                mix(&[(&body, 1.0), (&hum, 0.5)])
            }
            Self::Babble => {
                let secs = n as f64 / fs + 0.1;
                let voices: Vec<Vec<f64>> = (0..6)
                    .map(|k| synthetic_speech(rate, secs, seed.wrapping_add(7919 * (k + 1))))
                    .collect();
                (0..n)
                    .map(|i| {
                        voices
                            .iter()
                            .map(|v| v.get(i).copied().unwrap_or(0.0))
                            .sum()
                    })
                    .collect()
            }
        };
        normalize_rms(&mut out);
        out
    }
}

fn mix(parts: &[(&Vec<f64>, f64)]) -> Vec<f64> {
    let n = parts.iter().map(|(v, _)| v.len()).max().unwrap_or(0);
    let mut out = vec![0.0; n];
    for (v, g) in parts {
        let rms = (v.iter().map(|s| s * s).sum::<f64>() / v.len().max(1) as f64).sqrt();
        let k = g / rms.max(1e-30);
        for (o, s) in out.iter_mut().zip(v.iter()) {
            *o += k * s;
        }
    }
    out
}

fn lowpass(x: &[f64], rate: u32, corner_hz: f64) -> Vec<f64> {
    let a = (-2.0 * PI * corner_hz / rate as f64).exp();
    let mut y = 0.0;
    x.iter()
        .map(|v| {
            y = a * y + (1.0 - a) * v;
            y
        })
        .collect()
}

/// One directional noise source of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseSource {
    /// What it sounds like.
    pub kind: NoiseKind,
    /// Azimuth seen from the array, degrees.
    pub azimuth_deg: f64,
    /// Elevation seen from the array, degrees.
    pub elevation_deg: f64,
    /// Distance from the array, m (rooms only).
    pub distance_m: f64,
    /// Power on the omni relative to the talker's power over his active part, dB.
    pub level_db: f64,
    /// Switch-on time, s from the file start.
    pub on_s: f64,
    /// Switch-off time, s from the file start (`None`: to the end).
    pub off_s: Option<f64>,
}

impl NoiseSource {
    /// Parses `KIND[,az=DEG][,el=DEG][,dist=M][,level=DB][,on=S][,off=S]`, e.g.
    /// `fan,az=40,el=20,dist=1.5,level=-18,on=40`. Defaults: az 0, el 0, dist 2 m, level −20 dB,
    /// on from the start to the end.
    pub fn parse(s: &str) -> Result<Self> {
        let bad = |why: String| {
            SimError::Usage(format!(
                "--noise-source {s:?}: {why} (expected KIND[,az=DEG][,el=DEG][,dist=M][,level=DB][,on=S][,off=S] with KIND one of {})",
                NoiseKind::ALL.map(NoiseKind::name).join(", ")
            ))
        };
        let mut parts = s.split(',');
        let kind_name = parts.next().unwrap_or("").trim();
        let kind = NoiseKind::ALL
            .into_iter()
            .find(|k| k.name() == kind_name)
            .ok_or_else(|| bad(format!("unknown kind {kind_name:?}")))?;
        let mut src = Self {
            kind,
            azimuth_deg: 0.0,
            elevation_deg: 0.0,
            distance_m: 2.0,
            level_db: -20.0,
            on_s: 0.0,
            off_s: None,
        };
        for p in parts {
            let (k, v) = p
                .split_once('=')
                .ok_or_else(|| bad(format!("{p:?} is not KEY=VALUE")))?;
            let v: f64 = v
                .trim()
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| bad(format!("{k} needs a finite number")))?;
            match k.trim() {
                "az" if v.abs() <= 720.0 => src.azimuth_deg = v,
                "el" if v.abs() <= 90.0 => src.elevation_deg = v,
                "dist" if (0.2..=30.0).contains(&v) => src.distance_m = v,
                "level" if (-80.0..=20.0).contains(&v) => src.level_db = v,
                "on" if (0.0..=3600.0).contains(&v) => src.on_s = v,
                "off" if (0.0..=3600.0).contains(&v) => src.off_s = Some(v),
                "az" | "el" | "dist" | "level" | "on" | "off" => {
                    return Err(bad(format!(
                        "{k}={v} is out of range (az ±720°, el ±90°, dist 0.2–30 m, level −80–20 dB, on/off 0–3600 s)"
                    )))
                }
                other => return Err(bad(format!("unknown key {other:?}"))),
            }
        }
        if src.off_s.is_some_and(|off| off <= src.on_s) {
            return Err(bad("off must come after on".into()));
        }
        Ok(src)
    }

    /// The truth line of the source (`kind,azimuth_deg,elevation_deg,distance_m,level_db,on_s,off_s`).
    #[must_use]
    pub fn truth_row(&self) -> String {
        format!(
            "{},{:.2},{:.2},{:.2},{:.2},{:.3},{}",
            self.kind.name(),
            self.azimuth_deg,
            self.elevation_deg,
            self.distance_m,
            self.level_db,
            self.on_s,
            self.off_s.map_or(String::new(), |v| format!("{v:.3}"))
        )
    }
}

/// The room a scene's sources are rendered through.
#[derive(Debug, Clone)]
pub enum SourceRoom {
    /// Free field: plane waves (elevation kept).
    Free,
    /// A measured response, rotated to each source's azimuth (its elevation is the response's).
    Measured(RoomResponse),
    /// A shoebox room with the array at a position.
    ShoeBox {
        /// The room.
        room: ShoeBox,
        /// The array's position, m.
        array: [f64; 3],
        /// Response length, s.
        length_s: f64,
    },
}

/// Renders `sources` (W, X, Y) over `total` samples at `rate`, each scaled so that its power on W
/// over its switched-on time is `reference_power`·10^(level/10).
#[must_use]
pub fn render(
    sources: &[NoiseSource],
    room: &SourceRoom,
    rate: u32,
    total: usize,
    reference_power: f64,
    seed: u64,
) -> [Vec<f64>; 3] {
    let fs = rate as f64;
    let mut out = [vec![0.0; total], vec![0.0; total], vec![0.0; total]];
    for (k, src) in sources.iter().enumerate() {
        let on = ((src.on_s * fs) as usize).min(total);
        let off = src.off_s.map_or(total, |t| ((t * fs) as usize).min(total));
        if off <= on {
            continue;
        }
        // A source on from the start was running before the recording began: it is rendered from
        // a second earlier, so its reverberation is there from the first sample.
        let pre = if on == 0 { rate as usize } else { 0 };
        let mut s = src.kind.signal(
            rate,
            total + pre,
            seed.wrapping_add(1_000_003 * (k as u64 + 1)),
        );
        // Switched on and off with 50 ms raised-cosine ramps (none at the file's ends).
        let ramp = (0.05 * fs) as usize;
        for (j, v) in s.iter_mut().enumerate() {
            let i = j.saturating_sub(pre);
            let g = if j >= pre && (i < on || i >= off) {
                0.0
            } else {
                let a = if on == 0 {
                    1.0
                } else {
                    ((i - on) as f64 / ramp as f64).min(1.0)
                };
                let b = if off == total {
                    1.0
                } else {
                    ((off - i) as f64 / ramp as f64).min(1.0)
                };
                let e = a.min(b);
                0.5 - 0.5 * (PI * e).cos()
            };
            *v *= g;
        }
        let rendered = match room {
            SourceRoom::Free => {
                let (a, e) = (src.azimuth_deg.to_radians(), src.elevation_deg.to_radians());
                let (cx, cy) = (e.cos() * a.cos(), e.cos() * a.sin());
                [
                    s.clone(),
                    s.iter().map(|v| v * cx).collect(),
                    s.iter().map(|v| v * cy).collect(),
                ]
            }
            SourceRoom::Measured(r) => r.rotated(src.azimuth_deg).map(|h| convolve(&s, &h)),
            SourceRoom::ShoeBox {
                room,
                array,
                length_s,
            } => {
                let p = room.place(*array, src.azimuth_deg, src.elevation_deg, src.distance_m);
                let (w, x, y) = room.response(*array, p, rate, *length_s).into_parts();
                [convolve(&s, &w), convolve(&s, &x), convolve(&s, &y)]
            }
        };
        let [w, x, y] = rendered.map(|v| v.into_iter().skip(pre).take(total).collect::<Vec<f64>>());
        // The level holds between the ramps.
        let a = if on == 0 { 0 } else { (on + ramp).min(off) };
        let b = if off == total {
            total
        } else {
            off.saturating_sub(ramp).max(a + 1)
        };
        let p = w[a..b].iter().map(|v| v * v).sum::<f64>() / (b - a) as f64;
        let g = (reference_power * 10f64.powf(src.level_db / 10.0) / p.max(1e-30)).sqrt();
        for (o, v) in out.iter_mut().zip([w, x, y]) {
            for (d, s) in o.iter_mut().zip(v) {
                *d += g * s;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_sources_and_names_what_is_wrong() {
        let s = NoiseSource::parse("fan,az=40,el=20,dist=1.5,level=-18,on=40").unwrap();
        assert_eq!(s.kind, NoiseKind::Fan);
        assert_eq!(
            (s.azimuth_deg, s.elevation_deg, s.distance_m),
            (40.0, 20.0, 1.5)
        );
        assert_eq!((s.level_db, s.on_s, s.off_s), (-18.0, 40.0, None));
        for (bad, says) in [
            ("drill,az=3", "unknown kind"),
            ("fan,az", "KEY=VALUE"),
            ("fan,level=nan", "finite"),
            ("fan,el=95", "out of range"),
            ("fan,on=5,off=2", "after on"),
            ("fan,colour=3", "unknown key"),
        ] {
            let e = NoiseSource::parse(bad).unwrap_err().to_string();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn every_kind_is_unit_power_and_reproducible() {
        for k in NoiseKind::ALL {
            let a = k.signal(16000, 16000, 3);
            let p = a.iter().map(|v| v * v).sum::<f64>() / a.len() as f64;
            assert!((p - 1.0).abs() < 1e-9, "{}", k.name());
            assert_eq!(a, k.signal(16000, 16000, 3));
        }
    }

    #[test]
    fn a_free_field_source_has_its_level_and_direction_while_on() {
        let src = NoiseSource::parse("white,az=120,level=-10,on=0.5,off=1.5").unwrap();
        let [w, x, y] = render(&[src], &SourceRoom::Free, 16000, 32000, 2.0, 1);
        let p = w[8800..23200].iter().map(|v| v * v).sum::<f64>() / 14400.0;
        assert!((p / 0.2 - 1.0).abs() < 0.05, "power {p}");
        assert!(w[..7000].iter().all(|v| *v == 0.0));
        let (ix, iy) = (0..32000).fold((0.0, 0.0), |(a, b), i| (a + w[i] * x[i], b + w[i] * y[i]));
        assert!((iy.atan2(ix).to_degrees() - 120.0).abs() < 0.1);
    }
}
