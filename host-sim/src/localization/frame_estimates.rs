//! The core's estimates of a recording, one per analysis frame: the core run over it block by block
//! as the firmware does (what `host-sim locate` computes), and the estimate CSV it writes and
//! `eval`/`score` read.

use crate::error::{Result, SimError};
use crate::io::fixed_decimal::write_fixed;
use crate::io::wav_io::{Recording, RecordingStream};
use crate::localization::analysis_rate::{core_rate, RateConverter};
use cma_core::background_field::{BackgroundBand, BG_BANDS};
use cma_core::capsule_calibration::CapsuleEstimate;
use cma_core::{Estimate, Locator, LocatorConfig, ReferenceTable};
use std::io::Write;

/// Input sample frames per block handed to the core: one hop at 48 kHz, what the firmware's DMA
/// half-buffer delivers.
pub const BLOCK: usize = 1024;

// Streamed chunks hold whole blocks, so streaming feeds the core exactly the blocks of `locate`.
const _: () =
    assert!(crate::io::wav_io::CHUNK_FRAMES / BLOCK * BLOCK == crate::io::wav_io::CHUNK_FRAMES);

/// One analysis frame's result with its time in seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Time of the frame centre, s.
    pub t_s: f64,
    /// The core's estimate.
    pub estimate: Estimate,
}

/// Runs the localizer over a whole recording; `progress` is called with the number of sample frames
/// consumed after each block.
pub fn locate(
    rec: &Recording,
    config: LocatorConfig,
    table: ReferenceTable<'_>,
    progress: impl FnMut(usize),
) -> Result<Vec<Row>> {
    let mut run = Run::new(config, table, rec.rate, rec.frames.len() / 256 + 1)?;
    run.feed(&rec.frames, progress);
    Ok(run.rows)
}

/// Runs the localizer over a recording read chunk by chunk (memory O(chunk), not O(file)), with the
/// same blocks and so the same rows as [`locate`] on the whole recording. Truncated or corrupt data is
/// an error (after the frames before it were processed); `progress` as in [`locate`].
pub fn locate_stream(
    stream: &mut RecordingStream,
    config: LocatorConfig,
    table: ReferenceTable<'_>,
    progress: impl FnMut(usize),
) -> Result<Vec<Row>> {
    Ok(locate_stream_calibrated(stream, config, table, None, progress)?.rows)
}

/// What [`locate_stream_calibrated`] returns: the rows and the self-calibration at the end.
#[derive(Debug, Clone)]
pub struct Located {
    /// One row per analysis frame.
    pub rows: Vec<Row>,
    /// The self-calibration's estimate after the last frame.
    pub capsules: CapsuleEstimate,
    /// Its confidence in [0, 1] (0 when the stage is off).
    pub capsule_confidence: f32,
    /// The share of the omni parts' correction the talker's sound supports (1 when the stage is
    /// off or the speech check has not withdrawn any).
    pub capsule_omni_scale: f32,
    /// The stationary background per band after the last frame
    /// ([`Locator::background_field`]; `None` for a band without evidence).
    pub background: [Option<BackgroundBand>; BG_BANDS],
}

/// [`locate_stream`] with the self-calibration starting from `start` (ideal when `None`),
/// returning its final estimate too.
pub fn locate_stream_calibrated(
    stream: &mut RecordingStream,
    config: LocatorConfig,
    table: ReferenceTable<'_>,
    start: Option<&CapsuleEstimate>,
    mut progress: impl FnMut(usize),
) -> Result<Located> {
    let mut run = Run::new(
        config,
        table,
        stream.rate(),
        stream.capacity_frames() / 256 + 1,
    )?;
    if let Some(start) = start {
        run.loc.set_capsule_estimate(start);
    }
    loop {
        let chunk = stream.next_chunk()?;
        if chunk.is_empty() {
            return Ok(Located {
                capsules: *run.loc.capsule_estimate(),
                capsule_confidence: run.loc.capsule_confidence(),
                capsule_omni_scale: run.loc.capsule_state().omni_scale(),
                background: run.loc.background_field(),
                rows: run.rows,
            });
        }
        run.feed(chunk, &mut progress);
    }
}

/// A localizer and the rows it has emitted.
struct Run<'t> {
    loc: Locator<'t>,
    /// The core's input rate ([`core_rate`] of the recording's).
    rate: u32,
    /// Brings 22.05–96 kHz to 16 kHz before the core (see [`RateConverter`]).
    convert: Option<RateConverter>,
    converted: Vec<[f32; 4]>,
    rows: Vec<Row>,
}

impl<'t> Run<'t> {
    fn new(
        config: LocatorConfig,
        table: ReferenceTable<'t>,
        rate: u32,
        rows: usize,
    ) -> Result<Self> {
        let convert = RateConverter::for_rate(rate);
        let rate = core_rate(rate);
        let loc = Locator::new(config, table, rate).map_err(|source| SimError::Core {
            context: "configuration".into(),
            source,
        })?;
        Ok(Self {
            loc,
            rate,
            convert,
            converted: Vec::new(),
            rows: Vec::with_capacity(rows),
        })
    }

    /// Feeds frames in blocks of [`BLOCK`] (`frames` starts on a block boundary: every chunk but the
    /// last is a multiple of [`BLOCK`]); at 22.05–96 kHz each block is converted to
    /// 16 kHz first. `progress` counts the recording's frames.
    fn feed(&mut self, frames: &[[f32; 4]], mut progress: impl FnMut(usize)) {
        let rate = self.rate;
        for input in frames.chunks(BLOCK) {
            let block = match &mut self.convert {
                Some(conv) => {
                    self.converted.clear();
                    conv.process(input, &mut self.converted);
                    &self.converted[..]
                }
                None => input,
            };
            let rows = &mut self.rows;
            self.loc.process_block(block, |e| {
                rows.push(Row {
                    t_s: e.time_s(rate),
                    estimate: *e,
                })
            });
            progress(input.len());
        }
    }
}

/// Median of the rows' `power_db` (10·log10 of the frame's mean-square omni power, as in the
/// CSV), `None` without rows.
#[must_use]
pub fn median_power_db(rows: &[Row]) -> Option<f64> {
    let mut db: Vec<f64> = rows
        .iter()
        .map(|r| 10.0 * f64::from(r.estimate.power.max(1e-30)).log10())
        .collect();
    db.sort_by(f64::total_cmp);
    db.get(db.len() / 2).copied()
}

/// The stationary background's summary line of `locate` for the bands of `background` (their
/// names by [`crate::serial::monitor::background_band_name`]), levels in dB re full-scale mean
/// square (dBFS) and, with `reference_db`, also relative to it (the median frame `power_db`):
/// a band whose directivity is above
/// [`DIRECTIONAL_MIN`](cma_core::background_field::DIRECTIONAL_MIN) as a source, the others as
/// diffuse. E.g. `stationary background: <1 kHz source at 31° (directivity 0.45), -48.2 dBFS,
/// -14.1 dB re the median frame power; ≥1 kHz diffuse (directivity 0.12), …`.
#[must_use]
pub fn background_summary(
    background: &[Option<BackgroundBand>; BG_BANDS],
    reference_db: Option<f64>,
) -> String {
    let bands: Vec<String> = background
        .iter()
        .enumerate()
        .map(|(k, b)| {
            let name = crate::serial::monitor::background_band_name(k);
            let Some(b) = b else {
                return format!("{name} no background frame yet");
            };
            let what = if b.is_directional() {
                format!(
                    "source at {:.0}° (directivity {:.2})",
                    b.direction_deg, b.directivity
                )
            } else {
                format!("diffuse (directivity {:.2})", b.directivity)
            };
            let level = f64::from(b.level_db);
            let relative = reference_db.map_or_else(String::new, |r| {
                format!(", {:+.1} dB re the median frame power", level - r)
            });
            format!("{name} {what}, {level:.1} dBFS{relative}")
        })
        .collect();
    format!("stationary background: {}", bands.join("; "))
}

/// CSV header of [`write_csv`].
pub const CSV_HEADER: &str = "frame,t_s,azimuth_deg,azimuth_raw_deg,confidence,power_db,flags";

/// Writes rows as CSV (header [`CSV_HEADER`]).
pub fn write_csv(mut out: impl Write, rows: &[Row]) -> std::io::Result<()> {
    writeln!(out, "{CSV_HEADER}")?;
    for r in rows {
        let e = &r.estimate;
        let db = 10.0 * (e.power.max(1e-30) as f64).log10();
        // "{},{:.6},{:.2},{:.2},{:.4},{:.1},{}" without the general float formatter.
        write!(out, "{},", e.frame_index)?;
        write_fixed(&mut out, r.t_s, 6)?;
        out.write_all(b",")?;
        write_fixed(&mut out, f64::from(e.azimuth_deg), 2)?;
        out.write_all(b",")?;
        write_fixed(&mut out, f64::from(e.azimuth_raw_deg), 2)?;
        out.write_all(b",")?;
        write_fixed(&mut out, f64::from(e.confidence), 4)?;
        out.write_all(b",")?;
        write_fixed(&mut out, db, 1)?;
        writeln!(out, ",{}", e.flags.0)?;
    }
    out.flush()
}

/// A row of an estimate CSV as read back (from `locate --csv` or `monitor --record`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CsvEstimate {
    /// Frame time, s.
    pub t_s: f64,
    /// Azimuth, degrees.
    pub azimuth_deg: f64,
    /// Unweighted azimuth, degrees.
    pub azimuth_raw_deg: f64,
    /// Confidence.
    pub confidence: f64,
}

/// Reads an estimate CSV with at least the columns `t_s,azimuth_deg,azimuth_raw_deg,confidence`.
pub fn read_csv(path: &std::path::Path) -> Result<Vec<CsvEstimate>> {
    let text = crate::io::text_file::read(path)?;
    let bad = |line: usize, reason: String| SimError::BadCsv {
        path: path.to_path_buf(),
        line,
        reason,
    };
    let mut lines = text.lines().enumerate();
    let (_, header) = lines
        .next()
        .ok_or_else(|| bad(1, "empty file, expected a header".into()))?;
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let col = |name: &str| {
        cols.iter()
            .position(|c| *c == name)
            .ok_or_else(|| bad(1, format!("missing column `{name}` in header `{header}`")))
    };
    let (it, ia, ir, ic) = (
        col("t_s")?,
        col("azimuth_deg")?,
        col("azimuth_raw_deg")?,
        col("confidence")?,
    );
    let mut out = Vec::new();
    for (i, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != cols.len() {
            return Err(bad(
                i + 1,
                format!("expected {} fields, got {}", cols.len(), f.len()),
            ));
        }
        let num = |j: usize| {
            f[j].trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(i + 1, format!("`{}` is not a number", f[j])))
                .and_then(|v| {
                    // Azimuths and confidence are single precision in the core.
                    if j != it && v.abs() > f64::from(f32::MAX) {
                        Err(bad(i + 1, format!("`{}` is outside the f32 range", f[j])))
                    } else {
                        Ok(v)
                    }
                })
        };
        out.push(CsvEstimate {
            t_s: num(it)?,
            azimuth_deg: num(ia)?,
            azimuth_raw_deg: num(ir)?,
            confidence: num(ic)?,
        });
    }
    Ok(out)
}
