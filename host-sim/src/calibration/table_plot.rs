//! The plot of a reference table (`host-sim calibrate --plot`): features vs azimuth per capsule at
//! four frequency rows, beside the ideal cardioid model.

use crate::error::{Result, SimError};
use crate::io::table_io::OwnedTable;
use cma_core::CARDIOID_LOOK_DEG;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use std::path::Path;

/// Draws a table: features vs azimuth per capsule at four frequency rows (near 300, 1000, 2000 and
/// 3500 Hz): the magnitude features (solid, with the measured points), the active features (dashed),
/// the ideal cardioid model (grey) and each capsule's look direction (dotted vertical line), every
/// curve closed over the full circle; one legend above the panels, off the data. Written atomically.
pub fn table_plot(path: &Path, t: &OwnedTable) -> Result<()> {
    crate::evaluation::plots::ensure_font()?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".partial.{name}"));
    let result = draw_table(&tmp, t);
    match result {
        Ok(()) => std::fs::rename(&tmp, path).map_err(|e| SimError::io(path, e)),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// The points of one capsule's curve over the table's azimuths, closed: the first azimuth repeated
/// at +360°.
fn closed_curve(azimuths: &[f32], values: impl Fn(usize) -> f32) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64)> = azimuths
        .iter()
        .enumerate()
        .map(|(qi, a)| (f64::from(*a), f64::from(values(qi))))
        .collect();
    if let Some(&(a, v)) = pts.first() {
        pts.push((a + 360.0, v));
    }
    pts
}

fn draw_table(path: &Path, t: &OwnedTable) -> Result<()> {
    let err = |e: &dyn std::fmt::Debug| {
        SimError::Other(format!("{}: plotting failed: {e:?}", path.display()))
    };
    let table = t.as_table()?;
    let q = t.azimuths_deg.len();
    let root = BitMapBackend::new(path, (1200, 900)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root
        .titled(
            "calibrated reference table: features vs source azimuth, per cardioid",
            ("sans-serif", 22),
        )
        .map_err(|e| err(&e))?;
    let (legend, panels) = root.split_vertically(70);
    let colors = [
        RGBColor(200, 30, 30),
        RGBColor(30, 140, 30),
        RGBColor(30, 60, 200),
    ];
    let grey = RGBColor(160, 160, 160);
    // The legend, above the panels: the capsules' colours, then the line styles.
    let text = ("sans-serif", 16).into_font();
    for (m, color) in colors.iter().enumerate() {
        let x = 20 + 160 * m as i32;
        legend
            .draw(&PathElement::new(
                [(x, 18), (x + 30, 18)],
                color.stroke_width(2),
            ))
            .map_err(|e| err(&e))?;
        legend
            .draw(&Text::new(
                format!("cardioid {:.0}°", CARDIOID_LOOK_DEG[m]),
                (x + 38, 10),
                text.clone(),
            ))
            .map_err(|e| err(&e))?;
    }
    let styles: [(&str, (i32, i32)); 4] = [
        ("ideal cardioid ½ + ½·cos(φ − φ_c)", (520, 10)),
        ("look direction φ_c", (900, 10)),
        ("magnitude |H_c|/|H_0| (dots: measured azimuths)", (20, 40)),
        ("active Re(H_c/H_0)", (520, 40)),
    ];
    for (k, (label, (x, y))) in styles.into_iter().enumerate() {
        let (a, b) = ((x, y + 8), (x + 30, y + 8));
        match k {
            0 => legend.draw(&PathElement::new([a, b], grey.stroke_width(1))),
            1 => legend.draw(&DashedPathElement::new(
                [(x + 15, y), (x + 15, y + 16)],
                2,
                3,
                BLACK.stroke_width(1),
            )),
            2 => legend.draw(&PathElement::new([a, b], BLACK.stroke_width(2))),
            _ => legend.draw(&DashedPathElement::new([a, b], 6, 4, BLACK.stroke_width(1))),
        }
        .map_err(|e| err(&e))?;
        legend
            .draw(&Text::new(label, (x + 38, y), text.clone()))
            .map_err(|e| err(&e))?;
    }
    for (area, f_want) in panels
        .split_evenly((2, 2))
        .iter()
        .zip([300.0, 1000.0, 2000.0, 3500.0])
    {
        let fi = table.freq_index(f_want);
        // The panel's range: its row's values and the ideal model's [0, 1].
        let shown = t.features[fi * q..(fi + 1) * q]
            .iter()
            .chain(&t.active[fi * q..(fi + 1) * q])
            .flatten();
        let ymax = f64::from(shown.clone().fold(1.0f32, |m, v| m.max(*v))) + 0.05;
        let ymin = f64::from(shown.fold(0.0f32, |m, v| m.min(*v))) - 0.05;
        let mut chart = ChartBuilder::on(area)
            .caption(format!("{:.0} Hz", t.freqs_hz[fi]), ("sans-serif", 18))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(40)
            .build_cartesian_2d(0.0..360.0, ymin..ymax)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("azimuth (°)")
            .y_desc("feature")
            .x_labels(13)
            .draw()
            .map_err(|e| err(&e))?;
        for (m, color) in colors.iter().enumerate() {
            let look = f64::from(CARDIOID_LOOK_DEG[m]);
            chart
                .draw_series(LineSeries::new(
                    (0..=360).map(|a| {
                        let a = f64::from(a);
                        (a, 0.5 + 0.5 * (a - look).to_radians().cos())
                    }),
                    grey.stroke_width(1),
                ))
                .map_err(|e| err(&e))?;
            // 0° is also 360°: its line at both edges.
            let edges = if look == 0.0 {
                vec![0.0, 360.0]
            } else {
                vec![look]
            };
            for x in edges {
                chart
                    .draw_series(DashedLineSeries::new(
                        [(x, ymin), (x, ymax)],
                        2,
                        4,
                        color.stroke_width(1),
                    ))
                    .map_err(|e| err(&e))?;
            }
            let base = fi * q;
            let magnitude = closed_curve(&t.azimuths_deg, |qi| t.features[base + qi][m]);
            let active = closed_curve(&t.azimuths_deg, |qi| t.active[base + qi][m]);
            chart
                .draw_series(DashedLineSeries::new(active, 6, 4, color.stroke_width(1)))
                .map_err(|e| err(&e))?;
            chart
                .draw_series(LineSeries::new(magnitude.clone(), color.stroke_width(2)))
                .map_err(|e| err(&e))?;
            chart
                .draw_series(
                    magnitude[..q]
                        .iter()
                        .map(|p| Circle::new(*p, 2, color.filled())),
                )
                .map_err(|e| err(&e))?;
        }
    }
    root.present().map_err(|e| err(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plot is written (legend, ideal curves, look directions, closed curves are drawn without
    /// error, also with negative active features).
    #[test]
    fn table_plot_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.png");
        let mut t = OwnedTable::from_table(&cma_core::ReferenceTable::ideal_15deg());
        t.active[12][1] = -0.2;
        table_plot(&path, &t).unwrap();
        assert!(std::fs::metadata(&path).unwrap().len() > 10_000);
    }
}
