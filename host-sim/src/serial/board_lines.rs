//! The lines a board sends for a recording, computed on the host (what `host-sim emit`, a
//! stand-in board, writes to a serial port): one [`cma_core::wire`] frame line per analysis frame,
//! `seq` from 0, the recording's sample rate, no overruns and no drops (the host never falls behind
//! the recording); and, like the firmware, a calibration line (the self-calibration's state) before
//! the first frame line and then every [`CALIBRATION_PERIOD_S`](cma_core::wire::CALIBRATION_PERIOD_S) seconds
//! of the recording ([`CalibrationSchedule`]), after the frame line that made it due. With the
//! multi-talker tracks on, a track line follows every frame line once the tracks' spans are
//! decided: it holds the tracks of the frame `multi_track.span_delay_frames()` frames earlier (its `t`
//! says which; the last frames' tracks are not sent, as a board decides them only when the next
//! frames come). Like the firmware, a background
//! line (the stationary background per band) follows the frame line (and track line) of the
//! estimate after each calibration line: one hop later, so that the two never share a hop.

use crate::error::{Result, SimError};
use crate::io::wav_io::Recording;
use cma_core::capsule_calibration::CapsuleEstimate;
use cma_core::wire::{
    BackgroundLine, CalibrationLine, CalibrationSchedule, Frame, Line, TracksLine,
};
use cma_core::{Locator, LocatorConfig, ReferenceTable};

/// Sample frames per block, as on the boards: a block completes at most one analysis hop, so a
/// calibration line follows the frame line that made it due, as the board sends it (the estimates
/// do not depend on the block size).
pub const BOARD_BLOCK: usize = 32;

/// The lines a board sends for `rec`, in order: frame lines are the core's estimates (in blocks of
/// [`BOARD_BLOCK`] sample frames, as `locate` computes them) through [`Frame::from_estimate`] with
/// `seq` = row index (wrapping), the recording's rate, 0 overruns, 0 drops; calibration lines as
/// the firmware sends them (at start, then every [`cma_core::wire::CALIBRATION_PERIOD_S`] s after the frame
/// line that made one due; their own `seq` from 0, 0 drops). The self-calibration starts from
/// `start` if given (as a board with a stored estimate does).
pub fn lines(
    rec: &Recording,
    config: LocatorConfig,
    table: ReferenceTable<'_>,
    start: Option<&CapsuleEstimate>,
) -> Result<Vec<Line>> {
    // 22.05–96 kHz at the boards' 16 kHz, as `locate` runs them.
    let rec = &*crate::localization::analysis_rate::analysis_recording(rec);
    let mut loc = Locator::new(config, table, rec.rate).map_err(|source| SimError::Core {
        context: "configuration".into(),
        source,
    })?;
    if let Some(start) = start {
        loc.set_capsule_estimate(start);
    }
    let mut out = Vec::with_capacity(rec.frames.len() / 256 + 2);
    let mut schedule = CalibrationSchedule::new(rec.rate);
    let (mut seq, mut calibration_seq) = (0u32, 0u32);
    let mut calibration = |loc: &Locator<'_>, t: u64, out: &mut Vec<Line>| {
        out.push(Line::Calibration(CalibrationLine::from_capsules(
            loc.capsule_estimate(),
            loc.capsule_confidence(),
            calibration_seq,
            t,
            0,
        )));
        calibration_seq = calibration_seq.wrapping_add(1);
    };
    // A background line is due at the next estimate after a calibration line.
    let mut background_due = false;
    let mut background_seq = 0u32;
    let mut background = |loc: &Locator<'_>, t: u64, out: &mut Vec<Line>| {
        out.push(Line::Background(BackgroundLine::from_summary(
            &loc.background_field(),
            background_seq,
            t,
        )));
        background_seq = background_seq.wrapping_add(1);
    };
    if schedule.due(0) {
        calibration(&loc, 0, &mut out);
        background_due = true;
    }
    if config.multi_track.enabled {
        // Sample by sample (the same estimates as in blocks), so the tracks can be read after
        // each estimate.
        let mut tracks_seq = 0u32;
        for x in &rec.frames {
            let Some(e) = loc.process_sample(*x) else {
                continue;
            };
            out.push(Line::Frame(Frame::from_estimate(&e, seq, rec.rate, 0, 0)));
            seq = seq.wrapping_add(1);
            if let Some(f) = loc.talker_tracks() {
                out.push(Line::Tracks(TracksLine::from_tracks(
                    f.tracks(),
                    tracks_seq,
                    loc.centre_sample(f.frame_index),
                )));
                tracks_seq = tracks_seq.wrapping_add(1);
            }
            if std::mem::take(&mut background_due) {
                background(&loc, e.centre_sample, &mut out);
            }
            if schedule.due(e.centre_sample) {
                calibration(&loc, e.centre_sample, &mut out);
                background_due = true;
            }
        }
        return Ok(out);
    }
    for block in rec.frames.chunks(BOARD_BLOCK) {
        let (mut due, mut estimated) = (None, None);
        loc.process_block(block, |e| {
            out.push(Line::Frame(Frame::from_estimate(e, seq, rec.rate, 0, 0)));
            seq = seq.wrapping_add(1);
            if schedule.due(e.centre_sample) {
                due = Some(e.centre_sample);
            }
            estimated = Some(e.centre_sample);
        });
        if let (true, Some(t)) = (background_due, estimated) {
            background(&loc, t, &mut out);
            background_due = false;
        }
        if let Some(t) = due {
            calibration(&loc, t, &mut out);
            background_due = true;
        }
    }
    Ok(out)
}

/// The frame lines of `lines` alone.
#[must_use]
pub fn frames(lines: Vec<Line>) -> Vec<Frame> {
    lines
        .into_iter()
        .filter_map(|l| match l {
            Line::Frame(f) => Some(f),
            Line::Calibration(_) | Line::Tracks(_) | Line::Background(_) => None,
        })
        .collect()
}
