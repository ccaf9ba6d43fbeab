//! SVG plots (plotters, with an embedded DejaVu font so no system font is needed): a feasible
//! region of stage 1 (the exact polygon of constraints (16)-(17), truth marked) and the
//! inner-signal bound band of stage 2 over time (eqs 23-27), truth drawn when known.
use crate::error::{Result, SmidError};
use crate::inversion::{InnerBound, InnerKind};
use crate::nonlinearity::Region;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

static FONT: Once = Once::new();

/// Register the embedded DejaVu font once (plotters needs a registered font even for SVG).
pub fn ensure_font() {
    FONT.call_once(|| {
        for style in [
            FontStyle::Normal,
            FontStyle::Bold,
            FontStyle::Italic,
            FontStyle::Oblique,
        ] {
            let _ = plotters::style::register_font("sans-serif", style, dejavu::sans::regular());
        }
    });
}

fn plot_err(path: &Path, e: impl std::fmt::Display) -> SmidError {
    SmidError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    }
}

/// Decimals needed to tell ticks apart over a range of `span`.
fn digits(span: f64) -> usize {
    if span > 0.0 && span.is_finite() {
        ((-span.log10()).ceil() as i64 + 2).clamp(1, 12) as usize
    } else {
        3
    }
}

fn padded(lo: f64, hi: f64) -> (f64, f64) {
    let w = (hi - lo).abs().max(1e-12 * (1.0 + lo.abs()));
    (lo - 0.1 * w, hi + 0.1 * w)
}

/// Plot a feasible polygon with its vertices and the truth.
pub fn region_svg(region: &Region, path: &Path) -> Result<()> {
    ensure_font();
    let pts: Vec<[f64; 2]> = region
        .vertices
        .iter()
        .copied()
        .chain(region.truth)
        .collect();
    let (x0, x1) = padded(
        pts.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min),
        pts.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max),
    );
    let (y0, y1) = padded(
        pts.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min),
        pts.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max),
    );
    let root = SVGBackend::new(path, (640, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("feasible set: {}", region.name.replace('_', " ")),
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| plot_err(path, e))?;
    let (dx, dy) = (digits(x1 - x0), digits(y1 - y0));
    chart
        .configure_mesh()
        .x_desc(region.axes[0].as_str())
        .y_desc(region.axes[1].as_str())
        .x_labels(6)
        .y_labels(6)
        .x_label_formatter(&|v| format!("{v:.dx$}"))
        .y_label_formatter(&|v| format!("{v:.dy$}"))
        .draw()
        .map_err(|e| plot_err(path, e))?;
    let poly: Vec<(f64, f64)> = region.vertices.iter().map(|v| (v[0], v[1])).collect();
    chart
        .draw_series(std::iter::once(Polygon::new(
            poly.clone(),
            BLUE.mix(0.25).filled(),
        )))
        .map_err(|e| plot_err(path, e))?
        .label("feasible set")
        .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 15, y + 5)], BLUE.mix(0.25).filled()));
    let mut closed = poly.clone();
    if let Some(f) = poly.first() {
        closed.push(*f);
    }
    chart
        .draw_series(LineSeries::new(closed, BLUE.stroke_width(2)))
        .map_err(|e| plot_err(path, e))?;
    chart
        .draw_series(poly.iter().map(|&p| Circle::new(p, 3, BLUE.filled())))
        .map_err(|e| plot_err(path, e))?;
    if let Some(t) = region.truth {
        chart
            .draw_series(std::iter::once(Cross::new(
                (t[0], t[1]),
                7,
                RED.stroke_width(2),
            )))
            .map_err(|e| plot_err(path, e))?
            .label("true parameters")
            .legend(|(x, y)| Cross::new((x + 7, y), 5, RED.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()
        .map_err(|e| plot_err(path, e))?;
    root.present().map_err(|e| plot_err(path, e))?;
    Ok(())
}

/// Plot inner-signal bounds over time: inverted samples dark, band-only samples light.
pub fn inner_svg(inner: &[InnerBound], truth: Option<&[f64]>, path: &Path) -> Result<()> {
    ensure_font();
    let finite: Vec<(usize, &InnerBound)> = inner
        .iter()
        .enumerate()
        .filter(|(_, b)| b.interval.is_finite())
        .collect();
    let mut lo = finite
        .iter()
        .map(|(_, b)| b.interval.lo)
        .fold(f64::INFINITY, f64::min);
    let mut hi = finite
        .iter()
        .map(|(_, b)| b.interval.hi)
        .fold(f64::NEG_INFINITY, f64::max);
    if let Some(x) = truth {
        lo = lo.min(x.iter().copied().fold(f64::INFINITY, f64::min));
        hi = hi.max(x.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    }
    if !(lo.is_finite() && hi.is_finite()) {
        lo = -1.0;
        hi = 1.0;
    }
    let (y0, y1) = padded(lo, hi);
    let n = inner.len().max(2);
    let root = SVGBackend::new(path, (960, 720)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
    let (top, bottom) = root.split_vertically(430);
    // Bottom panel: the radius Δx_t of each bound (eq 28) on a log scale, so thin bounds show.
    let radii: Vec<(usize, f64, InnerKind)> = finite
        .iter()
        .map(|(t, b)| (*t, b.interval.radius().max(1e-300), b.kind))
        .collect();
    let rmin = radii.iter().map(|r| r.1).fold(f64::INFINITY, f64::min);
    let rmax = radii.iter().map(|r| r.1).fold(f64::NEG_INFINITY, f64::max);
    let (rmin, rmax) = if rmin.is_finite() && rmax.is_finite() {
        (rmin / 2.0, rmax * 2.0)
    } else {
        (1e-6, 1.0)
    };
    let mut rc = ChartBuilder::on(&bottom)
        .caption("bound radius Δx_t", ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(-0.5..(n as f64 - 0.5), (rmin..rmax).log_scale())
        .map_err(|e| plot_err(path, e))?;
    rc.configure_mesh()
        .x_desc("t")
        .y_desc("Δx_t")
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(|e| plot_err(path, e))?;
    for (kind, color) in [
        (InnerKind::Band, RGBColor(150, 190, 230)),
        (InnerKind::Inverted, BLUE),
    ] {
        rc.draw_series(
            radii
                .iter()
                .filter(|r| r.2 == kind)
                .map(|r| Circle::new((r.0 as f64, r.1), 3, color.filled())),
        )
        .map_err(|e| plot_err(path, e))?;
    }
    let mut chart = ChartBuilder::on(&top)
        .caption("inner-signal bounds x_t (stage 2)", ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(-0.5..(n as f64 - 0.5), y0..y1)
        .map_err(|e| plot_err(path, e))?;
    chart
        .configure_mesh()
        .x_desc("t")
        .y_desc("x_t")
        .draw()
        .map_err(|e| plot_err(path, e))?;
    for (kind, color, label) in [
        (
            InnerKind::Band,
            RGBColor(150, 190, 230).mix(0.7),
            "dead-band bound",
        ),
        (InnerKind::Inverted, BLUE.mix(0.9), "inverted bound"),
    ] {
        chart
            .draw_series(finite.iter().filter(|(_, b)| b.kind == kind).map(|(t, b)| {
                let t = *t as f64;
                Rectangle::new(
                    [(t - 0.3, b.interval.lo), (t + 0.3, b.interval.hi)],
                    color.filled(),
                )
            }))
            .map_err(|e| plot_err(path, e))?
            .label(label)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 15, y + 5)], color.filled()));
    }
    if let Some(x) = truth {
        chart
            .draw_series(LineSeries::new(
                x.iter().enumerate().map(|(t, v)| (t as f64, *v)),
                RED.stroke_width(1),
            ))
            .map_err(|e| plot_err(path, e))?
            .label("true x_t")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], RED));
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()
        .map_err(|e| plot_err(path, e))?;
    root.present().map_err(|e| plot_err(path, e))?;
    Ok(())
}
