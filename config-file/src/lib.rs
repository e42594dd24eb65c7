//! # cma-config — the localizer's configuration as a TOML file
//!
//! One file format for every setting of [`LocatorConfig`] (and everything nested in it: features,
//! kernel, tracker, noise gate, frame onset, self-calibration …), read by `host-sim --config FILE`
//! and embedded into the firmware at build time (`CMA_CONFIG=FILE`, see `firmware/build.rs`).
//!
//! - The keys are the field names of the core's configuration types and the values their Rust
//!   spelling: enum variants as strings (`method = "Similarity"`), variants with data as a table
//!   named after the variant (`[tracking.Grid]`, `measure = { Lp = 1.0 }`). The types derive their
//!   serialisation (`cma-core`'s `serde` feature), so a new field is in the file as soon as it is in
//!   the struct. `host-sim config` prints a complete file.
//! - A file may be partial: its keys are laid over a [`Preset`] (precedence: preset < file <
//!   command-line flags, the last in `host-sim`). A file printed by `host-sim config` is complete
//!   and gives the same configuration over any preset ([`to_toml`] and [`parse_over`] round-trip).
//! - Rejected, with the key named ([`ConfigError::key`]): syntax errors, unknown keys, values of the
//!   wrong type, numbers that are not finite (TOML has `nan` and `inf`), values outside the ranges
//!   the core relies on without checking them ([`RANGES`]: the error also gives the value and the
//!   range) and values the core refuses (the core's own check; both in [`validate`]).
//!
//! ```
//! use cma_config::{parse_over, to_toml, Preset};
//! let c = parse_over(&Preset::Default.config(), "num_peaks = 8\n[reliability]\nv_max = 0.004\n")?;
//! assert_eq!((c.peaks.num_peaks, c.reliability.v_max), (8, 0.004));
//! assert_eq!(parse_over(&Preset::Thesis.config(), &to_toml(&c))?, c);
//! assert_eq!(parse_over(&c, "num_peaks = 0").unwrap_err().key(), Some("num_peaks"));
//! # Ok::<(), cma_config::ConfigError>(())
//! ```

mod rust_code;

use cma_core::similarity::SimilarityMeasure;
use cma_core::track_spans::MAX_SPAN_FRAMES;
use cma_core::{Locator, LocatorConfig, ReferenceTable};
use std::fmt;
use toml::{Table, Value};

pub use rust_code::to_rust;

/// A named starting configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Preset {
    /// The product defaults ([`LocatorConfig::default`]): the thesis method plus the measured
    /// improvements.
    Default,
    /// The thesis's published configuration ([`LocatorConfig::thesis`]).
    Thesis,
}

impl Preset {
    /// Every preset, in the order of the documentation.
    pub const ALL: [Preset; 2] = [Preset::Default, Preset::Thesis];

    /// The preset's name on the command line and in messages.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Preset::Default => "default",
            Preset::Thesis => "thesis",
        }
    }

    /// The preset's configuration.
    #[must_use]
    pub fn config(self) -> LocatorConfig {
        match self {
            Preset::Default => LocatorConfig::default(),
            Preset::Thesis => LocatorConfig::thesis(),
        }
    }
}

/// A configuration file that cannot be used: what is wrong and, where one key is to blame, which.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigError {
    key: Option<String>,
    message: String,
}

impl ConfigError {
    fn at(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            key: Some(key.into()),
            message: message.into(),
        }
    }

    /// The dotted key at fault (`tracking.Grid.sharpness`), if one is.
    #[must_use]
    pub fn key(&self) -> Option<&str> {
        self.key.as_deref()
    }

    /// Every key at fault (several when only together they are wrong; none when no key is).
    #[must_use]
    pub fn keys(&self) -> Vec<&str> {
        self.key
            .as_deref()
            .map(|k| k.split("`, `").collect())
            .unwrap_or_default()
    }

    /// What is wrong.
    #[must_use]
    pub fn message(&self) -> &str {
        &self.message
    }
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.key {
            Some(k) => write!(f, "`{k}`: {}", self.message),
            None => f.write_str(&self.message),
        }
    }
}

impl std::error::Error for ConfigError {}

/// The configuration as a complete TOML file, with a header saying what it is.
#[must_use]
pub fn to_toml(config: &LocatorConfig) -> String {
    let table = to_table(config);
    format!(
        "# cma-core localizer configuration: every setting, as `host-sim config` prints it.\n\
         # Use with `host-sim … --config FILE` (flags on the command line override it) or build it\n\
         # into the firmware with `CMA_CONFIG=FILE`. A file may also hold only some keys: the others\n\
         # come from the preset (`--preset`, default `default`).\n\n{table}"
    )
}

/// The configuration as a TOML table.
fn to_table(config: &LocatorConfig) -> Table {
    // Note(expect): every configuration type serialises to plain TOML (no maps with non-string
    // keys, no unit values); the round-trip tests cover every preset.
    let mut t = Table::try_from(config).expect("a LocatorConfig serialises to TOML");
    shortest_f32_text(&mut t);
    t
}

/// TOML numbers are f64: an f32 setting arrives widened (0.999 as 0.9990000128746033). Every float
/// that is exactly an f32 is replaced by the f64 of the f32's shortest decimal text (0.999), when
/// that reads back to the same f32, so the file shows the value as it was written in the code.
fn shortest_f32_text(t: &mut Table) {
    for (_, v) in t.iter_mut() {
        match v {
            Value::Float(x) => {
                let f = *x as f32;
                if f64::from(f) == *x {
                    if let Ok(d) = f.to_string().parse::<f64>() {
                        if d as f32 == f {
                            *x = d;
                        }
                    }
                }
            }
            Value::Table(inner) => shortest_f32_text(inner),
            _ => {}
        }
    }
}

/// Reads a configuration file's text over `base`: the file's keys replace the base's, the rest
/// stays. Rejects unknown keys, wrong types, non-finite numbers and values [`validate`] refuses,
/// naming the key.
pub fn parse_over(base: &LocatorConfig, text: &str) -> Result<LocatorConfig, ConfigError> {
    let file: Table = text.parse().map_err(|e: toml::de::Error| ConfigError {
        key: None,
        message: format!("not a TOML file: {}", e.to_string().trim_end()),
    })?;
    check_finite(&file, "")?;
    let base_table = to_table(base);
    let mut merged = base_table.clone();
    lay_over(&mut merged, file);
    let config: LocatorConfig = serde_path_to_error::deserialize(Value::Table(merged.clone()))
        .map_err(|e| {
            let path = e.path().to_string();
            let message = plain_wording(&e.into_inner().to_string());
            if path == "." || path.is_empty() {
                ConfigError { key: None, message }
            } else {
                ConfigError::at(path, message)
            }
        })?;
    check_ranges(&config)?;
    if let Err(message) = core_check(&config) {
        return Err(blame(&base_table, &merged, message));
    }
    Ok(config)
}

/// The core's check of `config` as [`validate`], naming the keys changed from `base` that make it
/// fail (as [`parse_over`] names a file's keys): for settings made by other means than a file, such
/// as command-line flags laid over a file.
pub fn validate_changes(base: &LocatorConfig, config: &LocatorConfig) -> Result<(), ConfigError> {
    check_ranges(config)?;
    match core_check(config) {
        Ok(()) => Ok(()),
        Err(message) => Err(blame(&to_table(base), &to_table(config), message)),
    }
}

/// The deserializer's message in plain words: `expected usize` becomes `expected a whole number
/// ≥ 0`, `invalid type: string "x", expected f32` becomes `expected a number, got the string "x"`,
/// and the trailing `in `key`` (the key is named already) goes.
fn plain_wording(message: &str) -> String {
    let message = message.lines().next().unwrap_or_default().trim_end();
    let what = |expected: &str| -> String {
        let expected = expected.trim();
        match expected {
            "usize" | "u8" | "u16" | "u32" | "u64" => "a whole number ≥ 0".into(),
            "isize" | "i8" | "i16" | "i32" | "i64" => "a whole number".into(),
            "f32" | "f64" => "a number".into(),
            "struct variant" => "a table of the variant's settings".into(),
            "unit variant" => "a variant name in quotes".into(),
            e => match e.strip_prefix("struct ") {
                Some(_) => "a table of settings".into(),
                None => e.to_string(),
            },
        }
    };
    let got = |found: &str| -> String {
        let found = found.trim();
        for (prefix, name) in [
            ("string ", "the string "),
            ("integer ", ""),
            ("floating point ", ""),
            ("boolean ", ""),
        ] {
            if let Some(v) = found.strip_prefix(prefix) {
                return format!("{name}{}", v.trim_matches('`'));
            }
        }
        match found {
            "map" => "a table".into(),
            "sequence" => "a list".into(),
            "unit variant" => "a variant name without settings".into(),
            f => f.to_string(),
        }
    };
    for prefix in ["invalid type: ", "invalid value: "] {
        if let Some(rest) = message.strip_prefix(prefix) {
            if let Some((found, expected)) = rest.split_once(", expected ") {
                return format!("expected {}, got {}", what(expected), got(found));
            }
        }
    }
    if message.starts_with("wanted exactly 1 element") {
        return "more than one variant given: a setting with variants takes exactly one (write \
                `key = \"Variant\"`, or one `[key.Variant]` table)"
            .into();
    }
    message.to_string()
}

/// The check of a configuration as [`parse_over`] makes it: the ranges of [`RANGES`] (naming the
/// key), then the core's own check as the firmware's localizer will run it (48 kHz input, the ideal
/// reference table), `Err` with the core's message when the localizer would refuse it.
pub fn validate(config: &LocatorConfig) -> Result<(), ConfigError> {
    check_ranges(config)?;
    core_check(config).map_err(|message| ConfigError { key: None, message })
}

/// A setting whose range the core relies on without checking it (its DSP crates have no room left
/// in the firmware's flash for more checks): out of range, the localizer would run and misbehave,
/// so the file is refused here, on the host and in the firmware's build.
#[derive(Debug, Clone, Copy)]
pub struct Range {
    /// The dotted key (`quality.binary_threshold`).
    pub key: &'static str,
    /// The valid values in words, as the error gives them.
    pub valid: &'static str,
    /// The setting's value in a configuration (`None` where the configuration has no such key,
    /// e.g. `measure.Lp` with the Euclidean measure).
    value: fn(&LocatorConfig) -> Option<f64>,
    /// Whether a value is in range.
    accepts: fn(f64) -> bool,
}

/// Smallest and largest p of the L_p measure (`measure = { Lp = p }`). The measure computes
/// (Σ|a − b|^p)^(1/p) in single precision: for p below about 0.02 that overflows to infinity
/// already at equal features (3^(1/p)), the similarity becomes 0 and reads as distance 0, a perfect
/// match at every azimuth (p = 0 does so always); for large p the feature differences below
/// 10^(−38/p) underflow to 0, a perfect match too. Measured on synthetic scenes (`host-sim locate
/// --measure lP`, both presets): from 0.25 to 32 the track is right with a usable reliability; at
/// p = 0.1 the thesis preset's reliability b is 0 in every frame, at p = 64 the per-frame
/// estimates fall apart.
pub const LP_RANGE: (f64, f64) = (0.25, 32.0);

// The span keys' texts below say "0 to 24".
const _: () = assert!(MAX_SPAN_FRAMES == 24);

/// The settings [`parse_over`], [`validate_changes`] and [`validate`] check the range of, beyond
/// the core's own check.
pub const RANGES: &[Range] = &[
    Range {
        key: "measure.Lp",
        valid: "p from 0.25 to 32 (the power of the L_p norm; beyond, its single-precision sum \
                overflows or underflows and azimuths score as perfect matches)",
        value: |c| match c.curves.measure {
            SimilarityMeasure::Lp(p) => Some(f64::from(p)),
            _ => None,
        },
        accepts: |p| (LP_RANGE.0..=LP_RANGE.1).contains(&p),
    },
    Range {
        key: "quality.binary_threshold",
        valid: "at most 1 (a threshold on the reliability b, which is in [0, 1]; 0 or less \
                switches it off)",
        value: |c| Some(f64::from(c.quality.binary_threshold)),
        accepts: |v| v <= 1.0,
    },
    Range {
        key: "clipped_confidence",
        valid: "0 to 1 (the factor on the reliability b of a frame with clipped samples)",
        value: |c| Some(f64::from(c.front_end.clipped_confidence)),
        accepts: |v| (0.0..=1.0).contains(&v),
    },
    Range {
        key: "reliability.exponent",
        valid: "more than 0 (b = clip(K·(V/V_max)^p, 0, 1): p = 0 gives every frame, a silent one \
                too, the same b; p < 0 trusts the worst frames most)",
        value: |c| Some(f64::from(c.reliability.exponent)),
        accepts: |v| v > 0.0,
    },
    Range {
        key: "capsule_calibration.directional_reliability",
        valid: "0 to 1 (a threshold on the reliability b, which is in [0, 1])",
        value: |c| Some(f64::from(c.capsule_calibration.directional_reliability)),
        accepts: |v| (0.0..=1.0).contains(&v),
    },
    Range {
        key: "multi_track.span_gap_frames",
        valid: "0 to 24 (with span_lead_frames at most 24 frames of delay)",
        value: |c| Some(f64::from(c.multi_track.span_gap_frames)),
        accepts: |v| v <= MAX_SPAN_FRAMES as f64,
    },
    Range {
        key: "multi_track.span_lead_frames",
        valid: "0 to 24 (with span_gap_frames at most 24 frames of delay)",
        value: |c| Some(f64::from(c.multi_track.span_lead_frames)),
        accepts: |v| v <= MAX_SPAN_FRAMES as f64,
    },
];

/// Refuses the first setting of `config` outside its range in [`RANGES`], naming the key, the
/// value and the range.
fn check_ranges(config: &LocatorConfig) -> Result<(), ConfigError> {
    for r in RANGES {
        if let Some(v) = (r.value)(config) {
            if !(r.accepts)(v) {
                return Err(ConfigError::at(
                    r.key,
                    format!("{} is out of range; valid: {}", shown(v), r.valid),
                ));
            }
        }
    }
    Ok(())
}

/// A setting's value as the file would write it: an f32 setting by its shortest text (0.3, not
/// 0.30000001192092896), a whole number without a fraction.
fn shown(v: f64) -> String {
    let f = v as f32;
    if f64::from(f) == v {
        f.to_string()
    } else {
        v.to_string()
    }
}

fn core_check(config: &LocatorConfig) -> Result<(), String> {
    Locator::new(*config, ReferenceTable::ideal_5deg(), 48_000)
        .map(drop)
        .map_err(|e| e.to_string())
}

/// The key whose value the core refuses: of the keys where `merged` differs from `base`, the one
/// whose base value makes the configuration acceptable again (several are named when it takes more
/// than one, e.g. a band whose edges cross).
fn blame(base: &Table, merged: &Table, message: String) -> ConfigError {
    let mut changed = Vec::new();
    changed_leaves(base, merged, "", &mut changed);
    let culprits: Vec<&String> = changed
        .iter()
        .filter(|key| {
            let mut t = merged.clone();
            restore(&mut t, base, key);
            Value::Table(t)
                .try_into::<LocatorConfig>()
                .is_ok_and(|c| core_check(&c).is_ok())
        })
        .collect();
    match culprits.as_slice() {
        [] => ConfigError { key: None, message },
        [one] => ConfigError::at((*one).clone(), message),
        many => ConfigError::at(
            many.iter()
                .map(|k| k.as_str())
                .collect::<Vec<_>>()
                .join("`, `"),
            message,
        ),
    }
}

/// Lays `file` over `into`: tables merge key by key, any other value replaces. A table naming
/// another variant than the base's (`[tracking.OnePole]` over `[tracking.Grid]`) replaces it: a
/// setting with variants holds one.
fn lay_over(into: &mut Table, file: Table) {
    for (k, v) in file {
        match (into.get_mut(&k), v) {
            (Some(Value::Table(a)), Value::Table(b)) if !other_variant(a, &b) => lay_over(a, b),
            (_, v) => {
                into.insert(k, v);
            }
        }
    }
}

/// `true` if `a` and `b` are both one variant's table (a single key spelled like a variant,
/// `Grid`) and name different variants.
fn other_variant(a: &Table, b: &Table) -> bool {
    let variant = |t: &Table| match t.keys().collect::<Vec<_>>().as_slice() {
        [k] if k.starts_with(|c: char| c.is_ascii_uppercase()) => Some((*k).clone()),
        _ => None,
    };
    matches!((variant(a), variant(b)), (Some(x), Some(y)) if x != y)
}

/// Dotted keys of the leaves (non-table values, and tables present in only one) where `b` differs
/// from `a`.
fn changed_leaves(a: &Table, b: &Table, prefix: &str, out: &mut Vec<String>) {
    for (k, vb) in b {
        let key = join(prefix, k);
        match (a.get(k), vb) {
            (Some(Value::Table(ta)), Value::Table(tb)) => changed_leaves(ta, tb, &key, out),
            (Some(va), vb) if va == vb => {}
            _ => out.push(key),
        }
    }
}

/// Puts `base`'s value of the dotted `key` back into `t` (removes it where `base` has none).
fn restore(t: &mut Table, base: &Table, key: &str) {
    let mut parts = key.split('.').collect::<Vec<_>>();
    let Some(last) = parts.pop() else { return };
    let (mut t, mut base) = (t, Some(base));
    for p in parts {
        base = base.and_then(|b| b.get(p)).and_then(Value::as_table);
        match t.get_mut(p).and_then(Value::as_table_mut) {
            Some(next) => t = next,
            None => return,
        }
    }
    match base.and_then(|b| b.get(last)) {
        Some(v) => {
            t.insert(last.to_string(), v.clone());
        }
        None => {
            t.remove(last);
        }
    }
}

fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_string()
    } else {
        format!("{prefix}.{key}")
    }
}

/// Rejects NaN and infinities (TOML's `nan`, `inf`), naming the key: no setting takes them.
fn check_finite(t: &Table, prefix: &str) -> Result<(), ConfigError> {
    for (k, v) in t {
        let key = join(prefix, k);
        match v {
            Value::Float(x) if !x.is_finite() => {
                return Err(ConfigError::at(
                    key,
                    format!("expected a finite number, got {x}"),
                ))
            }
            Value::Table(inner) => check_finite(inner, &key)?,
            _ => {}
        }
    }
    Ok(())
}

/// The value of the dotted `key` in `config` as the file writes it (`None` when the configuration
/// has no such key, e.g. a grid-tracker setting of a configuration with the one-pole filter).
#[must_use]
pub fn value_of(config: &LocatorConfig, key: &str) -> Option<String> {
    let table = to_table(config);
    let mut parts = key.split('.');
    let mut v = table.get(parts.next()?)?;
    for p in parts {
        v = v.as_table()?.get(p)?;
    }
    Some(match v {
        Value::String(s) => s.clone(),
        Value::Table(t) if t.len() == 1 => t.keys().next().cloned().unwrap_or_default(),
        other => other.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_round_trips_over_every_preset() {
        for p in Preset::ALL {
            let text = to_toml(&p.config());
            for base in Preset::ALL {
                assert_eq!(
                    parse_over(&base.config(), &text),
                    Ok(p.config()),
                    "{} over {}",
                    p.name(),
                    base.name()
                );
            }
        }
    }

    #[test]
    fn printed_numbers_are_the_fields_values() {
        let text = to_toml(&LocatorConfig::default());
        assert!(text.contains("clip_level = 0.999\n"), "{text}");
        assert!(text.contains("silence_power = 0.0000000001\n"), "{text}");
        assert!(text.contains("v_floor = 0.0004\n"), "{text}");
    }

    #[test]
    fn a_partial_file_changes_only_its_keys() {
        let base = Preset::Thesis.config();
        let c = parse_over(
            &base,
            "band_hi_hz = 3500.0\n[capsule_calibration]\nshrinkage = 2.5\n",
        )
        .unwrap();
        let mut expected = base;
        expected.peaks.band_hi_hz = 3500.0;
        expected.capsule_calibration.shrinkage = 2.5;
        assert_eq!(c, expected);
        let c = parse_over(&base, "tracking = \"OnePole\"\nmeasure = { Lp = 1.0 }").unwrap();
        assert_eq!(
            c.curves.measure,
            cma_core::similarity::SimilarityMeasure::Lp(1.0)
        );
    }

    #[test]
    fn unknown_keys_are_named() {
        let base = Preset::Default.config();
        let e = parse_over(&base, "num_peak = 8").unwrap_err();
        assert_eq!(e.key(), Some("num_peak"), "{e}");
        let e = parse_over(&base, "[tracking.Grid]\nsharpnes = 50.0").unwrap_err();
        assert_eq!(e.key(), Some("tracking.Grid.sharpnes"), "{e}");
        assert!(e.message().contains("unknown field"), "{e}");
        let e = parse_over(&base, "method = \"Magic\"").unwrap_err();
        assert_eq!(e.key(), Some("method"), "{e}");
    }

    #[test]
    fn wrong_types_are_named() {
        let base = Preset::Default.config();
        let e = parse_over(&base, "num_peaks = \"ten\"").unwrap_err();
        assert_eq!(e.key(), Some("num_peaks"), "{e}");
        let e = parse_over(&base, "[frame_onset]\nhistory = -3").unwrap_err();
        assert_eq!(e.key(), Some("frame_onset.history"), "{e}");
        let e = parse_over(&base, "reliability = 3").unwrap_err();
        assert_eq!(e.key(), Some("reliability"), "{e}");
    }

    #[test]
    fn non_finite_numbers_are_named() {
        let base = Preset::Default.config();
        for (text, key) in [
            (
                "[tracking.Grid]\nsharpness = nan",
                "tracking.Grid.sharpness",
            ),
            ("band_hi_hz = inf", "band_hi_hz"),
            (
                "[capsule_calibration]\nshrinkage = -inf",
                "capsule_calibration.shrinkage",
            ),
        ] {
            let e = parse_over(&base, text).unwrap_err();
            assert_eq!(e.key(), Some(key), "{text}: {e}");
            assert!(e.message().contains("finite"), "{e}");
        }
    }

    #[test]
    fn values_the_core_refuses_are_named() {
        let base = Preset::Default.config();
        for (text, key) in [
            ("num_peaks = 0", "num_peaks"),
            (
                "[tracking.Grid]\njump_probability = 2.0",
                "tracking.Grid.jump_probability",
            ),
            (
                "[capsule_calibration]\nmemory_frames = 0.0",
                "capsule_calibration.memory_frames",
            ),
            (
                "[capsule_calibration]\nmax_omni_spread = -1.0",
                "capsule_calibration.max_omni_spread",
            ),
            (
                "[background]\nexcess_directivity = -0.5",
                "background.excess_directivity",
            ),
            ("fdiv_pole = 1.0", "fdiv_pole"),
            ("band_hi_hz = 100.0\nnum_peaks = 8", "band_hi_hz"),
        ] {
            let e = parse_over(&base, text).unwrap_err();
            assert_eq!(e.key(), Some(key), "{text}: {e}");
            assert!(e.message().contains("invalid configuration"), "{e}");
        }
        // Two keys that only together are wrong: both named.
        let e = parse_over(&base, "band_lo_hz = 3000.0\nband_hi_hz = 2000.0").unwrap_err();
        assert_eq!(e.key(), Some("band_lo_hz`, `band_hi_hz"), "{e}");
        assert_eq!(e.keys(), ["band_lo_hz", "band_hi_hz"]);
        let mut c = base;
        c.peaks.band_lo_hz = 5000.0;
        let e = validate_changes(&base, &c).unwrap_err();
        assert_eq!(e.keys(), ["band_lo_hz"], "{e}");
    }

    #[test]
    fn values_outside_the_ranges_the_core_relies_on_are_named_with_value_and_range() {
        // (file text, key, value as the error gives it, words of the range); every key of RANGES.
        let cases = [
            ("measure = { Lp = 0 }", "measure.Lp", "0", "0.25 to 32"),
            ("measure = { Lp = -1.0 }", "measure.Lp", "-1", "0.25 to 32"),
            ("measure = { Lp = 64.0 }", "measure.Lp", "64", "0.25 to 32"),
            (
                "[quality]\nbinary_threshold = 2",
                "quality.binary_threshold",
                "2",
                "at most 1",
            ),
            (
                "clipped_confidence = 1.5",
                "clipped_confidence",
                "1.5",
                "0 to 1",
            ),
            (
                "clipped_confidence = -0.1",
                "clipped_confidence",
                "-0.1",
                "0 to 1",
            ),
            (
                "[reliability]\nexponent = 0.0",
                "reliability.exponent",
                "0",
                "more than 0",
            ),
            (
                "[capsule_calibration]\ndirectional_reliability = 1.2",
                "capsule_calibration.directional_reliability",
                "1.2",
                "0 to 1",
            ),
            (
                "[multi_track]\nenabled = true\nspan_gap_frames = 4294967295\nspan_lead_frames = 1",
                "multi_track.span_gap_frames",
                "4294967295",
                "0 to 24",
            ),
            (
                "[multi_track]\nspan_lead_frames = 25",
                "multi_track.span_lead_frames",
                "25",
                "0 to 24",
            ),
        ];
        for r in RANGES {
            assert!(cases.iter().any(|c| c.1 == r.key), "{} untested", r.key);
        }
        for base in Preset::ALL.map(Preset::config) {
            for (text, key, value, range) in cases {
                let e = parse_over(&base, text).unwrap_err();
                assert_eq!(e.key(), Some(key), "{text}: {e}");
                let said = e.to_string();
                assert!(
                    said.starts_with(&format!("`{key}`: {value} is out of range; valid: "))
                        && said.contains(range),
                    "{text}: {said}"
                );
                // The same check where a configuration is made otherwise (command-line flags).
                let c = toml_config(&base, text);
                assert_eq!(validate_changes(&base, &c).unwrap_err().key(), Some(key));
                assert_eq!(validate(&c).unwrap_err().key(), Some(key));
            }
        }
        // The ends of the ranges are valid.
        let base = Preset::Default.config();
        for text in [
            "measure = { Lp = 0.25 }",
            "measure = { Lp = 32.0 }",
            "[quality]\nbinary_threshold = 1.0",
            "[quality]\nbinary_threshold = -1.0",
            "clipped_confidence = 0.0",
            "[reliability]\nexponent = 0.5",
            "[capsule_calibration]\ndirectional_reliability = 1.0",
        ] {
            assert!(parse_over(&base, text).is_ok(), "{text}");
        }
    }

    /// `text` laid over `base` without any check (as flags could set it).
    fn toml_config(base: &LocatorConfig, text: &str) -> LocatorConfig {
        let mut t = to_table(base);
        lay_over(&mut t, text.parse().unwrap());
        Value::Table(t).try_into().unwrap()
    }

    #[test]
    fn type_errors_are_in_plain_words() {
        let base = Preset::Default.config();
        for (text, key, says) in [
            (
                "num_peaks = \"ten\"",
                "num_peaks",
                "expected a whole number ≥ 0, got the string \"ten\"",
            ),
            (
                "num_peaks = -1",
                "num_peaks",
                "expected a whole number ≥ 0, got -1",
            ),
            (
                "[reliability]\nspeed = \"x\"",
                "reliability.speed",
                "expected a number, got the string \"x\"",
            ),
            (
                "reliability = 3",
                "reliability",
                "expected a table of settings, got 3",
            ),
        ] {
            let e = parse_over(&base, text).unwrap_err();
            assert_eq!(e.key(), Some(key), "{text}: {e}");
            assert_eq!(e.message(), says, "{text}");
        }
    }

    #[test]
    fn a_variant_table_replaces_the_base_variant() {
        let base = Preset::Default.config();
        let c = parse_over(&base, "[tracking.OnePole]").unwrap();
        assert_eq!(c.tracking, cma_core::config::Tracking::OnePole);
        let e = parse_over(
            &base,
            "[tracking.Grid]\nsharpness = 3.0\n[tracking.OnePole]",
        )
        .unwrap_err();
        assert!(!e.message().contains("wanted exactly"), "{e}");
    }

    #[test]
    fn syntax_errors_say_where() {
        let e = parse_over(&Preset::Default.config(), "num_peaks = = 3").unwrap_err();
        assert!(e.message().contains("line 1"), "{e}");
    }

    #[test]
    fn values_print_as_the_file_writes_them() {
        let d = Preset::Default.config();
        assert_eq!(value_of(&d, "num_peaks").as_deref(), Some("16"));
        assert_eq!(value_of(&d, "tracking").as_deref(), Some("Grid"));
        assert_eq!(value_of(&d, "features").as_deref(), Some("Active"));
        assert_eq!(
            value_of(&d, "tracking.Grid.sharpness").as_deref(),
            Some("60.0")
        );
        let t = Preset::Thesis.config();
        assert_eq!(value_of(&t, "tracking").as_deref(), Some("OnePole"));
        assert_eq!(value_of(&t, "tracking.Grid.sharpness"), None);
    }
}
