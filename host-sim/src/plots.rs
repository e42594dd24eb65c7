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

/// Azimuth estimate (weighted and raw) and truth over time for one scene.
pub fn track_plot(path: &Path, scene: &SceneResult) -> Result<()> {
    ensure_font()?;
    let err = draw_err(path);
    let t_end = scene.rows.last().map_or(1.0, |r| r.t_s).max(0.1);
    let root = BitMapBackend::new(path, (1000, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(&err)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("{} — azimuth vs truth", scene.entry.name()),
            ("sans-serif", 20),
        )
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
    let raw_color = RGBColor(240, 150, 150);
    chart
        .draw_series(scene.rows.iter().map(|r| {
            Circle::new(
                (r.t_s, r.estimate.azimuth_raw_deg as f64),
                2,
                raw_color.filled(),
            )
        }))
        .map_err(&err)?
        .label("unweighted (b = 1)")
        .legend(move |(x, y)| Circle::new((x + 10, y), 3, raw_color.filled()));
    let truth: Vec<(f64, f64)> = (0..=2000)
        .map(|i| i as f64 * t_end / 2000.0)
        .map(|t| (t, scene.track.azimuth_at(t)))
        .collect();
    chart
        .draw_series(truth.iter().map(|p| Circle::new(*p, 1, BLACK.filled())))
        .map_err(&err)?
        .label("truth")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    chart
        .draw_series(
            scene
                .rows
                .iter()
                .map(|r| Circle::new((r.t_s, r.estimate.azimuth_deg as f64), 2, BLUE.filled())),
        )
        .map_err(&err)?
        .label("estimate")
        .legend(|(x, y)| Circle::new((x + 10, y), 3, BLUE.filled()));
    chart
        .draw_series(LineSeries::new(
            scene
                .rows
                .iter()
                .map(|r| (r.t_s, -180.0 + 60.0 * r.estimate.confidence as f64)),
            GREEN.stroke_width(1),
        ))
        .map_err(&err)?
        .label("confidence b (0…1 → −180…−120°)")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], GREEN.stroke_width(1)));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(&err)?;
    root.present().map_err(&err)
}

/// ACC_Δ vs Δ for every set.
pub fn accuracy_plot(path: &Path, report: &Report) -> Result<()> {
    ensure_font()?;
    let err = draw_err(path);
    let root = BitMapBackend::new(path, (800, 500)).into_drawing_area();
    root.fill(&WHITE).map_err(&err)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("accuracy vs tolerance (settled frames)", ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(50)
        .build_cartesian_2d(1.0..30.0, 0.0..100.0)
        .map_err(&err)?;
    chart
        .configure_mesh()
        .x_desc("tolerance Δ (°)")
        .y_desc("ACC_Δ (%)")
        .draw()
        .map_err(&err)?;
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
            .map_err(&err)?
            .label(set.set.clone())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(&err)?;
    root.present().map_err(&err)
}
