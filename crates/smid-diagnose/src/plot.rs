//! SVG plots of validation and diagnosis: measured output with the guaranteed band widened by
//! Δ and the residual with ±Δ (first held-out record), the residual auto- and input
//! cross-correlations with their 99% bands, and held-out residuals before and after diagnosis.
use crate::validate::{Assessment, Correlations, Series};
use crate::DiagError;
use plotters::prelude::*;
use smid_core::plot::ensure_font;
use std::path::Path;

fn err(path: &Path, e: impl std::fmt::Display) -> DiagError {
    DiagError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    }
}

fn range(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for x in v.filter(|x| x.is_finite()) {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return (-1.0, 1.0);
    }
    let w = (hi - lo).max(1e-12 * (1.0 + lo.abs()));
    (lo - 0.08 * w, hi + 0.08 * w)
}

/// Output, band ± Δ and residual of one held-out record.
pub fn validation_svg(s: &Series, title: &str, path: &Path) -> Result<(), DiagError> {
    ensure_font();
    let root = SVGBackend::new(path, (1000, 720)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(path, e))?;
    let (top, bottom) = root.split_vertically(420);
    let t0 = *s.t.first().unwrap_or(&0) as f64;
    let t1 = (*s.t.last().unwrap_or(&1) as f64).max(t0 + 1.0);
    let band_pts = s.band.as_ref().map(|b| {
        b.iter()
            .map(|iv| (iv.lo - s.delta, iv.hi + s.delta))
            .collect::<Vec<_>>()
    });
    let (y0, y1) = range(
        s.y.iter().copied().chain(
            band_pts
                .iter()
                .flatten()
                .flat_map(|(a, b)| [*a, *b])
                .filter(|v| v.abs() < 1e3 * (1.0 + s.y.iter().fold(0.0f64, |m, x| m.max(x.abs())))),
        ),
    );
    let mut c = ChartBuilder::on(&top)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(80)
        .build_cartesian_2d(t0..t1, y0..y1)
        .map_err(|e| err(path, e))?;
    c.configure_mesh()
        .x_desc("sample")
        .y_desc("y")
        .draw()
        .map_err(|e| err(path, e))?;
    if let Some(bp) = &band_pts {
        let color = RGBColor(150, 190, 230);
        c.draw_series(s.t.iter().zip(bp).map(|(t, (a, b))| {
            let t = *t as f64;
            Rectangle::new([(t - 0.5, *a), (t + 0.5, *b)], color.mix(0.6).filled())
        }))
        .map_err(|e| err(path, e))?
        .label("guaranteed band ± Δ")
        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 15, y + 5)], color.filled()));
    }
    c.draw_series(LineSeries::new(
        s.t.iter().zip(&s.y).map(|(t, v)| (*t as f64, *v)),
        BLACK.stroke_width(1),
    ))
    .map_err(|e| err(path, e))?
    .label("measured y")
    .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], BLACK));
    c.configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()
        .map_err(|e| err(path, e))?;
    let (r0, r1) = range(
        s.residual
            .iter()
            .copied()
            .chain([s.delta, -s.delta].into_iter()),
    );
    let mut rc = ChartBuilder::on(&bottom)
        .caption("one-step residual and ±Δ", ("sans-serif", 16))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(80)
        .build_cartesian_2d(t0..t1, r0..r1)
        .map_err(|e| err(path, e))?;
    rc.configure_mesh()
        .x_desc("sample")
        .y_desc("residual")
        .draw()
        .map_err(|e| err(path, e))?;
    for d in [s.delta, -s.delta] {
        rc.draw_series(LineSeries::new([(t0, d), (t1, d)], RED.stroke_width(1)))
            .map_err(|e| err(path, e))?;
    }
    rc.draw_series(LineSeries::new(
        s.t.iter().zip(&s.residual).map(|(t, v)| (*t as f64, *v)),
        BLUE.stroke_width(1),
    ))
    .map_err(|e| err(path, e))?;
    root.present().map_err(|e| err(path, e))?;
    Ok(())
}

/// Residual autocorrelation and input cross-correlation with the 99% band.
pub fn correlation_svg(c: &Correlations, title: &str, path: &Path) -> Result<(), DiagError> {
    ensure_font();
    let root = SVGBackend::new(path, (900, 640)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(path, e))?;
    let (top, bottom) = root.split_vertically(320);
    let m = crate::validate::MAX_LAG as f64;
    let panels: [(&DrawingArea<SVGBackend, _>, &[f64], f64, String); 2] = [
        (
            &top,
            &c.auto,
            0.0,
            format!("{title}: residual autocorrelation r_ee(τ)"),
        ),
        (
            &bottom,
            &c.cross,
            -m,
            "cross-correlation r_eu(τ) with the input".to_string(),
        ),
    ];
    for (area, v, first, cap) in panels {
        let ymax = v
            .iter()
            .skip(if first == 0.0 { 1 } else { 0 })
            .fold(c.band, |a, b| a.max(b.abs()))
            * 1.2;
        let mut ch = ChartBuilder::on(area)
            .caption(cap, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d((first - 0.5)..(m + 0.5), -ymax..ymax)
            .map_err(|e| err(path, e))?;
        ch.configure_mesh()
            .x_desc("τ")
            .draw()
            .map_err(|e| err(path, e))?;
        for b in [c.band, -c.band] {
            ch.draw_series(LineSeries::new(
                [(first - 0.5, b), (m + 0.5, b)],
                RED.stroke_width(1),
            ))
            .map_err(|e| err(path, e))?;
        }
        ch.draw_series(v.iter().enumerate().map(|(k, r)| {
            let x = first + k as f64;
            Rectangle::new(
                [(x - 0.3, 0.0), (x + 0.3, r.clamp(-ymax, ymax))],
                BLUE.filled(),
            )
        }))
        .map_err(|e| err(path, e))?;
    }
    root.present().map_err(|e| err(path, e))?;
    Ok(())
}

/// Held-out residuals (first record) before and after diagnosis.
pub fn before_after_svg(b: &Assessment, a: &Assessment, path: &Path) -> Result<(), DiagError> {
    ensure_font();
    let (Some(sb), Some(sa)) = (b.series.first(), a.series.first()) else {
        return Ok(());
    };
    let root = SVGBackend::new(path, (1000, 640)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(path, e))?;
    let (top, bottom) = root.split_vertically(320);
    let (r0, r1) = range(
        sb.residual
            .iter()
            .chain(&sa.residual)
            .copied()
            .chain([sa.delta, -sa.delta]),
    );
    for (area, s, cap) in [
        (&top, sb, format!("before: {}", b.model)),
        (&bottom, sa, format!("after: {}", a.model)),
    ] {
        let t0 = *s.t.first().unwrap_or(&0) as f64;
        let t1 = (*s.t.last().unwrap_or(&1) as f64).max(t0 + 1.0);
        let mut ch = ChartBuilder::on(area)
            .caption(cap, ("sans-serif", 14))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(80)
            .build_cartesian_2d(t0..t1, r0..r1)
            .map_err(|e| err(path, e))?;
        ch.configure_mesh()
            .x_desc("sample (held-out)")
            .y_desc("residual")
            .draw()
            .map_err(|e| err(path, e))?;
        for d in [s.delta, -s.delta] {
            ch.draw_series(LineSeries::new([(t0, d), (t1, d)], RED.stroke_width(1)))
                .map_err(|e| err(path, e))?;
        }
        ch.draw_series(LineSeries::new(
            s.t.iter().zip(&s.residual).map(|(t, v)| (*t as f64, *v)),
            BLUE.stroke_width(1),
        ))
        .map_err(|e| err(path, e))?;
    }
    root.present().map_err(|e| err(path, e))?;
    Ok(())
}
