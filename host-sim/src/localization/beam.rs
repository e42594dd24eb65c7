//! `host-sim beam` and `host-sim beam-report`: the self-steered beamformer (thesis §3.3, appendix A
//! `result.sig` / `result.sigb`) on WAV files and its measured SNR gain on simulated scenes.
//!
//! The beamformer runs at the input rate next to the localizer, sample by sample as the firmware
//! would. With `--steer estimate` each new estimate (one per analysis hop) becomes the steering target
//! from the next sample on, so the beam lags the talker by the localizer's latency (one analysis frame
//! plus the decimator delay, ≈ 45 ms at 48 kHz) and then ramps over one hop (click-free steering,
//! [`cma_core::beamformer`]).

use crate::error::{Result, SimError};
use crate::io::ground_truth::Track;
use crate::io::wav_io::{write_wav, OutFormat};
use crate::simulation::scene::{self, Motion, SceneSpec};
use cma_core::beamformer::{self as bf, BeamConfig, BeamState, OmniSource};
use cma_core::{Locator, LocatorConfig, ReferenceTable};
use std::path::Path;

/// Where the beam points.
#[derive(Debug, Clone, PartialEq)]
pub enum Steer {
    /// At the localizer's estimate, updated once per analysis hop.
    Estimate,
    /// At the ground truth (a `.pos.csv` track), updated once per analysis hop.
    Truth(Track),
    /// At a fixed azimuth, degrees (appendix A `se.beamAz`).
    Fixed(f32),
}

/// Output of [`beamform`]: forward and reverse-steered signals plus the steering target per hop.
#[derive(Debug, Clone, Default)]
pub struct BeamOutput {
    /// Steered at the target (`result.sig`).
    pub forward: Vec<f32>,
    /// Steered away (`result.sigb`).
    pub reverse: Vec<f32>,
    /// (time s, steering target °) at every change of target.
    pub steering: Vec<(f64, f32)>,
}

/// Runs the localizer and the beamformer over `frames` at `rate`. Extra signals in `also` (same length
/// as `frames`, e.g. the talker-only and noise-only parts of a scene) are beamformed with the *same*
/// steering sequence; their outputs follow in the returned vector.
pub fn beamform(
    frames: &[[f32; 4]],
    rate: u32,
    steer: &Steer,
    beam: BeamConfig,
    config: LocatorConfig,
    table: ReferenceTable<'_>,
    also: &[&[[f32; 4]]],
) -> Result<(BeamOutput, Vec<BeamOutput>)> {
    if !beam.is_valid() {
        return Err(SimError::Usage(format!(
            "--pattern: expected 0 ≤ β ≤ 1, got {}",
            beam.beta
        )));
    }
    let mut loc = Locator::new(config, table, rate).map_err(|source| SimError::Core {
        context: "configuration".into(),
        source,
    })?;
    let hop = loc.input_samples_per_hop();
    let start = match steer {
        Steer::Fixed(a) => *a,
        Steer::Truth(t) => t.azimuth_at(0.0) as f32,
        Steer::Estimate => 0.0,
    };
    let mut states = vec![BeamState::new(start); 1 + also.len()];
    let mut outs: Vec<BeamOutput> = (0..=also.len())
        .map(|_| BeamOutput {
            forward: Vec::with_capacity(frames.len()),
            reverse: Vec::with_capacity(frames.len()),
            steering: vec![(0.0, start)],
        })
        .collect();
    for (n, x) in frames.iter().enumerate() {
        let target = match steer {
            Steer::Estimate => loc.process_sample(*x).map(|e| e.azimuth_deg),
            Steer::Truth(t) if n % hop == 0 => Some(t.azimuth_at(n as f64 / rate as f64) as f32),
            _ => None,
        };
        if let Some(a) = target {
            let changed = outs[0].steering.last().is_none_or(|l| l.1 != a);
            for (st, o) in states.iter_mut().zip(outs.iter_mut()) {
                st.steer(&beam, a);
                if changed {
                    o.steering.push((n as f64 / rate as f64, a));
                }
            }
        }
        for (i, (st, o)) in states.iter_mut().zip(outs.iter_mut()).enumerate() {
            let input = if i == 0 {
                *x
            } else {
                also[i - 1].get(n).copied().unwrap_or([0.0; 4])
            };
            let y = bf::process(&beam, st, input);
            o.forward.push(y.forward);
            o.reverse.push(y.reverse);
        }
    }
    let first = outs.remove(0);
    Ok((first, outs))
}

/// Mean-square level of `x[a..b]` in dB (−300 dB for silence or an empty range).
#[must_use]
pub fn level_db(x: &[f32], a: usize, b: usize) -> f64 {
    let b = b.min(x.len());
    if a >= b {
        return -300.0;
    }
    let p = x[a..b].iter().map(|v| (*v as f64).powi(2)).sum::<f64>() / (b - a) as f64;
    10.0 * p.max(1e-30).log10()
}

/// Writes a mono WAV (32-bit float, so a beam louder than the input does not clip).
pub fn write_mono(path: &Path, rate: u32, x: &[f32]) -> Result<()> {
    write_wav(path, rate, 1, x, OutFormat::Float)
}

/// One line of the beam report.
#[derive(Debug, Clone, PartialEq)]
pub struct BeamRow {
    /// Scene label.
    pub scene: String,
    /// Pattern β.
    pub beta: f32,
    /// W source.
    pub omni: OmniSource,
    /// Steering label.
    pub steer: &'static str,
    /// Output SNR minus omni SNR, dB.
    pub snr_gain_db: f64,
    /// Talker level forward minus reverse, dB.
    pub front_back_db: f64,
    /// Theoretical gain in a 3-D diffuse field (directivity index), dB.
    pub theory_db: f64,
}

/// Scenes of the report: (label, talker WAV, azimuth °, room response, near-field distance).
fn report_scenes(
    data: &Path,
) -> Vec<(String, std::path::PathBuf, f64, Option<std::path::PathBuf>)> {
    let speech = data.join("speech/cmu_arctic_us_aew_a0001.wav");
    let speech_f = data.join("speech/cmu_arctic_us_axb_a0004.wav");
    let rir = data.join("rir/marco_p90deg_3m_FOA_ACN_SN3D.wav");
    vec![
        ("anechoic 30° male".into(), speech.clone(), 30.0, None),
        (
            "anechoic −135° female".into(),
            speech_f.clone(),
            -135.0,
            None,
        ),
        (
            "room (3D-MARCo RIR) 100° male".into(),
            speech,
            100.0,
            Some(rir.clone()),
        ),
        (
            "room (3D-MARCo RIR) −40° female".into(),
            speech_f,
            -40.0,
            Some(rir),
        ),
    ]
}

/// Runs the beamformer report on scenes built from `data` (the `shared/data/src` folder): diffuse pink
/// noise at `snr_db` on the omni, patterns β ∈ {½, ¾, 1} with the cardioid-sum W and β = ¾ with the
/// omni capsule as W, steered at the truth and at the estimate. Levels are measured over the talker's
/// active interval from 0.5 s after its start (the estimate has settled by then).
pub fn beam_report(data: &Path, snr_db: f64, rate: u32) -> Result<Vec<BeamRow>> {
    let mut rows = Vec::new();
    let table = ReferenceTable::ideal_5deg();
    for (label, wav, az, rir) in report_scenes(data) {
        let source = scene::load_source(Some(&wav), None, rate, 1)?;
        let room = rir
            .as_deref()
            .map(|p| scene::RoomResponse::read(p, rate, false, 0.5, Some(79.5)))
            .transpose()?;
        let spec = SceneSpec {
            source,
            rate,
            lead_in_s: 0.25,
            motion: Motion::Steps(vec![(0.0, az)]),
            snr_db: Some(snr_db),
            room: room.map(scene::TalkerRoom::Rotated),
            peak_dbfs: -3.0,
            seed: 7,
            array: Default::default(),
            noise_sources: Vec::new(),
            source_room: crate::simulation::noise_source::SourceRoom::Free,
        };
        let parts = scene::synthesize_parts(&spec, None);
        let mix: Vec<[f32; 4]> = parts
            .talker
            .iter()
            .zip(&parts.noise)
            .map(|(t, n)| core::array::from_fn(|c| t[c] + n[c]))
            .collect();
        let a = ((parts.active_s.0 + 0.5) * rate as f64) as usize;
        let b = (parts.active_s.1 * rate as f64) as usize;
        let omni_t: Vec<f32> = parts.talker.iter().map(|f| f[0]).collect();
        let omni_n: Vec<f32> = parts.noise.iter().map(|f| f[0]).collect();
        let omni_snr = level_db(&omni_t, a, b) - level_db(&omni_n, a, b);
        let truth = Track {
            rows: vec![(0.0, az)],
        };
        let patterns = [
            (0.5f32, OmniSource::CardioidSum),
            (0.75, OmniSource::CardioidSum),
            (1.0, OmniSource::CardioidSum),
            (0.75, OmniSource::OmniCapsule),
        ];
        for (beta, omni) in patterns {
            let beam = BeamConfig {
                beta,
                omni,
                ramp_len: 256,
            };
            for (name, steer) in [
                ("truth", Steer::Truth(truth.clone())),
                ("estimate", Steer::Estimate),
            ] {
                let (_, parts_out) = beamform(
                    &mix,
                    rate,
                    &steer,
                    beam,
                    LocatorConfig::default(),
                    table,
                    &[&parts.talker, &parts.noise],
                )?;
                let (t, n) = (&parts_out[0], &parts_out[1]);
                let snr = level_db(&t.forward, a, b) - level_db(&n.forward, a, b);
                rows.push(BeamRow {
                    scene: label.clone(),
                    beta,
                    omni,
                    steer: name,
                    snr_gain_db: snr - omni_snr,
                    front_back_db: level_db(&t.forward, a, b) - level_db(&t.reverse, a, b),
                    theory_db: 10.0 * (beam.directivity_factor() as f64).log10(),
                });
            }
        }
    }
    Ok(rows)
}

/// The report as a Markdown table.
#[must_use]
pub fn format_report(rows: &[BeamRow]) -> String {
    let mut s = String::from(
        "| scene | β | W | steer | SNR gain over omni, dB | theory (DI), dB | talker fwd − rev, dB |\n|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {:.2} | {:.2} | {:.1} |\n",
            r.scene,
            r.beta,
            match r.omni {
                OmniSource::CardioidSum => "⅔Σcard",
                OmniSource::OmniCapsule => "omni",
            },
            r.steer,
            r.snr_gain_db,
            r.theory_db,
            r.front_back_db
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truth_steered_cardioid_gains_its_directivity_index_in_diffuse_noise() {
        let rate = 16_000;
        let spec = SceneSpec {
            source: scene::synthetic_speech(rate, 2.0, 3),
            rate,
            lead_in_s: 0.25,
            motion: Motion::Steps(vec![(0.0, 60.0)]),
            snr_db: Some(0.0),
            room: None,
            peak_dbfs: -3.0,
            seed: 5,
            array: Default::default(),
            noise_sources: Vec::new(),
            source_room: crate::simulation::noise_source::SourceRoom::Free,
        };
        let p = scene::synthesize_parts(&spec, None);
        let mix: Vec<[f32; 4]> = p
            .talker
            .iter()
            .zip(&p.noise)
            .map(|(t, n)| core::array::from_fn(|c| t[c] + n[c]))
            .collect();
        let truth = Steer::Truth(Track {
            rows: vec![(0.0, 60.0)],
        });
        let (out, parts) = beamform(
            &mix,
            rate,
            &truth,
            BeamConfig::CARDIOID,
            LocatorConfig::default(),
            ReferenceTable::ideal_15deg(),
            &[&p.talker, &p.noise],
        )
        .unwrap();
        let (a, b) = (8000, p.talker.len());
        let o_t: Vec<f32> = p.talker.iter().map(|f| f[0]).collect();
        let o_n: Vec<f32> = p.noise.iter().map(|f| f[0]).collect();
        // talker from the look direction passes at unit gain
        assert!((level_db(&parts[0].forward, a, b) - level_db(&o_t, a, b)).abs() < 0.01);
        // diffuse noise drops by ≈ 4.8 dB (finite-length estimate)
        let drop = level_db(&o_n, a, b) - level_db(&parts[1].forward, a, b);
        assert!((drop - 4.77).abs() < 0.5, "{drop}");
        // the mixture output is the sum of the parts (linearity with a shared steering sequence)
        for n in (a..b).step_by(997) {
            assert!((out.forward[n] - parts[0].forward[n] - parts[1].forward[n]).abs() < 1e-5);
        }
        assert!(beamform(
            &mix,
            rate,
            &Steer::Fixed(0.0),
            BeamConfig {
                beta: 1.5,
                ..BeamConfig::CARDIOID
            },
            LocatorConfig::default(),
            ReferenceTable::ideal_15deg(),
            &[]
        )
        .is_err());
    }
}
