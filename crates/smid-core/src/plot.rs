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

/// One line of a time-series plot.
pub struct Line<'a> {
    /// Legend entry.
    pub label: &'a str,
    /// One value per sample (the x axis is the sample index).
    pub values: &'a [f64],
    /// RGB colour.
    pub color: (u8, u8, u8),
}

/// A shaded area between two series (an envelope, a band), drawn under the lines.
pub struct Shade<'a> {
    /// Legend entry.
    pub label: &'a str,
    /// Lower edge, one value per sample (clipped to the chart; an infinite end reaches its
    /// edge).
    pub lower: &'a [f64],
    /// Upper edge, one value per sample (clipped likewise).
    pub upper: &'a [f64],
    /// RGB colour (drawn translucent).
    pub color: (u8, u8, u8),
}

/// Measured output against model outputs over time, with shaded areas (envelopes, bands;
/// infinite ends are clipped to the plot): the validation and before/after plots.
pub fn series_svg(title: &str, lines: &[Line], shades: &[Shade], path: &Path) -> Result<()> {
    ensure_font();
    let n = lines
        .iter()
        .map(|l| l.values.len())
        .max()
        .unwrap_or(0)
        .max(2);
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for l in lines {
        for v in l.values.iter().filter(|v| v.is_finite()) {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
    }
    // The measured output sets the scale: a diverging model is clipped, not the data.
    if let Some(first) = lines.first() {
        let (a, b) = first
            .values
            .iter()
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        if a.is_finite() && b.is_finite() {
            let w = (b - a).max(1e-12);
            lo = lo.max(a - 2.0 * w);
            hi = hi.min(b + 2.0 * w);
        }
    }
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        lo = -1.0;
        hi = 1.0;
    }
    let (y0, y1) = padded(lo, hi);
    let clip = |v: f64| v.clamp(y0, y1);
    let root = SVGBackend::new(path, (1100, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..(n as f64 - 1.0), y0..y1)
        .map_err(|e| plot_err(path, e))?;
    let d = digits(y1 - y0);
    chart
        .configure_mesh()
        .x_desc("sample")
        .y_label_formatter(&|v| format!("{v:.d$}"))
        .draw()
        .map_err(|e| plot_err(path, e))?;
    for sh in shades {
        let color = RGBColor(sh.color.0, sh.color.1, sh.color.2).mix(0.5);
        let at = |v: f64| if v.is_nan() { y0 } else { clip(v) };
        let poly: Vec<(f64, f64)> = sh
            .lower
            .iter()
            .enumerate()
            .map(|(t, v)| (t as f64, at(*v)))
            .chain(
                sh.upper
                    .iter()
                    .enumerate()
                    .rev()
                    .map(|(t, v)| (t as f64, if v.is_nan() { y1 } else { clip(*v) })),
            )
            .collect();
        chart
            .draw_series(std::iter::once(Polygon::new(poly, color.filled())))
            .map_err(|e| plot_err(path, e))?
            .label(sh.label)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 15, y + 5)], color.filled()));
    }
    for l in lines {
        let color = RGBColor(l.color.0, l.color.1, l.color.2);
        chart
            .draw_series(LineSeries::new(
                l.values
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| v.is_finite())
                    .map(|(t, v)| (t as f64, clip(*v))),
                color.stroke_width(1),
            ))
            .map_err(|e| plot_err(path, e))?
            .label(l.label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], color));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()
        .map_err(|e| plot_err(path, e))?;
    root.present().map_err(|e| plot_err(path, e))?;
    Ok(())
}

/// Residual auto-correlation (lags 0..) and input cross-correlation (lags -L..L) as stems, with
/// the 99 % band.
pub fn correlation_svg(auto: &[f64], cross: &[f64], band: f64, path: &Path) -> Result<()> {
    ensure_font();
    let root = SVGBackend::new(path, (960, 640)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
    let (top, bottom) = root.split_vertically(320);
    let lag = (cross.len() / 2) as i64;
    for (area, values, first, title) in [
        (
            &top,
            auto,
            0i64,
            "residual auto-correlation r_ee(τ) with the 99 % band",
        ),
        (
            &bottom,
            cross,
            -lag,
            "input cross-correlation r_eu(τ) with the 99 % band",
        ),
    ] {
        let last = first + values.len() as i64 - 1;
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(50)
            .build_cartesian_2d((first as f64 - 0.5)..(last as f64 + 0.5), -1.05..1.05)
            .map_err(|e| plot_err(path, e))?;
        chart
            .configure_mesh()
            .x_desc("τ")
            .draw()
            .map_err(|e| plot_err(path, e))?;
        for b in [band, -band] {
            chart
                .draw_series(LineSeries::new(
                    [(first as f64 - 0.5, b), (last as f64 + 0.5, b)],
                    RED.stroke_width(1),
                ))
                .map_err(|e| plot_err(path, e))?;
        }
        chart
            .draw_series(values.iter().enumerate().map(|(i, v)| {
                let x = (first + i as i64) as f64;
                PathElement::new(vec![(x, 0.0), (x, *v)], BLUE.stroke_width(2))
            }))
            .map_err(|e| plot_err(path, e))?;
    }
    root.present().map_err(|e| plot_err(path, e))?;
    Ok(())
}
