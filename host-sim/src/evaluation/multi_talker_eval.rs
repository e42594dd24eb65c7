//! Multi-talker tracks on the host: `locate --tracks OUT.csv` (one row per reported track per
//! frame) and `eval` of a folder of multi-talker scenes (`scene --talkers`), scored with
//! association-based metrics in the style of DCASE and LOCATA (with `--plots DIR`, one PNG per
//! scene of its tracks against its talkers' truth).
//!
//! # Scoring
//! Per analysis frame, the reported *active* tracks are matched one to one to the *speaking*
//! talkers within [`TOLERANCE_DEG`] (the matching with the most pairs, then the least total error).
//! A talker's frames within [`COLLAR_S`] of the start or end of one of its utterances are not
//! scored (the forgiveness collar of speaker diarization): a match to such a talker is neither a
//! hit nor a false alarm, and no match is not a miss. Then
//! - **recall**: matched speaking talker-frames / scored speaking talker-frames;
//! - **precision**: matched active track-frames / active track-frames (not counting those matched
//!   to a talker inside its collar);
//! - **mean error**: mean absolute azimuth error of the matches, degrees;
//! - **ID switches per minute**: per talker, a switch whenever its match carries another ID than its
//!   previous match; summed over talkers, per minute of recording;
//! - **ID purity**: per track ID, the share of its matched frames on the talker it is matched to
//!   most; pooled over IDs (Σ most / Σ all) and the worst ID with at least one second of matches.
//!
//! # Utterance spans
//! A camera or a transcript needs a talker's track active for his whole utterance, the short pauses
//! between words included, and not long after it. The *span* metrics score that: a talker speaks
//! from the start to the end of each of his utterances (the truth's `speaking` runs, runs less
//! than [`SPAN_MERGE_S`] apart joined into one utterance), and only the frames within
//! [`SPAN_COLLAR_S`] of an utterance's start or end are not scored. The matching is the same.
//! - **span recall**: matched / scored talker-frames inside utterances;
//! - **span precision**: matched / active track-frames (not counting those matched to a talker
//!   inside its collar);
//! - **located**: share of the scored talker-frames with a live track (active or not) within
//!   [`TOLERANCE_DEG`] of the talker: what a smarter activity decision could reach.
//!
//! The truth files of `host-sim scene --talkers` already mark whole utterances (first to last
//! sample of the utterance above −30 dB of its loudest 10 ms), so the spans are their `speaking`
//! runs; the span metrics differ from recall and precision by the narrower collar, which scores
//! the onset and the hangover of every track too.

use crate::error::{Result, SimError};
use crate::io::wav_io::{read_recording, InputLayout, Recording};
use crate::simulation::multi_talker_scene::{truth_path, MANIFEST_HEADER};
use cma_core::multi_track::TalkerTrack;
use cma_core::{Locator, LocatorConfig, ReferenceTable};
use serde::Serialize;
use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Largest azimuth error of a match, degrees.
pub const TOLERANCE_DEG: f64 = 20.0;
/// Frames this close to a talker's utterance start or end are not scored for that talker, s.
pub const COLLAR_S: f64 = 0.25;
/// Frames this close to the start or end of a talker's utterance span are not scored by the span
/// metrics, s.
pub const SPAN_COLLAR_S: f64 = 0.1;
/// Speaking runs of one talker less than this apart are one utterance for the span metrics, s.
pub const SPAN_MERGE_S: f64 = 0.5;

/// `host-sim eval --help` on a multi-talker folder's columns.
pub const COLUMNS_HELP: &str = "\
On a multi-talker folder (scene --talkers), per frame the active tracks are matched one to one to
the speaking talkers within 20° (most pairs, then least error):
  recall       matched / speaking talker-frames, not counting frames within 0.25 s of an
               utterance's start or end
  precision    matched / active track-frames (not counting matches inside that collar)
  error °      mean absolute azimuth error of the matches
  switch/min   a talker matched by another ID than before, per minute
  ID purity    share of each ID's matched frames on its main talker (worst: the worst ID)
  span recall, span precision
               the same over whole utterance spans (speaking runs less than 0.5 s apart joined),
               only frames within 0.1 s of a span's start or end not scored: the track must be
               active through the pauses inside an utterance and end with it
  located      share of those span talker-frames with a live track (active or not) within 20°
  noise        frames with an active track on a directional noise source (NAME.noise.csv)
               matched to no talker, %";

/// The tracks the core reports after one analysis frame.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackFrame {
    /// Time of the frame centre, s.
    pub t_s: f64,
    /// Live tracks (active or not).
    pub tracks: Vec<TalkerTrack>,
}

/// `config` with the multi-talker stage on, its other settings (a configuration file's) unchanged.
#[must_use]
pub fn with_tracks(mut config: LocatorConfig) -> LocatorConfig {
    config.multi_track.enabled = true;
    config
}

/// Runs the localizer (with the multi-talker stage on) over a recording and returns the tracks of
/// every analysis frame.
pub fn track_frames(
    rec: &Recording,
    config: LocatorConfig,
    table: ReferenceTable<'_>,
) -> Result<Vec<TrackFrame>> {
    // 22.05–96 kHz at the boards' 16 kHz, as `locate` runs them.
    let rec = &*crate::localization::analysis_rate::analysis_recording(rec);
    let mut loc =
        Locator::new(with_tracks(config), table, rec.rate).map_err(|source| SimError::Core {
            context: "configuration".into(),
            source,
        })?;
    let mut out = Vec::with_capacity(rec.frames.len() / 256 + 1);
    let take = |loc: &Locator<'_>, f: cma_core::track_spans::TrackFrame| TrackFrame {
        t_s: loc.centre_sample(f.frame_index) as f64 / f64::from(rec.rate),
        tracks: f.tracks().collect(),
    };
    for x in &rec.frames {
        if loc.process_sample(*x).is_some() {
            if let Some(f) = loc.talker_tracks() {
                out.push(take(&loc, f));
            }
        }
    }
    while let Some(f) = loc.flush_talker_tracks() {
        out.push(take(&loc, f));
    }
    Ok(out)
}

/// CSV header of [`write_tracks_csv`].
pub const TRACKS_HEADER: &str = "t_s,track_id,azimuth_deg,confidence,active";

/// Writes one row per reported track per frame (header [`TRACKS_HEADER`]; `active` is 1 when the
/// talker speaks in that frame).
pub fn write_tracks_csv(mut out: impl Write, frames: &[TrackFrame]) -> std::io::Result<()> {
    writeln!(out, "{TRACKS_HEADER}")?;
    for f in frames {
        for t in &f.tracks {
            writeln!(
                out,
                "{:.4},{},{:.2},{:.3},{}",
                f.t_s,
                t.id,
                t.azimuth_deg,
                t.confidence,
                u8::from(t.active)
            )?;
        }
    }
    Ok(())
}

/// `locate --tracks PATH`: runs the stage over `input` and writes the tracks CSV.
pub fn write_tracks_file(
    input: &Path,
    layout: InputLayout,
    config: LocatorConfig,
    table: ReferenceTable<'_>,
    path: &Path,
) -> Result<usize> {
    let rec = read_recording(input, layout)?;
    let frames = track_frames(&rec, config, table)?;
    crate::io::wav_io::write_atomically(path, |tmp| {
        let f = std::fs::File::create(tmp).map_err(|e| SimError::io(tmp, e))?;
        let mut w = std::io::BufWriter::new(f);
        write_tracks_csv(&mut w, &frames)
            .and_then(|()| w.flush())
            .map_err(|e| SimError::io(tmp, e))
    })?;
    Ok(frames.len())
}

/// One talker's truth (`NAME.talkerK.csv`).
#[derive(Debug, Clone, PartialEq)]
pub struct TalkerTruth {
    /// Rows (t_s, azimuth °, speaking), each holding until the next.
    pub rows: Vec<(f64, f64, bool)>,
}

impl TalkerTruth {
    /// Parses the CSV text; errors carry the 1-based line and the reason.
    pub fn parse(text: &str) -> std::result::Result<Self, (usize, String)> {
        let mut lines = text.lines().enumerate();
        match lines.next() {
            Some((_, h)) if h.trim() == "t_s,azimuth_deg,speaking" => {}
            _ => return Err((1, "expected the header t_s,azimuth_deg,speaking".into())),
        }
        let mut rows: Vec<(f64, f64, bool)> = Vec::new();
        for (i, line) in lines {
            if line.trim().is_empty() {
                continue;
            }
            let f: Vec<&str> = line.split(',').map(str::trim).collect();
            let num = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite());
            let (Some(t), Some(a), Some(on)) = (
                f.first().and_then(|s| num(s)),
                f.get(1).and_then(|s| num(s)),
                f.get(2).and_then(|s| match *s {
                    "0" => Some(false),
                    "1" => Some(true),
                    _ => None,
                }),
            ) else {
                return Err((i + 1, format!("expected t_s,azimuth_deg,0|1, got `{line}`")));
            };
            if rows.last().is_some_and(|r| t <= r.0) {
                return Err((i + 1, "times must increase".into()));
            }
            rows.push((t, a, on));
        }
        if rows.is_empty() {
            return Err((2, "no rows".into()));
        }
        Ok(Self { rows })
    }

    /// Reads a truth file.
    pub fn read(path: &Path) -> Result<Self> {
        let text = crate::io::text_file::read(path)?;
        Self::parse(&text).map_err(|(line, reason)| SimError::BadCsv {
            path: path.to_path_buf(),
            line,
            reason,
        })
    }

    fn index(&self, t: f64) -> usize {
        self.rows.partition_point(|r| r.0 <= t).saturating_sub(1)
    }

    /// Whether the talker speaks at `t`.
    #[must_use]
    pub fn speaking_at(&self, t: f64) -> bool {
        self.rows[self.index(t)].2
    }

    /// Azimuth at `t`, interpolated on the circle between rows less than 0.5 s apart (a moving
    /// talker), held otherwise.
    #[must_use]
    pub fn azimuth_at(&self, t: f64) -> f64 {
        let i = self.index(t);
        let (t0, a0, _) = self.rows[i];
        match self.rows.get(i + 1) {
            Some(&(t1, a1, _)) if t1 - t0 < 0.5 && t >= t0 => {
                let d = crate::io::ground_truth::wrap180(a1 - a0);
                crate::io::ground_truth::wrap180(a0 + d * (t - t0) / (t1 - t0))
            }
            _ => a0,
        }
    }

    /// The talker's utterances (start, end) in s: the runs of `speaking` rows, runs less than
    /// `merge` s apart joined; an utterance that lasts to the last row ends at infinity.
    #[must_use]
    pub fn utterances(&self, merge: f64) -> Vec<(f64, f64)> {
        let mut out: Vec<(f64, f64)> = Vec::new();
        let mut start: Option<f64> = None;
        for r in &self.rows {
            match (start, r.2) {
                (None, true) => start = Some(r.0),
                (Some(a), false) => {
                    match out.last_mut() {
                        Some(last) if a - last.1 < merge => last.1 = r.0,
                        _ => out.push((a, r.0)),
                    }
                    start = None;
                }
                _ => {}
            }
        }
        if let Some(a) = start {
            match out.last_mut() {
                Some(last) if a - last.1 < merge => last.1 = f64::INFINITY,
                _ => out.push((a, f64::INFINITY)),
            }
        }
        out
    }

    /// Whether `t` lies within `collar` s of a change of the speaking state.
    #[must_use]
    pub fn in_collar(&self, t: f64, collar: f64) -> bool {
        self.rows
            .windows(2)
            .filter(|w| w[0].2 != w[1].2)
            .any(|w| (w[1].0 - t).abs() < collar)
    }
}

/// Counts of one scene (or pooled over scenes).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Counts {
    /// Scored speaking talker-frames.
    pub talker_frames: usize,
    /// Of them matched.
    pub matched_talker_frames: usize,
    /// Active track-frames (without those matched to a talker inside its collar).
    pub track_frames: usize,
    /// Of them matched.
    pub matched_track_frames: usize,
    /// Sum of the matches' absolute errors, degrees.
    pub error_sum_deg: f64,
    /// ID switches.
    pub id_switches: usize,
    /// Σ over IDs of the frames on the ID's main talker.
    pub purity_main: usize,
    /// Σ over IDs of their matched frames.
    pub purity_all: usize,
    /// Recording length, s.
    pub seconds: f64,
    /// Scored frames.
    pub frames: usize,
    /// Frames with an active track on a directional noise source (within the tolerance of one that
    /// is switched on, and matched to no talker).
    pub noise_frames: usize,
    /// Scored talker-frames inside utterance spans ([`SPAN_COLLAR_S`]).
    pub span_talker_frames: usize,
    /// Of them matched.
    pub span_matched_talker_frames: usize,
    /// Of them with a live track (active or not) within the tolerance.
    pub span_located_frames: usize,
    /// Active track-frames (without those matched to a talker inside its span collar).
    pub span_track_frames: usize,
    /// Of them matched.
    pub span_matched_track_frames: usize,
}

impl Counts {
    fn add(&mut self, o: &Counts) {
        self.talker_frames += o.talker_frames;
        self.matched_talker_frames += o.matched_talker_frames;
        self.track_frames += o.track_frames;
        self.matched_track_frames += o.matched_track_frames;
        self.error_sum_deg += o.error_sum_deg;
        self.id_switches += o.id_switches;
        self.purity_main += o.purity_main;
        self.purity_all += o.purity_all;
        self.seconds += o.seconds;
        self.frames += o.frames;
        self.noise_frames += o.noise_frames;
        self.span_talker_frames += o.span_talker_frames;
        self.span_matched_talker_frames += o.span_matched_talker_frames;
        self.span_located_frames += o.span_located_frames;
        self.span_track_frames += o.span_track_frames;
        self.span_matched_track_frames += o.span_matched_track_frames;
    }
}

/// Metrics from counts.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Metrics {
    /// Matched / scored speaking talker-frames.
    pub recall: f64,
    /// Matched / reported active track-frames.
    pub precision: f64,
    /// Mean absolute error of the matches, degrees.
    pub mean_error_deg: f64,
    /// ID switches per minute.
    pub id_switches_per_min: f64,
    /// Pooled ID purity.
    pub id_purity: f64,
    /// Purity of the worst ID with at least one second of matches (1 when there is none).
    pub worst_id_purity: f64,
    /// Share of frames with an active track on a noise source (0 without noise sources).
    pub noise_track_share: f64,
    /// Matched / scored talker-frames inside utterance spans.
    pub span_recall: f64,
    /// Matched / active track-frames, scored over utterance spans.
    pub span_precision: f64,
    /// Share of the scored span talker-frames with a live track within the tolerance.
    pub span_located: f64,
}

/// One scene's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneScore {
    /// WAV path relative to the folder.
    pub file: String,
    /// Set name.
    pub set: String,
    /// Counts.
    pub counts: Counts,
    /// Metrics.
    pub metrics: Metrics,
}

/// A set's (or all scenes') result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SetScore {
    /// Set name (`all` overall).
    pub set: String,
    /// Scenes.
    pub scenes: usize,
    /// Pooled counts.
    pub counts: Counts,
    /// Metrics of the pooled counts (worst ID purity: the worst over the scenes).
    pub metrics: Metrics,
}

/// The report of `eval` on a multi-talker folder.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// Matching tolerance, degrees.
    pub tolerance_deg: f64,
    /// Collar, s.
    pub collar_s: f64,
    /// Collar of the span metrics, s.
    pub span_collar_s: f64,
    /// Per set, then `all`.
    pub sets: Vec<SetScore>,
    /// Per scene.
    pub scene_scores: Vec<SceneScore>,
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 {
        1.0
    } else {
        a as f64 / b as f64
    }
}

fn metrics(c: &Counts, worst_id_purity: f64) -> Metrics {
    Metrics {
        recall: ratio(c.matched_talker_frames, c.talker_frames),
        precision: ratio(c.matched_track_frames, c.track_frames),
        mean_error_deg: if c.matched_talker_frames > 0 {
            c.error_sum_deg / c.matched_talker_frames as f64
        } else {
            0.0
        },
        id_switches_per_min: if c.seconds > 0.0 {
            c.id_switches as f64 * 60.0 / c.seconds
        } else {
            0.0
        },
        id_purity: ratio(c.purity_main, c.purity_all),
        worst_id_purity,
        noise_track_share: if c.frames > 0 {
            c.noise_frames as f64 / c.frames as f64
        } else {
            0.0
        },
        span_recall: ratio(c.span_matched_talker_frames, c.span_talker_frames),
        span_precision: ratio(c.span_matched_track_frames, c.span_track_frames),
        span_located: ratio(c.span_located_frames, c.span_talker_frames),
    }
}

/// The best one-to-one matching of `tracks` (azimuths) to `talkers` (azimuths) within the
/// tolerance: most pairs, then least total error. Returns (track index, talker index, error) pairs.
#[must_use]
pub fn best_matching(tracks: &[f64], talkers: &[f64]) -> Vec<(usize, usize, f64)> {
    fn search(
        i: usize,
        tracks: &[f64],
        talkers: &[f64],
        used: &mut Vec<bool>,
        cur: &mut Vec<(usize, usize, f64)>,
        best: &mut (usize, f64, Vec<(usize, usize, f64)>),
    ) {
        if i == tracks.len() {
            let err: f64 = cur.iter().map(|m| m.2).sum();
            if cur.len() > best.0 || (cur.len() == best.0 && err < best.1) {
                *best = (cur.len(), err, cur.clone());
            }
            return;
        }
        search(i + 1, tracks, talkers, used, cur, best);
        for j in 0..talkers.len() {
            if used[j] {
                continue;
            }
            let e = crate::io::ground_truth::wrap180(tracks[i] - talkers[j]).abs();
            if e <= TOLERANCE_DEG {
                used[j] = true;
                cur.push((i, j, e));
                search(i + 1, tracks, talkers, used, cur, best);
                cur.pop();
                used[j] = false;
            }
        }
    }
    let mut best = (0, f64::INFINITY, Vec::new());
    search(
        0,
        tracks,
        talkers,
        &mut vec![false; talkers.len()],
        &mut Vec::new(),
        &mut best,
    );
    best.2
}

/// A directional noise source of a scene (`NAME.noise.csv`, written by `host-sim scene
/// --noise-source`): its azimuth and when it is switched on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseTruth {
    /// Azimuth, degrees.
    pub azimuth_deg: f64,
    /// Switch-on time, s.
    pub on_s: f64,
    /// Switch-off time, s (infinite: to the end).
    pub off_s: f64,
}

impl NoiseTruth {
    /// The noise sources next to `wav` (none when it has no `NAME.noise.csv`).
    pub fn read_beside(wav: &Path) -> Result<Vec<Self>> {
        let path = wav.with_extension("noise.csv");
        if !path.exists() {
            return Ok(Vec::new());
        }
        let text = std::fs::read_to_string(&path).map_err(|e| SimError::reading(&path, e))?;
        let bad = |line: usize| {
            SimError::Usage(format!(
                "{}: line {line}: not a noise source row",
                path.display()
            ))
        };
        text.lines()
            .enumerate()
            .skip(1)
            .filter(|(_, l)| !l.trim().is_empty())
            .map(|(i, l)| {
                let f: Vec<&str> = l.split(',').collect();
                let num = |j: usize| f.get(j).and_then(|v| v.trim().parse::<f64>().ok());
                Ok(Self {
                    azimuth_deg: num(1).ok_or_else(|| bad(i + 1))?,
                    on_s: num(5).ok_or_else(|| bad(i + 1))?,
                    off_s: num(6).unwrap_or(f64::INFINITY),
                })
            })
            .collect()
    }
}

/// Scores a scene's tracks against its talkers (and counts the frames with a track on one of
/// `noise` sources). Returns the counts and the worst ID purity.
#[must_use]
pub fn score(
    frames: &[TrackFrame],
    truths: &[TalkerTruth],
    noise: &[NoiseTruth],
    seconds: f64,
) -> (Counts, f64) {
    let mut c = Counts {
        seconds,
        ..Counts::default()
    };
    let mut last_id: Vec<Option<u16>> = vec![None; truths.len()];
    let spans: Vec<Vec<(f64, f64)>> = truths.iter().map(|t| t.utterances(SPAN_MERGE_S)).collect();
    let mut per_id: HashMap<u16, Vec<usize>> = HashMap::new();
    for f in frames {
        let active: Vec<&TalkerTrack> = f.tracks.iter().filter(|t| t.active).collect();
        // Talkers to match: speaking ones, and those inside a collar (optional).
        let mut cand = Vec::new();
        for (k, t) in truths.iter().enumerate() {
            let collar = t.in_collar(f.t_s, COLLAR_S);
            if t.speaking_at(f.t_s) || collar {
                cand.push((k, collar, t.azimuth_at(f.t_s)));
            }
        }
        let track_az: Vec<f64> = active.iter().map(|t| f64::from(t.azimuth_deg)).collect();
        let talker_az: Vec<f64> = cand.iter().map(|c| c.2).collect();
        let matches = best_matching(&track_az, &talker_az);
        let mut optional_matched = 0;
        for &(ti, ki, err) in &matches {
            let (k, collar, _) = cand[ki];
            if collar {
                optional_matched += 1;
                continue;
            }
            c.matched_talker_frames += 1;
            c.matched_track_frames += 1;
            c.error_sum_deg += err;
            let id = active[ti].id;
            if last_id[k].is_some_and(|l| l != id) {
                c.id_switches += 1;
            }
            last_id[k] = Some(id);
            let v = per_id.entry(id).or_insert_with(|| vec![0; truths.len()]);
            v[k] += 1;
        }
        c.talker_frames += cand.iter().filter(|x| !x.1).count();
        c.track_frames += active.len() - optional_matched;
        c.frames += 1;
        let on_noise = active.iter().enumerate().any(|(ti, t)| {
            !matches.iter().any(|m| m.0 == ti)
                && noise.iter().any(|n| {
                    f.t_s >= n.on_s
                        && f.t_s < n.off_s
                        && crate::io::ground_truth::wrap180(
                            f64::from(t.azimuth_deg) - n.azimuth_deg,
                        )
                        .abs()
                            <= TOLERANCE_DEG
                })
        });
        if on_noise {
            c.noise_frames += 1;
        }
        // Utterance spans: speaking from start to end, a narrower collar.
        let mut cand = Vec::new();
        for (k, t) in truths.iter().enumerate() {
            let near = |x: f64| (x - f.t_s).abs() < SPAN_COLLAR_S;
            let collar = spans[k].iter().any(|&(a, b)| near(a) || near(b));
            let inside = spans[k].iter().any(|&(a, b)| f.t_s >= a && f.t_s < b);
            if inside || collar {
                cand.push((collar, t.azimuth_at(f.t_s)));
            }
        }
        let talker_az: Vec<f64> = cand.iter().map(|c| c.1).collect();
        let matches = best_matching(&track_az, &talker_az);
        let optional = matches.iter().filter(|m| cand[m.1].0).count();
        let scored = matches.len() - optional;
        c.span_matched_talker_frames += scored;
        c.span_matched_track_frames += scored;
        c.span_talker_frames += cand.iter().filter(|x| !x.0).count();
        c.span_track_frames += active.len() - optional;
        c.span_located_frames += cand
            .iter()
            .filter(|x| {
                !x.0 && f.tracks.iter().any(|t| {
                    crate::io::ground_truth::wrap180(f64::from(t.azimuth_deg) - x.1).abs()
                        <= TOLERANCE_DEG
                })
            })
            .count();
    }
    let frame_s = if frames.len() > 1 {
        (frames[frames.len() - 1].t_s - frames[0].t_s) / (frames.len() - 1) as f64
    } else {
        1.0
    };
    let mut worst: f64 = 1.0;
    for v in per_id.values() {
        let all: usize = v.iter().sum();
        let main = v.iter().copied().max().unwrap_or(0);
        c.purity_main += main;
        c.purity_all += all;
        if all as f64 * frame_s >= 1.0 {
            worst = worst.min(main as f64 / all as f64);
        }
    }
    (c, worst)
}

/// One row of a multi-talker manifest.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// WAV path relative to the folder.
    pub file: PathBuf,
    /// Set name.
    pub set: String,
    /// Number of talkers.
    pub talkers: usize,
}

/// Whether `dir/manifest.csv` is a multi-talker manifest (its header is [`MANIFEST_HEADER`]).
#[must_use]
pub fn is_multi_talker_folder(dir: &Path) -> bool {
    std::fs::read_to_string(dir.join("manifest.csv"))
        .is_ok_and(|t| t.lines().next().map(str::trim) == Some(MANIFEST_HEADER))
}

/// Reads a multi-talker manifest.
pub fn read_manifest(dir: &Path) -> Result<Vec<Entry>> {
    let path = dir.join("manifest.csv");
    let text = crate::io::text_file::read(&path)?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.splitn(4, ',').collect();
        let talkers = f.get(2).and_then(|s| s.trim().parse::<usize>().ok());
        let (Some(file), Some(set), Some(talkers)) = (f.first(), f.get(1), talkers) else {
            return Err(SimError::BadCsv {
                path: path.clone(),
                line: i + 1,
                reason: format!("expected {MANIFEST_HEADER}, got `{line}`"),
            });
        };
        out.push(Entry {
            file: PathBuf::from(file.trim()),
            set: set.trim().to_string(),
            talkers,
        });
    }
    Ok(out)
}

/// Scores one scene.
pub fn evaluate_scene(
    dir: &Path,
    entry: &Entry,
    config: LocatorConfig,
    table: ReferenceTable<'_>,
    layout: InputLayout,
) -> Result<SceneScore> {
    evaluate_scene_with_plot(dir, entry, config, table, layout, None)
}

/// Scores one scene and, with `plots` a folder, draws its tracks against its talkers' truth into
/// `plots/NAME.png` (NAME the WAV's file stem).
pub fn evaluate_scene_with_plot(
    dir: &Path,
    entry: &Entry,
    config: LocatorConfig,
    table: ReferenceTable<'_>,
    layout: InputLayout,
    plots: Option<&Path>,
) -> Result<SceneScore> {
    let wav = dir.join(&entry.file);
    let rec = read_recording(&wav, layout)?;
    let truths = (0..entry.talkers)
        .map(|k| TalkerTruth::read(&truth_path(&wav, k)))
        .collect::<Result<Vec<_>>>()?;
    let frames = track_frames(&rec, config, table)?;
    let seconds = rec.frames.len() as f64 / f64::from(rec.rate);
    let noise = NoiseTruth::read_beside(&wav)?;
    let (counts, worst) = score(&frames, &truths, &noise, seconds);
    if let Some(plots) = plots {
        let name = entry
            .file
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        crate::evaluation::plots::multi_talker_plot(
            &plots.join(format!("{name}.png")),
            &name,
            &frames,
            &truths,
        )?;
    }
    Ok(SceneScore {
        file: entry.file.display().to_string(),
        set: entry.set.clone(),
        metrics: metrics(&counts, worst),
        counts,
    })
}

/// Scores every scene of a multi-talker folder on `threads` threads.
pub fn evaluate(
    dir: &Path,
    config: LocatorConfig,
    table: ReferenceTable<'_>,
    layout: InputLayout,
    threads: usize,
) -> Result<Report> {
    evaluate_with_plots(dir, config, table, layout, threads, None)
}

/// [`evaluate`], and with `plots` an existing folder, one PNG per scene in it
/// ([`crate::evaluation::plots::multi_talker_plot`]).
pub fn evaluate_with_plots(
    dir: &Path,
    config: LocatorConfig,
    table: ReferenceTable<'_>,
    layout: InputLayout,
    threads: usize,
    plots: Option<&Path>,
) -> Result<Report> {
    let entries = read_manifest(dir)?;
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results = std::sync::Mutex::new(
        (0..entries.len())
            .map(|_| None)
            .collect::<Vec<Option<Result<SceneScore>>>>(),
    );
    std::thread::scope(|s| {
        for _ in 0..threads.clamp(1, entries.len().max(1)) {
            s.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(e) = entries.get(i) else { break };
                let r = evaluate_scene_with_plot(dir, e, config, table, layout, plots);
                if let Ok(mut v) = results.lock() {
                    v[i] = Some(r);
                }
            });
        }
    });
    let scene_scores = results
        .into_inner()
        .map_err(|_| SimError::Other("a scoring thread panicked".into()))?
        .into_iter()
        .map(|r| r.unwrap_or_else(|| Err(SimError::Other("a scene was not scored".into()))))
        .collect::<Result<Vec<_>>>()?;
    let mut sets: Vec<String> = Vec::new();
    for s in &scene_scores {
        if !sets.contains(&s.set) {
            sets.push(s.set.clone());
        }
    }
    sets.push("all".into());
    let sets = sets
        .into_iter()
        .map(|name| {
            let mut c = Counts::default();
            let mut worst: f64 = 1.0;
            let mut n = 0;
            for s in scene_scores
                .iter()
                .filter(|s| name == "all" || s.set == name)
            {
                c.add(&s.counts);
                worst = worst.min(s.metrics.worst_id_purity);
                n += 1;
            }
            SetScore {
                set: name,
                scenes: n,
                metrics: metrics(&c, worst),
                counts: c,
            }
        })
        .collect();
    Ok(Report {
        tolerance_deg: TOLERANCE_DEG,
        collar_s: COLLAR_S,
        span_collar_s: SPAN_COLLAR_S,
        sets,
        scene_scores,
    })
}

/// The report as a text table.
#[must_use]
pub fn format_table(r: &Report) -> String {
    let mut s = format!(
        "multi-talker scenes: active tracks matched to speaking talkers within {}°, collar {} s\n\
         {:<14} {:>6} {:>8} {:>10} {:>9} {:>11} {:>10} {:>10}\n",
        r.tolerance_deg,
        r.collar_s,
        "set",
        "scenes",
        "recall",
        "precision",
        "error °",
        "switch/min",
        "ID purity",
        "worst ID"
    );
    for x in &r.sets {
        let m = &x.metrics;
        s.push_str(&format!(
            "{:<14} {:>6} {:>7.1}% {:>9.1}% {:>9.2} {:>11.2} {:>9.1}% {:>9.1}%\n",
            x.set,
            x.scenes,
            100.0 * m.recall,
            100.0 * m.precision,
            m.mean_error_deg,
            m.id_switches_per_min,
            100.0 * m.id_purity,
            100.0 * m.worst_id_purity
        ));
    }
    s.push_str(&format!(
        "utterance spans (speaking runs < {SPAN_MERGE_S} s apart joined), collar {} s\n\
         {:<14} {:>12} {:>15} {:>9}\n",
        r.span_collar_s, "set", "span recall", "span precision", "located"
    ));
    for x in &r.sets {
        let m = &x.metrics;
        s.push_str(&format!(
            "{:<14} {:>11.1}% {:>14.1}% {:>8.1}%\n",
            x.set,
            100.0 * m.span_recall,
            100.0 * m.span_precision,
            100.0 * m.span_located
        ));
    }
    if r.sets.iter().any(|x| x.counts.noise_frames > 0) {
        s.push_str("frames with an active track on a noise source (NAME.noise.csv):");
        for x in &r.sets {
            s.push_str(&format!(
                " {} {:.1}%",
                x.set,
                100.0 * x.metrics.noise_track_share
            ));
        }
        s.push('\n');
    }
    s
}

/// `host-sim eval` on a multi-talker folder.
pub fn run(a: &crate::commands::eval::EvalArgs) -> Result<()> {
    let config = a.config.config()?;
    let measured = a.config.measured_table()?;
    let table = a.config.table(measured.as_ref())?;
    let threads = a
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if let Some(dir) = &a.plots {
        if dir.exists() && !dir.is_dir() {
            return Err(SimError::Usage(format!(
                "--plots {}: exists and is not a folder",
                dir.display()
            )));
        }
        std::fs::create_dir_all(dir).map_err(|e| SimError::doing("create the folder", dir, e))?;
    }
    let report = evaluate_with_plots(
        &a.dir,
        config,
        table,
        a.input_layout,
        threads,
        a.plots.as_deref(),
    )?;
    if a.json {
        let json =
            serde_json::to_string_pretty(&report).map_err(|e| SimError::Other(e.to_string()))?;
        crate::io::stdout_text::print_text(&format!("{json}\n"))
    } else {
        crate::io::stdout_text::print_text(&format_table(&report))
    }
}
