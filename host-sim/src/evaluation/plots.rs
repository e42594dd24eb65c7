//! PNG plots: azimuth track vs truth per scene (thesis Fig. 5.5 / 6.7), accuracy vs tolerance per set,
//! and the talker tracks vs each talker's truth per multi-talker scene.

use crate::error::{Result, SimError};
use crate::evaluation::eval::{Report, SceneResult};
use crate::evaluation::multi_talker_eval::{TalkerTruth, TrackFrame};
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

const FONT_PATHS: [&str; 3] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
];

/// Registers a TrueType font for the plots' text once (Debian: `fonts-dejavu-core`).
pub(crate) fn ensure_font() -> Result<()> {
    static DONE: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        for p in FONT_PATHS {
            if let Ok(bytes) = std::fs::read(p) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                return plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
                    .map_err(|_| format!("{p}: not a usable font"));
            }
        }
        Err("no TrueType font found for plot labels (install Debian's fonts-dejavu-core)".into())
    })
    .clone()
    .map_err(SimError::Other)
}

fn draw_err<E: std::fmt::Debug>(path: &Path) -> impl Fn(E) -> SimError + '_ {
    move |e| SimError::Other(format!("{}: plotting failed: {e:?}", path.display()))
}

/// One legend entry: a marker drawer and its label.
type LegendEntry = (
    String,
    Box<
        dyn Fn(
            &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
            (i32, i32),
        ) -> std::result::Result<(), String>,
    >,
);

/// Draws `entries` in a row (or wrapped) into `area`, outside any chart's data.
fn draw_legend(
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    entries: &[LegendEntry],
    column_width: i32,
) -> std::result::Result<(), String> {
    let (w, _) = area.dim_in_pixel();
    let per_row = (w as i32 / column_width).max(1);
    for (i, (label, marker)) in entries.iter().enumerate() {
        let x = 10 + (i as i32 % per_row) * column_width;
        let y = 12 + (i as i32 / per_row) * 20;
        marker(area, (x, y))?;
        area.draw(&Text::new(
            label.as_str(),
            (x + 26, y - 7),
            ("sans-serif", 14),
        ))
        .map_err(|e| format!("{e:?}"))?;
    }
    Ok(())
}

/// Size of the axis labels and descriptions of the track plot, px (plotters' default, 12, is hard
/// to read in the small confidence panel).
const AXIS_FONT: u32 = 16;

/// Azimuth estimate (weighted and raw) and truth over time for one scene, and the confidence in a
/// panel of its own; frames before the first reliable one (flag NO_HISTORY) are drawn hollow.
pub fn track_plot(path: &Path, scene: &SceneResult) -> Result<()> {
    ensure_font()?;
    let err = draw_err(path);
    let t_end = scene.rows.last().map_or(1.0, |r| r.t_s).max(0.1);
    let root = BitMapBackend::new(path, (1000, 620)).into_drawing_area();
    root.fill(&WHITE).map_err(&err)?;
    let root = root
        .titled(
            &format!("{} — azimuth vs truth", scene.entry.name()),
            ("sans-serif", 20),
        )
        .map_err(&err)?;
    let (legend, rest) = root.split_vertically(30);
    let (top, bottom) = rest.split_vertically(380);
    let raw_color = RGBColor(240, 150, 150);
    let grey = RGBColor(150, 150, 150);
    let entries: Vec<LegendEntry> = vec![
        (
            "truth".into(),
            Box::new(|a, (x, y)| {
                a.draw(&PathElement::new(
                    [(x, y), (x + 20, y)],
                    BLACK.stroke_width(2),
                ))
                .map_err(|e| format!("{e:?}"))
            }),
        ),
        (
            "tracked estimate".into(),
            Box::new(|a, (x, y)| {
                a.draw(&Circle::new((x + 10, y), 3, BLUE.filled()))
                    .map_err(|e| format!("{e:?}"))
            }),
        ),
        (
            "raw per-frame estimate".into(),
            Box::new(move |a, (x, y)| {
                a.draw(&Circle::new((x + 10, y), 3, raw_color.filled()))
                    .map_err(|e| format!("{e:?}"))
            }),
        ),
        (
            "no reliable frame yet".into(),
            Box::new(move |a, (x, y)| {
                a.draw(&Circle::new((x + 10, y), 3, grey.stroke_width(1)))
                    .map_err(|e| format!("{e:?}"))
            }),
        ),
    ];
    draw_legend(&legend, &entries, 240).map_err(draw_err(path))?;
    let no_history = |r: &crate::localization::frame_estimates::Row| {
        r.estimate.flags.contains(cma_core::Flags::NO_HISTORY)
    };
    let mut chart = ChartBuilder::on(&top)
        .margin(10)
        .x_label_area_size(25)
        .y_label_area_size(65)
        .build_cartesian_2d(0.0..t_end, -180.0..180.0)
        .map_err(&err)?;
    chart
        .configure_mesh()
        .y_desc("azimuth (°)")
        .y_labels(9)
        .label_style(("sans-serif", AXIS_FONT))
        .axis_desc_style(("sans-serif", AXIS_FONT))
        .draw()
        .map_err(&err)?;
    chart
        .draw_series(scene.rows.iter().filter(|r| !no_history(r)).map(|r| {
            Circle::new(
                (r.t_s, r.estimate.azimuth_raw_deg as f64),
                2,
                raw_color.filled(),
            )
        }))
        .map_err(&err)?;
    let truth: Vec<(f64, f64)> = (0..=2000)
        .map(|i| i as f64 * t_end / 2000.0)
        .map(|t| (t, scene.track.azimuth_at(t)))
        .collect();
    chart
        .draw_series(truth.iter().map(|p| Circle::new(*p, 1, BLACK.filled())))
        .map_err(&err)?;
    chart
        .draw_series(
            scene
                .rows
                .iter()
                .filter(|r| !no_history(r))
                .map(|r| Circle::new((r.t_s, r.estimate.azimuth_deg as f64), 2, BLUE.filled())),
        )
        .map_err(&err)?;
    chart
        .draw_series(scene.rows.iter().filter(|r| no_history(r)).map(|r| {
            Circle::new(
                (r.t_s, r.estimate.azimuth_deg as f64),
                3,
                grey.stroke_width(1),
            )
        }))
        .map_err(&err)?;
    let mut conf = ChartBuilder::on(&bottom)
        .margin(10)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(0.0..t_end, 0.0..1.0)
        .map_err(&err)?;
    conf.configure_mesh()
        .x_desc("time (s)")
        .y_desc("confidence")
        .y_labels(3)
        .label_style(("sans-serif", AXIS_FONT))
        .axis_desc_style(("sans-serif", AXIS_FONT))
        .draw()
        .map_err(&err)?;
    conf.draw_series(LineSeries::new(
        scene
            .rows
            .iter()
            .map(|r| (r.t_s, f64::from(r.estimate.confidence))),
        GREEN.stroke_width(1),
    ))
    .map_err(&err)?;
    root.present().map_err(&err)
}

/// ACC_Δ vs Δ for every set; the vertical range starts just below the lowest curve so that curves
/// near 100 % can be told apart, and the legend sits beside the chart.
pub fn accuracy_plot(path: &Path, report: &Report) -> Result<()> {
    ensure_font()?;
    let err = draw_err(path);
    let root = BitMapBackend::new(path, (1000, 500)).into_drawing_area();
    root.fill(&WHITE).map_err(&err)?;
    let (left, right) = root.split_horizontally(780);
    let lowest = report
        .sets
        .iter()
        .flat_map(|s| s.settled.acc.iter().copied())
        .filter(|a| a.is_finite())
        .fold(100.0f64, f64::min);
    let y_lo = ((lowest - 2.0) / 5.0).floor().max(0.0) * 5.0;
    let y_lo = y_lo.min(95.0);
    let mut chart = ChartBuilder::on(&left)
        .caption("accuracy vs tolerance (settled frames)", ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(50)
        .build_cartesian_2d(1.0..30.0, y_lo..100.0)
        .map_err(&err)?;
    chart
        .configure_mesh()
        .x_desc("tolerance Δ (°)")
        .y_desc("ACC_Δ (%)")
        .draw()
        .map_err(&err)?;
    let mut entries: Vec<LegendEntry> = Vec::new();
    for (i, set) in report.sets.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(
                set.settled
                    .acc
                    .iter()
                    .enumerate()
                    .map(|(d, a)| ((d + 1) as f64, *a)),
                color.stroke_width(2),
            ))
            .map_err(&err)?;
        entries.push((
            set.set.clone(),
            Box::new(move |a, (x, y)| {
                a.draw(&PathElement::new(
                    [(x, y), (x + 20, y)],
                    color.stroke_width(2),
                ))
                .map_err(|e| format!("{e:?}"))
            }),
        ));
    }
    let legend = right.margin(40, 0, 0, 0);
    draw_legend(&legend, &entries, 200).map_err(draw_err(path))?;
    root.present().map_err(&err)
}

/// Track colours (Tableau 10 without its grey), picked by track ID.
const TRACK_COLORS: [RGBColor; 9] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Points of a talker's truth while it speaks, split into runs (a new run after a silence or a
/// wrap across ±180°), sampled at `n + 1` times over `0..=t_end`.
fn speaking_runs(truth: &TalkerTruth, t_end: f64, n: usize) -> Vec<Vec<(f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    for i in 0..=n {
        let t = i as f64 * t_end / n as f64;
        let az = truth.azimuth_at(t);
        let wraps = cur
            .last()
            .is_some_and(|p: &(f64, f64)| (p.1 - az).abs() > 180.0);
        if !truth.speaking_at(t) || wraps {
            if !cur.is_empty() {
                runs.push(std::mem::take(&mut cur));
            }
            if !truth.speaking_at(t) {
                continue;
            }
        }
        cur.push((t, az));
    }
    if !cur.is_empty() {
        runs.push(cur);
    }
    runs
}

/// Azimuth over time of one multi-talker scene: each track ID in its own colour (filled dots on
/// its active frames, faint small dots on its inactive ones), each talker's truth where that talker
/// speaks as a faint band behind the dots and a thin dark line over them (labelled with its
/// number), the legend above the chart.
pub fn multi_talker_plot(
    path: &Path,
    name: &str,
    frames: &[TrackFrame],
    truths: &[TalkerTruth],
) -> Result<()> {
    ensure_font()?;
    let err = draw_err(path);
    let t_end = frames.last().map_or(1.0, |f| f.t_s).max(0.1);
    let mut ids: Vec<u16> = frames
        .iter()
        .flat_map(|f| f.tracks.iter().map(|t| t.id))
        .collect();
    ids.sort_unstable();
    ids.dedup();
    let color = |id: u16| TRACK_COLORS[usize::from(id) % TRACK_COLORS.len()];
    let truth_color = RGBColor(30, 30, 30);
    let band = truth_color.mix(0.18);
    let mut entries: Vec<LegendEntry> = vec![
        (
            "talker truth (speaking)".into(),
            Box::new(move |a, (x, y)| {
                a.draw(&PathElement::new(
                    [(x, y), (x + 20, y)],
                    band.stroke_width(10),
                ))
                .and_then(|()| {
                    a.draw(&PathElement::new(
                        [(x, y), (x + 20, y)],
                        truth_color.stroke_width(1),
                    ))
                })
                .map_err(|e| format!("{e:?}"))
            }),
        ),
        (
            "track inactive (faint)".into(),
            Box::new(|a, (x, y)| {
                a.draw(&Circle::new((x + 10, y), 2, BLACK.mix(0.25).filled()))
                    .map_err(|e| format!("{e:?}"))
            }),
        ),
    ];
    for &id in &ids {
        let c = color(id);
        entries.push((
            format!("track ID {id} (active)"),
            Box::new(move |a, (x, y)| {
                a.draw(&Circle::new((x + 10, y), 3, c.filled()))
                    .map_err(|e| format!("{e:?}"))
            }),
        ));
    }
    const WIDTH: u32 = 1000;
    const COLUMN: i32 = 200;
    let per_row = (WIDTH as i32 / COLUMN) as usize;
    let legend_h = 10 + 20 * entries.len().div_ceil(per_row) as u32;
    let root = BitMapBackend::new(path, (WIDTH, 500 + legend_h)).into_drawing_area();
    root.fill(&WHITE).map_err(&err)?;
    let root = root
        .titled(
            &format!("{name} — talker tracks vs truth"),
            ("sans-serif", 20),
        )
        .map_err(&err)?;
    let (legend, chart_area) = root.split_vertically(legend_h);
    draw_legend(&legend, &entries, COLUMN).map_err(draw_err(path))?;
    let mut chart = ChartBuilder::on(&chart_area)
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..t_end, -180.0..180.0)
        .map_err(&err)?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc("azimuth (°)")
        .y_labels(9)
        .draw()
        .map_err(&err)?;
    // Truth: a faint band behind the tracks, a thin dark line over them, its number beside it.
    let runs: Vec<Vec<Vec<(f64, f64)>>> = truths
        .iter()
        .map(|truth| speaking_runs(truth, t_end, 2000))
        .collect();
    for run in runs.iter().flatten() {
        chart
            .draw_series(LineSeries::new(run.iter().copied(), band.stroke_width(10)))
            .map_err(&err)?;
    }
    let points = |active: bool| {
        frames.iter().flat_map(move |f| {
            f.tracks
                .iter()
                .filter(move |t| t.active == active)
                .map(move |t| (f.t_s, f64::from(t.azimuth_deg), t.id))
        })
    };
    chart
        .draw_series(
            points(false).map(|(t, az, id)| Circle::new((t, az), 1, color(id).mix(0.25).filled())),
        )
        .map_err(&err)?;
    chart
        .draw_series(points(true).map(|(t, az, id)| Circle::new((t, az), 2, color(id).filled())))
        .map_err(&err)?;
    for (k, talker_runs) in runs.iter().enumerate() {
        for run in talker_runs {
            chart
                .draw_series(LineSeries::new(
                    run.iter().copied(),
                    truth_color.stroke_width(1),
                ))
                .map_err(&err)?;
        }
        if let Some(&(t, az)) = talker_runs.first().and_then(|r| r.first()) {
            let label_az = if az > 150.0 { az - 8.0 } else { az + 16.0 };
            chart
                .draw_series(std::iter::once(Text::new(
                    format!("talker {}", k + 1),
                    (t, label_az),
                    ("sans-serif", 13).into_font().color(&truth_color),
                )))
                .map_err(&err)?;
        }
    }
    root.present().map_err(&err)
}
