//! Self-steered first-order beamformer for CMA1 (thesis §3.3, eq. 3.16–3.29; appendix A
//! `result.sig`, `result.sigb`, `se.omnibeam`, `se.wbeam`, `se.beamAz`).
//!
//! Eigenbeams (eq. 3.18–3.23, scaled as in [`crate::bformat`]): W = ⅔·Σc_m (or the omni capsule,
//! eq. 3.28–3.29), X = ⁴⁄₃·Σc_m cos φ_m, Y = ⁴⁄₃·Σc_m sin φ_m. Modal weights (eq. 3.25) give the
//! virtual microphone H_β(φ) = (1 − β) + β·cos(φ − φ_s):
//!
//! ```text
//! y = (1 − β)·W + β·(X cos φ_s + Y sin φ_s)            (forward, steered at φ_s)
//! y_rev = (1 − β)·W + β·(X cos(φ_s+π) + Y sin(φ_s+π))  (reverse-steered, `sigb`)
//! ```
//!
//! β = 0 omni, ½ cardioid, ¾ hypercardioid, 1 figure-8 (eq. 3.7; `docs/algorithm.md` notes that
//! Table 3.1 swaps the omni and figure-8 rows). The beamformer runs at the *input* rate ("Beamformer
//! always works with original and not downsampled signal", appendix A): a sample frame in, one
//! (forward, reverse) sample pair out.
//!
//! **Click-free steering.** A new steering angle (typically one per analysis hop, from the
//! localizer) is not applied at once: the steering vector (cos φ_s, sin φ_s) moves linearly from the
//! old to the new value over `ramp_len` samples. The output is a linear function of that vector, so
//! the sample-to-sample change caused by steering is at most β·‖ΔXY‖·2/ramp_len per sample — bounded
//! whatever the jump. The interpolation is on the unit-vector components (not on the angle), so a jump
//! of 180° passes through a narrower pattern rather than sweeping round; that keeps it cheap
//! (no trigonometry per sample) and symmetric.
//!
//! When steered from the localizer the steering lags the talker by the analysis latency (one analysis
//! frame plus the decimator delay) plus the ramp: say so in user documentation.

use crate::bformat::{COS_LOOK, SIN_LOOK};
use crate::CHANNELS;

/// Where the W (omni) eigenbeam comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OmniSource {
    /// ⅔·(c₁ + c₂ + c₃): the cardioids only (appendix A `se.omnibeam = 0`, eq. 3.27).
    CardioidSum,
    /// The omni capsule, channel 0 (`se.omnibeam = 1`, eq. 3.28–3.29): nicer low end, but the pattern
    /// depends on its gain matching the cardioids'.
    OmniCapsule,
}

/// Beamformer configuration (fixed while it runs).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BeamConfig {
    /// Pattern β ∈ [0, 1] of the virtual microphone (0 omni … 0.5 cardioid … 0.75 hypercardioid … 1
    /// figure-8).
    pub beta: f32,
    /// Source of the W eigenbeam.
    pub omni: OmniSource,
    /// Samples over which a steering change is ramped (≥ 1; one analysis hop at the input rate is
    /// the natural choice).
    pub ramp_len: u32,
}

impl BeamConfig {
    /// Cardioid (β = ½) on the cardioid sum, ramped over 1024 samples (one hop at 48 kHz).
    pub const CARDIOID: BeamConfig = BeamConfig {
        beta: 0.5,
        omni: OmniSource::CardioidSum,
        ramp_len: 1024,
    };

    /// `true` when β ∈ [0, 1] and the ramp is at least one sample.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        (0.0..=1.0).contains(&self.beta) && self.ramp_len >= 1
    }

    /// Directivity factor Q of the virtual pattern in a 3-D diffuse field (eq. 3.8):
    /// Q = 1 / ((1 − β)² + β²/3). Its dB value is the theoretical SNR gain over an omni.
    #[must_use]
    pub fn directivity_factor(&self) -> f32 {
        let a = 1.0 - self.beta;
        1.0 / (a * a + self.beta * self.beta / 3.0)
    }

    /// 4-channel weight vector w (eq. 3.26/3.28) for steering unit vector (cx, sx) = (cos φ_s, sin φ_s):
    /// `y = w · [omni, c₁, c₂, c₃]`.
    #[must_use]
    pub fn weights(&self, cx: f32, sx: f32) -> [f32; CHANNELS] {
        let b = self.beta;
        let mut w = [0.0f32; CHANNELS];
        let w_gain = 1.0 - b;
        match self.omni {
            OmniSource::OmniCapsule => w[0] = w_gain,
            OmniSource::CardioidSum => {
                for wm in &mut w[1..] {
                    *wm = w_gain * (2.0 / 3.0);
                }
            }
        }
        for m in 0..3 {
            w[m + 1] += b * (4.0 / 3.0) * (COS_LOOK[m] * cx + SIN_LOOK[m] * sx);
        }
        w
    }
}

/// Run-time state of the beamformer: current and target steering vectors and the ramp position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamState {
    cur: [f32; 2],
    from: [f32; 2],
    to: [f32; 2],
    step: u32,
    ramp: u32,
}

impl BeamState {
    /// A beamformer looking at `azimuth_deg` (no ramp pending).
    #[must_use]
    pub fn new(azimuth_deg: f32) -> Self {
        let v = unit(azimuth_deg);
        Self {
            cur: v,
            from: v,
            to: v,
            step: 0,
            ramp: 0,
        }
    }

    /// Requests steering to `azimuth_deg`, reached linearly over `config.ramp_len` samples from the
    /// current (possibly mid-ramp) steering vector. Non-finite angles are ignored.
    pub fn steer(&mut self, config: &BeamConfig, azimuth_deg: f32) {
        if !azimuth_deg.is_finite() {
            return;
        }
        self.from = self.cur;
        self.to = unit(azimuth_deg);
        self.step = 0;
        self.ramp = config.ramp_len.max(1);
    }

    /// Current steering azimuth, degrees (of the possibly mid-ramp steering vector).
    #[must_use]
    pub fn azimuth_deg(&self) -> f32 {
        libm::atan2f(self.cur[1], self.cur[0]).to_degrees()
    }

    /// Target steering azimuth, degrees.
    #[must_use]
    pub fn target_deg(&self) -> f32 {
        libm::atan2f(self.to[1], self.to[0]).to_degrees()
    }
}

fn unit(deg: f32) -> [f32; 2] {
    let r = deg.to_radians();
    let (s, c) = crate::trig::sin_cos(r);
    [c, s]
}

/// Forward and reverse-steered output of one sample frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BeamSample {
    /// Steered at the target (`result.sig`).
    pub forward: f32,
    /// Steered away, φ_s + 180° (`result.sigb`).
    pub reverse: f32,
}

/// Processes one sample frame (omni, c₁, c₂, c₃) and advances the steering ramp.
#[inline]
#[must_use]
pub fn process(config: &BeamConfig, state: &mut BeamState, x: [f32; CHANNELS]) -> BeamSample {
    if state.step < state.ramp {
        state.step += 1;
        let t = state.step as f32 / state.ramp as f32;
        state.cur = [
            state.from[0] + t * (state.to[0] - state.from[0]),
            state.from[1] + t * (state.to[1] - state.from[1]),
        ];
    }
    let b = config.beta;
    let w = match config.omni {
        OmniSource::OmniCapsule => x[0],
        OmniSource::CardioidSum => (2.0 / 3.0) * (x[1] + x[2] + x[3]),
    };
    let mut xe = 0.0f32;
    let mut ye = 0.0f32;
    for m in 0..3 {
        xe += x[m + 1] * COS_LOOK[m];
        ye += x[m + 1] * SIN_LOOK[m];
    }
    let d = (4.0 / 3.0) * (xe * state.cur[0] + ye * state.cur[1]);
    let o = (1.0 - b) * w;
    BeamSample {
        forward: o + b * d,
        reverse: o - b * d,
    }
}

/// Processes a block of sample frames into `forward` and `reverse` (the shorter length wins).
pub fn process_block(
    config: &BeamConfig,
    state: &mut BeamState,
    input: &[[f32; CHANNELS]],
    forward: &mut [f32],
    reverse: &mut [f32],
) {
    for ((x, f), r) in input.iter().zip(forward.iter_mut()).zip(reverse.iter_mut()) {
        let s = process(config, state, *x);
        *f = s.forward;
        *r = s.reverse;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CMA1 sample frame of a plane wave of amplitude `s` from `az` degrees (eq. 3.15).
    fn plane(s: f32, az: f32) -> [f32; 4] {
        let a = az.to_radians();
        let mut f = [s; 4];
        for m in 0..3 {
            let l = (m as f32 * 120.0).to_radians();
            f[m + 1] = s * (0.5 + 0.5 * (a - l).cos());
        }
        f
    }

    #[test]
    fn steered_pattern_is_first_order_for_all_betas_and_w_sources() {
        for omni in [OmniSource::CardioidSum, OmniSource::OmniCapsule] {
            for beta in [0.0f32, 0.5, 0.75, 1.0] {
                let c = BeamConfig {
                    beta,
                    omni,
                    ramp_len: 1,
                };
                for steer in [0.0f32, 37.0, -120.0, 200.0] {
                    let mut st = BeamState::new(steer);
                    for src in (0..360).step_by(15) {
                        let src = src as f32;
                        let y = process(&c, &mut st, plane(1.0, src));
                        let d = (src - steer).to_radians();
                        let want = (1.0 - beta) + beta * d.cos();
                        let want_rev = (1.0 - beta) - beta * d.cos();
                        assert!((y.forward - want).abs() < 1e-5, "{beta} {steer} {src}");
                        assert!((y.reverse - want_rev).abs() < 1e-5);
                        // the weight-vector form (eq. 3.29) agrees with the eigenbeam form
                        let (cx, sx) = (steer.to_radians().cos(), steer.to_radians().sin());
                        let w = c.weights(cx, sx);
                        let x = plane(1.0, src);
                        let yw: f32 = w.iter().zip(x).map(|(a, b)| a * b).sum();
                        assert!((yw - want).abs() < 1e-5);
                    }
                }
            }
        }
    }

    #[test]
    fn directivity_factor_matches_table_3_1() {
        let q = |beta| {
            10.0 * BeamConfig {
                beta,
                ..BeamConfig::CARDIOID
            }
            .directivity_factor()
            .log10()
        };
        assert!(q(0.0).abs() < 1e-6);
        assert!((q(0.5) - 4.77).abs() < 0.01);
        assert!((q(0.75) - 6.02).abs() < 0.01);
        assert!((q(1.0) - 4.77).abs() < 0.01);
    }

    #[test]
    fn steering_jump_is_click_free_on_a_steady_tone() {
        // 1 kHz tone from 90° at 48 kHz; steering jumps 0° → 180° → 90° every 1024 samples.
        let c = BeamConfig {
            beta: 1.0,
            omni: OmniSource::CardioidSum,
            ramp_len: 1024,
        };
        let fs = 48_000.0f32;
        let mut st = BeamState::new(0.0);
        let mut prev = 0.0f32;
        let mut max_step = 0.0f32;
        let targets = [180.0f32, 90.0, -90.0, 0.0];
        for n in 0..(1024 * 8) {
            if n % 1024 == 0 {
                st.steer(&c, targets[(n / 1024) % targets.len()]);
            }
            let s = libm::sinf(2.0 * core::f32::consts::PI * 1000.0 * n as f32 / fs);
            let y = process(&c, &mut st, plane(s, 90.0)).forward;
            if n > 0 {
                max_step = max_step.max((y - prev).abs());
            }
            prev = y;
        }
        // The tone alone moves by at most 2π·1000/48000 ≈ 0.131 per sample at unit gain;
        // steering adds at most 2/1024 per sample. A hard switch would jump by up to 2.
        assert!(max_step < 0.14, "max step {max_step}");

        // Without a ramp the same jump clicks.
        let hard = BeamConfig { ramp_len: 1, ..c };
        let mut st = BeamState::new(-90.0);
        let s0 = process(&hard, &mut st, plane(1.0, 90.0)).forward;
        st.steer(&hard, 90.0);
        let s1 = process(&hard, &mut st, plane(1.0, 90.0)).forward;
        assert!((s1 - s0).abs() > 1.9);
    }

    #[test]
    fn ramp_reaches_target_and_ignores_nan() {
        let c = BeamConfig {
            ramp_len: 10,
            ..BeamConfig::CARDIOID
        };
        let mut st = BeamState::new(0.0);
        st.steer(&c, 90.0);
        for _ in 0..10 {
            let _ = process(&c, &mut st, [0.0; 4]);
        }
        assert!((st.azimuth_deg() - 90.0).abs() < 1e-4);
        st.steer(&c, f32::NAN);
        assert!((st.target_deg() - 90.0).abs() < 1e-4);
        let mut f = [0.0; 3];
        let mut r = [0.0; 3];
        process_block(&c, &mut st, &[plane(1.0, 90.0); 3], &mut f, &mut r);
        assert!((f[2] - 1.0).abs() < 1e-5 && r[2].abs() < 1e-5);
    }
}
