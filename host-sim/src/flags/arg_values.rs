//! Value parsers for numeric flags: a value that parses but cannot mean anything (NaN, an hour-long
//! lead-in, more threads than any machine has) is a usage error naming its range, reported by clap
//! like any other bad value.

/// Most worker threads accepted by `--threads`.
pub const MAX_THREADS: usize = 1024;

/// Longest synthetic talker of `scene --synth`, s (a 48 kHz scene of this length takes a few GB).
pub const MAX_SYNTH_S: f64 = 3600.0;

/// Longest `scene --lead-in`, s.
pub const MAX_LEAD_IN_S: f64 = 600.0;

/// Longest `scene --rir-length`, s.
pub const MAX_RIR_S: f64 = 10.0;

/// Largest level or SNR accepted, in magnitude, dB.
pub const MAX_DB: f64 = 200.0;

/// Largest angle or angular speed accepted, in magnitude (degrees or degrees per second).
pub const MAX_DEG: f64 = 1e6;

/// Longest time flag (`--exit-after-idle`, `score --from/--to`), s: about 11.6 days.
pub const MAX_TIME_S: f64 = 1e6;

/// Parses a finite number within `[lo, hi]` (`lo` excluded if `lo_open`).
fn number_in(s: &str, lo: f64, hi: f64, lo_open: bool) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number"))?;
    let above = if lo_open { v > lo } else { v >= lo };
    if !(v.is_finite() && above && v <= hi) {
        let open = if lo_open { "(" } else { "[" };
        return Err(format!("{v} is outside {open}{lo}, {hi}]"));
    }
    Ok(v)
}

/// A worker-thread count, 1 to [`MAX_THREADS`].
pub fn threads(s: &str) -> Result<usize, String> {
    let n: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number"))?;
    if !(1..=MAX_THREADS).contains(&n) {
        return Err(format!("{n} is outside 1 to {MAX_THREADS}"));
    }
    Ok(n)
}

/// An azimuth or angular speed: finite, at most [`MAX_DEG`] in magnitude.
pub fn degrees(s: &str) -> Result<f64, String> {
    number_in(s, -MAX_DEG, MAX_DEG, false)
}

/// A level or SNR: finite, at most [`MAX_DB`] in magnitude.
pub fn decibels(s: &str) -> Result<f64, String> {
    number_in(s, -MAX_DB, MAX_DB, false)
}

/// A synthetic talker's duration: more than 0, at most [`MAX_SYNTH_S`].
pub fn synth_seconds(s: &str) -> Result<f64, String> {
    number_in(s, 0.0, MAX_SYNTH_S, true)
}

/// A lead-in: 0 to [`MAX_LEAD_IN_S`].
pub fn lead_in_seconds(s: &str) -> Result<f64, String> {
    number_in(s, 0.0, MAX_LEAD_IN_S, false)
}

/// A time within a scene: 0 to [`MAX_TIME_S`].
pub fn scene_time(s: &str) -> Result<f64, String> {
    number_in(s, 0.0, MAX_TIME_S, false)
}

/// A room-response length: more than 0, at most [`MAX_RIR_S`].
pub fn rir_seconds(s: &str) -> Result<f64, String> {
    number_in(s, 0.0, MAX_RIR_S, true)
}

/// A talker's distance in a room: 0.3 to 20 m.
pub fn talker_distance(s: &str) -> Result<f64, String> {
    number_in(s, 0.3, 20.0, false)
}

/// A waiting time: more than 0, at most [`MAX_TIME_S`].
pub fn positive_seconds(s: &str) -> Result<f64, String> {
    number_in(s, 0.0, MAX_TIME_S, true)
}

/// A time on a recording's axis: finite, at most [`MAX_TIME_S`] in magnitude.
pub fn time_seconds(s: &str) -> Result<f64, String> {
    number_in(s, -MAX_TIME_S, MAX_TIME_S, false)
}

/// Parses a single-precision number that `ok` accepts; else the message says it must be `rule`.
fn setting(s: &str, rule: &str, ok: impl Fn(f32) -> bool) -> Result<f32, String> {
    let v: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number; must be {rule}"))?;
    if v.is_finite() && ok(v) {
        Ok(v)
    } else {
        Err(format!("must be {rule}, got {v}"))
    }
}

/// A configuration setting: any finite number.
pub fn finite(s: &str) -> Result<f32, String> {
    setting(s, "a finite number", |_| true)
}

/// A configuration setting: a finite number ≥ 0.
pub fn non_negative(s: &str) -> Result<f32, String> {
    setting(s, "a finite number ≥ 0", |v| v >= 0.0)
}

/// A configuration setting: a finite number > 0.
pub fn positive(s: &str) -> Result<f32, String> {
    setting(s, "a finite number > 0", |v| v > 0.0)
}

/// A configuration setting in [0, 1]: a probability, floor or gain.
pub fn unit(s: &str) -> Result<f32, String> {
    setting(s, "a number in [0, 1]", |v| (0.0..=1.0).contains(&v))
}

/// A smoothing pole: in [0, 1).
pub fn pole(s: &str) -> Result<f32, String> {
    setting(s, "a number in [0, 1)", |v| (0.0..1.0).contains(&v))
}

/// The number of spectral peaks: 1 to [`cma_core::MAX_PEAKS`].
pub fn peaks(s: &str) -> Result<usize, String> {
    let max = cma_core::MAX_PEAKS;
    match s.trim().parse::<usize>() {
        Ok(n) if (1..=max).contains(&n) => Ok(n),
        _ => Err(format!("must be a whole number from 1 to {max}, got `{s}`")),
    }
}

/// The frame onset's power history: 1 to 8 frames.
pub fn onset_history(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(n) if (1..=8).contains(&n) => Ok(n),
        _ => Err(format!("must be a whole number from 1 to 8, got `{s}`")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absurd_values_are_refused_with_their_range() {
        assert_eq!(threads("8"), Ok(8));
        assert!(threads("18446744073709551615")
            .unwrap_err()
            .contains("outside 1 to 1024"));
        assert!(threads("0").is_err());
        assert!(threads("-1").is_err());
        assert_eq!(degrees("-160"), Ok(-160.0));
        assert!(degrees("NaN").unwrap_err().contains("outside"));
        assert!(degrees("inf").is_err());
        assert!(decibels("nan").is_err());
        assert_eq!(decibels("-30"), Ok(-30.0));
        assert!(synth_seconds("1e9")
            .unwrap_err()
            .contains("outside (0, 3600]"));
        assert!(synth_seconds("0").is_err());
        assert_eq!(lead_in_seconds("0"), Ok(0.0));
        assert!(lead_in_seconds("-0.1").is_err());
        assert!(rir_seconds("0").is_err());
        assert!(positive_seconds("-1").is_err());
        assert!(time_seconds("x").unwrap_err().contains("not a number"));
    }

    #[test]
    fn configuration_settings_name_their_one_rule() {
        assert_eq!(
            finite("nan"),
            Err("must be a finite number, got NaN".into())
        );
        assert_eq!(finite("-3.5"), Ok(-3.5));
        assert_eq!(
            non_negative("-5"),
            Err("must be a finite number ≥ 0, got -5".into())
        );
        assert_eq!(
            positive("0").unwrap_err(),
            "must be a finite number > 0, got 0"
        );
        assert_eq!(
            unit("1.5").unwrap_err(),
            "must be a number in [0, 1], got 1.5"
        );
        assert_eq!(pole("1"), Err("must be a number in [0, 1), got 1".into()));
        assert_eq!(
            peaks("0"),
            Err("must be a whole number from 1 to 32, got `0`".into())
        );
        assert_eq!(peaks("32"), Ok(32));
        assert!(onset_history("9").is_err());
        assert!(finite("x").unwrap_err().contains("not a number"));
    }
}
