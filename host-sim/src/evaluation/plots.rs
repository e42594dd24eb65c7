//! PNG plots: azimuth track vs truth per scene (thesis Fig. 5.5 / 6.7) and accuracy vs tolerance per set.

use crate::error::{Result, SimError};
use crate::eval::{Report, SceneResult};
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
    &'static str,
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
        area.draw(&Text::new(*label, (x + 26, y - 7), ("sans-serif", 14)))
            .map_err(|e| format!("{e:?}"))?;
    }
    Ok(())
}

/// Azimuth estimate (weighted and raw) and truth over time for one scene, and the confidence in a
/// panel of its own; frames before the first reliable one (flag NO_HISTORY) are drawn hollow.
pub fn track_plot(path: &Path, scene: &SceneResult) -> Result<()> {
    ensure_font()?;
    let err = draw_err(path);
    let t_end = scene.rows.last().map_or(1.0, |r| r.t_s).max(0.1);
    let root = BitMapBackend::new(path, (1000, 560)).into_drawing_area();
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
            "truth",
            Box::new(|a, (x, y)| {
                a.draw(&PathElement::new(
                    [(x, y), (x + 20, y)],
                    BLACK.stroke_width(2),
                ))
                .map_err(|e| format!("{e:?}"))
            }),
        ),
        (
            "estimate",
            Box::new(|a, (x, y)| {
                a.draw(&Circle::new((x + 10, y), 3, BLUE.filled()))
                    .map_err(|e| format!("{e:?}"))
            }),
        ),
        (
            "single frame (b = 1)",
            Box::new(move |a, (x, y)| {
                a.draw(&Circle::new((x + 10, y), 3, raw_color.filled()))
                    .map_err(|e| format!("{e:?}"))
            }),
        ),
        (
            "no reliable frame yet",
            Box::new(move |a, (x, y)| {
                a.draw(&Circle::new((x + 10, y), 3, grey.stroke_width(1)))
                    .map_err(|e| format!("{e:?}"))
            }),
        ),
    ];
    draw_legend(&legend, &entries, 240).map_err(draw_err(path))?;
    let no_history =
        |r: &crate::locate::Row| r.estimate.flags.contains(cma_core::Flags::NO_HISTORY);
    let mut chart = ChartBuilder::on(&top)
        .margin(10)
        .x_label_area_size(20)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..t_end, -180.0..180.0)
        .map_err(&err)?;
    chart
        .configure_mesh()
        .y_desc("azimuth (°)")
        .y_labels(9)
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
        .x_label_area_size(35)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..t_end, 0.0..1.0)
        .map_err(&err)?;
    conf.configure_mesh()
        .x_desc("time (s)")
        .y_desc("confidence b")
        .y_labels(3)
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
        let label: &'static str = Box::leak(set.set.clone().into_boxed_str());
        entries.push((
            label,
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
