//! `host-sim distance-report`: the proximity-effect distance estimate (thesis §5.1.5 eq. 5.15,
//! [`cma_core::distance`]) on simulated near-field scenes.
//!
//! Front end (host-side for now): long frames (appendix A `Mfact` = 4 → 2048 samples at 16 kHz,
//! 128 ms, hop 1024), Hamming window, the `peaks` strongest local maxima of |X_omni| in a low band,
//! features |X_c|/|X_0| there. Frames more than 30 dB below the scene's loudest frame are skipped.
//! The azimuth is given (the truth), as eq. 5.15 assumes a known direction.

use crate::error::Result;
use crate::simulation::scene::{self, Motion, SceneSpec};
use cma_core::distance::{accumulate_scores, best_distance, REFERENCE_DISTANCES_M};
use rustfft::num_complex::Complex;
use rustfft::FftPlanner;
use std::path::Path;

/// Long frame length (512 · `Mfact` with `Mfact` = 4).
pub const LONG_FRAME: usize = 2048;

/// Result for one true distance.
#[derive(Debug, Clone, PartialEq)]
pub struct DistanceRow {
    /// SNR of the scenes, dB (`None`: no noise).
    pub snr_db: Option<f64>,
    /// True distance, m.
    pub true_m: f32,
    /// Frames classified as each reference distance.
    pub frame_counts: [usize; 3],
    /// Scenes whose summed score picks each reference distance.
    pub scene_counts: [usize; 3],
}

/// Per-frame distance decisions and the summed scores of one recording.
pub fn analyse(
    frames: &[[f32; 4]],
    rate: u32,
    azimuth_deg: f32,
    band_hz: (f32, f32),
    peaks: usize,
) -> (Vec<usize>, [f32; 3]) {
    let mut planner = FftPlanner::<f32>::new();
    let fft = planner.plan_fft_forward(LONG_FRAME);
    let win: Vec<f32> = (0..LONG_FRAME)
        .map(|n| {
            0.54 - 0.46 * (2.0 * std::f32::consts::PI * n as f32 / (LONG_FRAME - 1) as f32).cos()
        })
        .collect();
    let hop = LONG_FRAME / 2;
    let n_frames = frames.len().saturating_sub(LONG_FRAME) / hop + 1;
    let energy: Vec<f32> = (0..n_frames)
        .map(|l| {
            frames[l * hop..(l * hop + LONG_FRAME).min(frames.len())]
                .iter()
                .map(|f| f[0] * f[0])
                .sum()
        })
        .collect();
    let max_e = energy.iter().copied().fold(0.0f32, f32::max);
    let df = rate as f32 / LONG_FRAME as f32;
    let (lo, hi) = (
        ((band_hz.0 / df).round() as usize).max(1),
        ((band_hz.1 / df).round() as usize).min(LONG_FRAME / 2 - 1),
    );
    let mut decisions = Vec::new();
    let mut total = [0.0f32; 3];
    let mut spec = vec![vec![Complex::new(0.0f32, 0.0); LONG_FRAME]; 4];
    for (l, e) in energy.iter().enumerate() {
        if !(max_e > 0.0) || *e < max_e * 1e-3 || l * hop + LONG_FRAME > frames.len() {
            continue;
        }
        for (c, s) in spec.iter_mut().enumerate() {
            for (n, v) in s.iter_mut().enumerate() {
                *v = Complex::new(frames[l * hop + n][c] * win[n], 0.0);
            }
            fft.process(s);
        }
        let p0: Vec<f32> = spec[0].iter().map(|v| v.norm_sqr()).collect();
        let mut cand: Vec<usize> = (lo..=hi)
            .filter(|&k| p0[k] > p0[k - 1] && p0[k] >= p0[k + 1] && p0[k] > 0.0)
            .collect();
        cand.sort_by(|a, b| p0[*b].total_cmp(&p0[*a]));
        cand.truncate(peaks);
        let feats: Vec<(f32, [f32; 3])> = cand
            .iter()
            .map(|&k| {
                let m0 = p0[k].sqrt();
                (
                    k as f32 * df,
                    [
                        spec[1][k].norm() / m0,
                        spec[2][k].norm() / m0,
                        spec[3][k].norm() / m0,
                    ],
                )
            })
            .collect();
        let mut s = [0.0f32; 3];
        if accumulate_scores(azimuth_deg, &feats, &REFERENCE_DISTANCES_M, &mut s) {
            if let Some(i) = best_distance(&s) {
                decisions.push(i);
            }
            for (t, v) in total.iter_mut().zip(s) {
                *t += v;
            }
        }
    }
    (decisions, total)
}

/// Runs the report: for each SNR and each true distance in {0.5, 1, 2} m, the talkers of `data/speech`
/// at azimuths 0°, 70°, 150°, −100° rendered as near-field point sources (anechoic, diffuse noise).
pub fn distance_report(
    data: &Path,
    snrs: &[Option<f64>],
    band_hz: (f32, f32),
    peaks: usize,
) -> Result<Vec<DistanceRow>> {
    let rate = 16_000;
    let talkers = [
        "speech/cmu_arctic_us_aew_a0001.wav",
        "speech/cmu_arctic_us_axb_a0004.wav",
    ];
    let mut sources = Vec::new();
    for t in talkers {
        sources.push(scene::load_source(Some(&data.join(t)), None, rate, 1)?);
    }
    let mut rows = Vec::new();
    for snr in snrs {
        for r in REFERENCE_DISTANCES_M {
            let mut row = DistanceRow {
                snr_db: *snr,
                true_m: r,
                frame_counts: [0; 3],
                scene_counts: [0; 3],
            };
            for (si, source) in sources.iter().enumerate() {
                for az in [0.0, 70.0, 150.0, -100.0] {
                    let spec = SceneSpec {
                        source: source.clone(),
                        rate,
                        lead_in_s: 0.25,
                        motion: Motion::Steps(vec![(0.0, az)]),
                        snr_db: *snr,
                        room: None,
                        peak_dbfs: -3.0,
                        seed: 11 + si as u64,
                        array: Default::default(),
                        noise_sources: Vec::new(),
                        source_room: crate::simulation::noise_source::SourceRoom::Free,
                    };
                    let p = scene::synthesize_parts(&spec, Some(r as f64));
                    let mix: Vec<[f32; 4]> = p
                        .talker
                        .iter()
                        .zip(&p.noise)
                        .map(|(t, n)| std::array::from_fn(|c| t[c] + n[c]))
                        .collect();
                    let (dec, total) = analyse(&mix, rate, az as f32, band_hz, peaks);
                    for d in dec {
                        row.frame_counts[d] += 1;
                    }
                    if let Some(i) = best_distance(&total) {
                        row.scene_counts[i] += 1;
                    }
                }
            }
            rows.push(row);
        }
    }
    Ok(rows)
}

/// The report as a Markdown table (rows: SNR × true distance; columns: share of frames / scenes
/// classified as 0.5, 1, 2 m).
#[must_use]
pub fn format_report(rows: &[DistanceRow]) -> String {
    let mut s = String::from(
        "| SNR | true r | frames → 0.5 / 1 / 2 m (%) | frame accuracy | scenes → 0.5 / 1 / 2 m |\n|---|---|---|---|---|\n",
    );
    for r in rows {
        let n: usize = r.frame_counts.iter().sum();
        let pct = |c: usize| 100.0 * c as f64 / n.max(1) as f64;
        let idx = REFERENCE_DISTANCES_M
            .iter()
            .position(|d| *d == r.true_m)
            .unwrap_or(0);
        s.push_str(&format!(
            "| {} | {} m | {:.0} / {:.0} / {:.0} | {:.0} % of {n} | {} / {} / {} |\n",
            r.snr_db.map_or("clean".into(), |v| format!("{v} dB")),
            r.true_m,
            pct(r.frame_counts[0]),
            pct(r.frame_counts[1]),
            pct(r.frame_counts[2]),
            pct(r.frame_counts[idx]),
            r.scene_counts[0],
            r.scene_counts[1],
            r.scene_counts[2],
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clean_synthetic_near_field_scenes_are_classified() {
        let rate = 16_000;
        for (i, r) in REFERENCE_DISTANCES_M.iter().enumerate() {
            let spec = SceneSpec {
                source: scene::synthetic_speech(rate, 1.5, 2),
                rate,
                lead_in_s: 0.1,
                motion: Motion::Steps(vec![(0.0, 40.0)]),
                snr_db: None,
                room: None,
                peak_dbfs: -3.0,
                seed: 1,
                array: Default::default(),
                noise_sources: Vec::new(),
                source_room: crate::simulation::noise_source::SourceRoom::Free,
            };
            let p = scene::synthesize_parts(&spec, Some(*r as f64));
            let (_, total) = analyse(&p.talker, rate, 40.0, (80.0, 500.0), 5);
            assert_eq!(best_distance(&total), Some(i), "{r} m: {total:?}");
        }
    }
}
