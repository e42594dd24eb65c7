//! Shoebox rooms by the image-source method (Allen & Berkley 1979): the first-order (W, X, Y; SN3D)
//! response from a point source to the array, so that `host-sim scene --room` renders talkers and
//! noise sources through rooms of any size and reverberation time without measured responses.
//!
//! Every wall reflects with the same pressure coefficient β = √(1 − ᾱ), ᾱ from Sabine's formula
//! (RT60 = 0.161 V / (S ᾱ)). An image at distance r after k reflections arrives with the gain
//! β^k / r and the direction from the array to the image; its fractional delay is realised by a
//! Hann-windowed sinc. Images are kept up to the response's length and down to −80 dB of the direct
//! sound.

use crate::error::{Result, SimError};
use crate::simulation::scene::RoomResponse;
use crate::simulation::signal::Rng;
use std::f64::consts::PI;

/// Speed of sound, m/s.
pub const SPEED_OF_SOUND: f64 = 343.0;
/// Half length of the fractional-delay filter, taps.
const HALF_TAPS: i64 = 16;
/// The closest a source or the array comes to a wall, m.
const WALL_CLEARANCE: f64 = 0.3;

/// A shoebox room: its size and reverberation time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShoeBox {
    /// Length, width and height, m.
    pub dims: [f64; 3],
    /// Reverberation time (Sabine), s.
    pub rt60: f64,
}

impl ShoeBox {
    /// Parses `LxWxH:RT60`, e.g. `6x5x3:0.45` (metres, seconds).
    pub fn parse(s: &str) -> Result<Self> {
        let bad = |why: &str| {
            SimError::Usage(format!(
                "--room {s:?}: {why} (expected LxWxH:RT60 in metres and seconds, e.g. 6x5x3:0.45)"
            ))
        };
        let (size, rt) = s.split_once(':').ok_or_else(|| bad("no `:RT60`"))?;
        let dims: Vec<f64> = size
            .split('x')
            .map(|v| v.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| bad("a size is not a number"))?;
        let rt60: f64 = rt.trim().parse().map_err(|_| bad("RT60 is not a number"))?;
        if dims.len() != 3 {
            return Err(bad("three sizes are needed"));
        }
        if dims
            .iter()
            .any(|d| !d.is_finite() || !(2.0..=50.0).contains(d))
        {
            return Err(bad("each size must lie in 2..=50 m"));
        }
        if !rt60.is_finite() || !(0.05..=3.0).contains(&rt60) {
            return Err(bad("RT60 must lie in 0.05..=3 s"));
        }
        let room = Self {
            dims: [dims[0], dims[1], dims[2]],
            rt60,
        };
        if room.mean_absorption() >= 1.0 {
            return Err(bad(
                "RT60 is too short for a room of this size (Sabine's absorption > 1)",
            ));
        }
        Ok(room)
    }

    /// Mean absorption coefficient from Sabine's formula.
    #[must_use]
    pub fn mean_absorption(&self) -> f64 {
        let [l, w, h] = self.dims;
        let volume = l * w * h;
        let surface = 2.0 * (l * w + l * h + w * h);
        0.161 * volume / (surface * self.rt60)
    }

    /// Pressure reflection coefficient of every wall.
    #[must_use]
    pub fn reflection(&self) -> f64 {
        (1.0 - self.mean_absorption().min(1.0)).sqrt()
    }

    /// A point inside the room, at least the wall clearance from every wall.
    #[must_use]
    pub fn clamp(&self, p: [f64; 3]) -> [f64; 3] {
        let mut q = p;
        for (v, d) in q.iter_mut().zip(self.dims) {
            *v = v.clamp(WALL_CLEARANCE, d - WALL_CLEARANCE);
        }
        q
    }

    /// The array's position drawn from `seed`: at 1.1–1.6 m height, at least 1 m (or a quarter of
    /// the room's side, if smaller) from every wall.
    #[must_use]
    pub fn array_position(&self, seed: u64) -> [f64; 3] {
        let mut rng = Rng::new(seed ^ 0x524f_4f4d);
        let margin = |d: f64| (d / 4.0).min(1.0);
        let [l, w, _] = self.dims;
        [
            margin(l) + rng.uniform() * (l - 2.0 * margin(l)),
            margin(w) + rng.uniform() * (w - 2.0 * margin(w)),
            (1.1 + 0.5 * rng.uniform()).min(self.dims[2] - WALL_CLEARANCE),
        ]
    }

    /// Where a source at `azimuth_deg`, `elevation_deg` and `distance_m` from the array at `array`
    /// lies: on that ray, brought closer to the array when the wanted point is not inside the room
    /// (at least the wall clearance from every wall), so that its direction stays the wanted one.
    #[must_use]
    pub fn place(
        &self,
        array: [f64; 3],
        azimuth_deg: f64,
        elevation_deg: f64,
        distance_m: f64,
    ) -> [f64; 3] {
        let (a, e) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
        let dir = [e.cos() * a.cos(), e.cos() * a.sin(), e.sin()];
        // The largest distance along the ray that stays inside the clearance box.
        let mut reach = distance_m;
        for k in 0..3 {
            let (lo, hi) = (WALL_CLEARANCE, self.dims[k] - WALL_CLEARANCE);
            if dir[k] > 1e-12 {
                reach = reach.min((hi - array[k]) / dir[k]);
            } else if dir[k] < -1e-12 {
                reach = reach.min((lo - array[k]) / dir[k]);
            }
        }
        let reach = reach.max(0.0);
        self.clamp([
            array[0] + reach * dir[0],
            array[1] + reach * dir[1],
            array[2] + reach * dir[2],
        ])
    }

    /// First-order response (W, X, Y; SN3D) of `length_s` seconds at `rate` from a source at
    /// `source` to the array at `array`, scaled so the direct sound has unit gain; its direct-sound
    /// azimuth is the geometric one.
    #[must_use]
    pub fn response(
        &self,
        array: [f64; 3],
        source: [f64; 3],
        rate: u32,
        length_s: f64,
    ) -> RoomResponse {
        let fs = rate as f64;
        let len = ((length_s * fs) as usize).max(1);
        let max_r = len as f64 / fs * SPEED_OF_SOUND;
        let beta = self.reflection();
        let direct = dist(array, source).max(0.05);
        let floor = 1e-4 / direct;
        let mut out = [vec![0.0; len], vec![0.0; len], vec![0.0; len]];
        // Image coordinates per axis: (position, reflections) for x = (1 − 2q)s + 2nL.
        let axis = |k: usize| -> Vec<(f64, i32)> {
            let l = self.dims[k];
            let n_max = (max_r / (2.0 * l)).ceil() as i64 + 1;
            let mut v = Vec::new();
            for n in -n_max..=n_max {
                for q in 0..2i64 {
                    let x = (1 - 2 * q) as f64 * source[k] + 2.0 * n as f64 * l;
                    let refl = (n - q).abs() + n.abs();
                    if (x - array[k]).abs() <= max_r {
                        v.push((x - array[k], refl as i32));
                    }
                }
            }
            v
        };
        let (ax, ay, az) = (axis(0), axis(1), axis(2));
        let taps = tap_angles();
        for &(dx, kx) in &ax {
            for &(dy, ky) in &ay {
                let dxy2 = dx * dx + dy * dy;
                if dxy2 > max_r * max_r {
                    continue;
                }
                for &(dz, kz) in &az {
                    let r = (dxy2 + dz * dz).sqrt().max(0.05);
                    if r > max_r {
                        continue;
                    }
                    let gain = beta.powi(kx + ky + kz) / r;
                    if gain < floor {
                        continue;
                    }
                    let t = r / SPEED_OF_SOUND * fs;
                    let (ux, uy) = (dx / r, dy / r);
                    add_fractional(&mut out, t, gain * direct, [1.0, ux, uy], &taps);
                }
            }
        }
        let [w, x, y] = out;
        let d = [
            source[0] - array[0],
            source[1] - array[1],
            source[2] - array[2],
        ];
        RoomResponse::from_parts(w, x, y, d[1].atan2(d[0]).to_degrees())
    }
}

/// Adds one image (delay `t` samples, `gain`, encoding `enc` for W, X, Y) with a Hann-windowed sinc.
///
/// Tap k sits at x = k − frac: its sinc is sin(πx)/(πx) = (−1)^(k+1)·sin(π·frac)/(πx), and its
/// window's cos(πx/(H+1)) follows from the taps' fixed angles (`taps`: sine and cosine of
/// πk/(H+1), k = −H…H, see [`tap_angles`]) by the angle-difference formula, so an image costs
/// three sines and cosines instead of two per tap.
fn add_fractional(out: &mut [Vec<f64>; 3], t: f64, gain: f64, enc: [f64; 3], taps: &TapAngles) {
    let n0 = t.floor() as i64;
    let frac = t - n0 as f64;
    let len = out[0].len() as i64;
    let sin_frac = (PI * frac).sin();
    let step = PI / (HALF_TAPS + 1) as f64;
    let (sin_shift, cos_shift) = (step * frac).sin_cos();
    for k in -HALF_TAPS..=HALF_TAPS {
        let i = n0 + k;
        if i < 0 || i >= len {
            continue;
        }
        let x = k as f64 - frac;
        let sinc = if x.abs() < 1e-12 {
            1.0
        } else if k % 2 == 0 {
            -sin_frac / (PI * x)
        } else {
            sin_frac / (PI * x)
        };
        let (sin_k, cos_k) = taps[(k + HALF_TAPS) as usize];
        let win = 0.5 + 0.5 * (cos_k * cos_shift + sin_k * sin_shift);
        let v = sinc * win * gain;
        for (o, e) in out.iter_mut().zip(enc) {
            o[i as usize] += v * e;
        }
    }
}

/// Sine and cosine of πk/(H+1) for the fractional-delay filter's taps k = −H…H.
type TapAngles = [(f64, f64); 2 * HALF_TAPS as usize + 1];

/// The taps' angles of [`add_fractional`]'s window.
fn tap_angles() -> TapAngles {
    let step = PI / (HALF_TAPS + 1) as f64;
    core::array::from_fn(|i| (step * (i as i64 - HALF_TAPS) as f64).sin_cos())
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fractional-delay taps from the angle identities equal the Hann-windowed sinc computed
    /// tap by tap, at the edges of the response too.
    #[test]
    fn fractional_delay_taps_are_the_windowed_sinc() {
        let taps = tap_angles();
        for t in [0.0, 0.25, 3.5, 7.999, 20.0, 40.3, 58.75, 63.2] {
            let mut out = [vec![0.0; 64], vec![0.0; 64], vec![0.0; 64]];
            add_fractional(&mut out, t, 0.8, [1.0, 0.5, -0.25], &taps);
            let n0 = t.floor() as i64;
            for (i, w) in out[0].iter().enumerate() {
                let x = i as f64 - t;
                let k = i as i64 - n0;
                let want = if k.abs() > HALF_TAPS {
                    0.0
                } else {
                    let sinc = if x.abs() < 1e-12 {
                        1.0
                    } else {
                        (PI * x).sin() / (PI * x)
                    };
                    0.8 * sinc * (0.5 + 0.5 * (PI * x / (HALF_TAPS + 1) as f64).cos())
                };
                assert!((w - want).abs() < 1e-12, "t {t}, sample {i}: {w} vs {want}");
                assert!((out[1][i] - 0.5 * want).abs() < 1e-12);
                assert!((out[2][i] + 0.25 * want).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn parses_and_refuses_rooms() {
        let r = ShoeBox::parse("6x5x3:0.45").unwrap();
        assert_eq!(r.dims, [6.0, 5.0, 3.0]);
        assert!((r.rt60 - 0.45).abs() < 1e-12);
        for bad in ["6x5:0.4", "6x5x3", "6x5x3:nan", "1x5x3:0.4", "6x5x3:0.05"] {
            assert!(ShoeBox::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_direct_sound_comes_first_from_the_source_s_direction() {
        let room = ShoeBox::parse("6x5x3:0.4").unwrap();
        let array = [3.0, 2.5, 1.4];
        let src = room.place(array, 60.0, 0.0, 1.5);
        let h = room.response(array, src, 16000, 0.4);
        assert!((h.direct_deg - 60.0).abs() < 1e-9);
        // The first arrival: at 1.5 m / c, with unit gain and the intensity pointing at 60°.
        let t = (1.5 / SPEED_OF_SOUND * 16000.0).round() as usize;
        let (w, x, y) = h.parts();
        let peak = (0..w.len())
            .max_by(|a, b| w[*a].abs().total_cmp(&w[*b].abs()))
            .unwrap();
        assert!(peak.abs_diff(t) <= 1, "peak at {peak}, expected {t}");
        let (ix, iy): (f64, f64) =
            (t - 3..t + 4).fold((0.0, 0.0), |(a, b), i| (a + w[i] * x[i], b + w[i] * y[i]));
        assert!((iy.atan2(ix).to_degrees() - 60.0).abs() < 1.0);
    }

    /// A place beyond a wall is brought closer along its ray: the direction stays the wanted one.
    #[test]
    fn a_place_beyond_a_wall_keeps_its_direction() {
        let room = ShoeBox::parse("5x4x3:0.4").unwrap();
        let array = [4.2, 1.0, 1.4];
        for (az, el) in [(10.0, 0.0), (-75.0, 20.0), (160.0, -10.0), (45.0, 0.0)] {
            let p = room.place(array, az, el, 3.0);
            let d = [p[0] - array[0], p[1] - array[1], p[2] - array[2]];
            let got_az = d[1].atan2(d[0]).to_degrees();
            let got_el = d[2].atan2(d[0].hypot(d[1])).to_degrees();
            assert!((got_az - az).abs() < 1e-9, "{az}: {got_az}");
            assert!((got_el - el).abs() < 1e-9, "{el}: {got_el}");
            for k in 0..3 {
                assert!(
                    p[k] >= WALL_CLEARANCE - 1e-9 && p[k] <= room.dims[k] - WALL_CLEARANCE + 1e-9
                );
            }
        }
        // Inside the room the wanted distance is kept.
        let p = room.place(array, 180.0, 0.0, 1.5);
        assert!((p[0] - 2.7).abs() < 1e-9 && (p[1] - 1.0).abs() < 1e-9);
    }

    #[test]
    fn a_longer_reverberation_time_keeps_more_energy_late() {
        let late = |rt: f64| {
            let room = ShoeBox {
                dims: [6.0, 5.0, 3.0],
                rt60: rt,
            };
            let array = [3.0, 2.5, 1.4];
            let h = room.response(array, room.place(array, 0.0, 0.0, 1.5), 16000, 0.5);
            let (w, _, _) = h.parts();
            let e = |a: usize, b: usize| w[a..b].iter().map(|v| v * v).sum::<f64>();
            e(1600, 8000) / e(0, 1600)
        };
        assert!(late(0.7) > 2.0 * late(0.3));
    }
}
