//! Ground-truth tracks (`NAME.pos.csv`: `t_s,azimuth_deg,elevation_deg,distance_m`, each row holding
//! from its `t_s` until the next row; rows less than 0.5 s apart describe a moving talker and are
//! interpolated on the circle).

use crate::error::{Result, SimError};
use std::path::Path;

/// Rows closer than this make a track "moving".
pub const MOVING_ROW_SPACING_S: f64 = 0.5;

/// A truth track.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// (t_s, azimuth_deg) rows, ascending in time.
    pub rows: Vec<(f64, f64)>,
}

/// Wraps degrees to (−180, 180].
#[must_use]
pub fn wrap180(a: f64) -> f64 {
    let mut x = a.rem_euclid(360.0);
    if x > 180.0 {
        x -= 360.0;
    }
    x
}

impl Track {
    /// Parses a `.pos.csv` file.
    pub fn read(path: &Path) -> Result<Self> {
        let text = crate::io::text_file::read(path)?;
        Self::parse(&text).map_err(|(line, reason)| SimError::BadCsv {
            path: path.to_path_buf(),
            line,
            reason,
        })
    }

    /// Parses the text of a `.pos.csv` file; errors carry (line, reason).
    pub fn parse(text: &str) -> std::result::Result<Self, (usize, String)> {
        let mut rows = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || (i == 0 && line.starts_with("t_s")) {
                continue;
            }
            let f: Vec<&str> = line.split(',').map(str::trim).collect();
            if f.len() < 2 {
                return Err((
                    i + 1,
                    format!("expected t_s,azimuth_deg[,elevation_deg,distance_m], got `{line}`"),
                ));
            }
            let num = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite());
            let (Some(t), Some(az)) = (num(f[0]), num(f[1])) else {
                return Err((i + 1, format!("not a number in `{line}`")));
            };
            if let Some(&(prev, _)) = rows.last() {
                if t <= prev {
                    return Err((
                        i + 1,
                        format!("time {t} does not increase (previous row {prev})"),
                    ));
                }
            }
            rows.push((t, az));
        }
        if rows.is_empty() {
            return Err((1, "no rows".into()));
        }
        Ok(Self { rows })
    }

    /// A track with one azimuth for all time.
    #[must_use]
    pub fn fixed(azimuth_deg: f64) -> Self {
        Self {
            rows: vec![(0.0, azimuth_deg)],
        }
    }

    /// `true` for a moving talker (rows closer than [`MOVING_ROW_SPACING_S`]).
    #[must_use]
    pub fn is_moving(&self) -> bool {
        self.rows
            .windows(2)
            .any(|w| w[1].0 - w[0].0 < MOVING_ROW_SPACING_S)
    }

    /// Truth azimuth at `t` (wrapped to (−180, 180]).
    #[must_use]
    pub fn azimuth_at(&self, t: f64) -> f64 {
        let i = self.rows.partition_point(|r| r.0 <= t);
        if i == 0 {
            return wrap180(self.rows[0].1);
        }
        let (t0, a0) = self.rows[i - 1];
        if self.is_moving() && i < self.rows.len() {
            let (t1, a1) = self.rows[i];
            let d = wrap180(a1 - a0);
            return wrap180(a0 + d * (t - t0) / (t1 - t0));
        }
        wrap180(a0)
    }

    /// Times at which a static/jumping track changes azimuth (none for a moving track).
    #[must_use]
    pub fn changes(&self) -> Vec<f64> {
        if self.is_moving() {
            return Vec::new();
        }
        self.rows
            .windows(2)
            .filter(|w| wrap180(w[1].1 - w[0].1).abs() > 1e-9)
            .map(|w| w[1].0)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_and_interpolated_tracks() {
        let t =
            Track::parse("t_s,azimuth_deg,elevation_deg,distance_m\n0,30,0,1.5\n2,-160,0,1.5\n")
                .unwrap();
        assert!(!t.is_moving());
        assert_eq!(t.azimuth_at(1.0), 30.0);
        assert_eq!(t.azimuth_at(2.5), -160.0);
        assert_eq!(t.changes(), vec![2.0]);
        let m = Track::parse("0,170,0,1\n0.05,-178,0,1\n").unwrap();
        assert!(m.is_moving());
        assert!((m.azimuth_at(0.025) - 176.0).abs() < 1e-9);
        assert!(Track::parse("0,abc\n").is_err());
        assert!(Track::parse("1,0\n0.5,3\n").is_err());
        assert!(Track::parse("").is_err());
    }
}
