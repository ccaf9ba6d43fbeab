//! Loading measured data from CSV files by column name, with errors that name the file, the
//! row and the column. Nothing is silently dropped: a NaN or non-numeric cell is an error.
use crate::error::{Result, SmidError};
use std::path::Path;

/// Columns `u` and `y` (rows whose `part` column equals `part`, when given).
pub fn read_columns(
    file: &Path,
    u: &str,
    y: &str,
    part: Option<&str>,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let data_err = |location: String, message: String| SmidError::Data {
        file: file.to_path_buf(),
        location,
        message,
    };
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_path(file)
        .map_err(|e| data_err("opening".into(), e.to_string()))?;
    let headers = rdr
        .headers()
        .map_err(|e| data_err("header".into(), e.to_string()))?
        .clone();
    let col = |name: &str| {
        headers.iter().position(|h| h == name).ok_or_else(|| {
            data_err(
                "header".into(),
                format!(
                    "no column `{name}`; columns are: {}",
                    headers.iter().collect::<Vec<_>>().join(", ")
                ),
            )
        })
    };
    let (iu, iy) = (col(u)?, col(y)?);
    let ip = part.map(|_| col("part")).transpose()?;
    let (mut us, mut ys) = (Vec::new(), Vec::new());
    for (r, rec) in rdr.records().enumerate() {
        let row = r + 2; // 1-based, after the header
        let rec = rec.map_err(|e| data_err(format!("row {row}"), e.to_string()))?;
        if let (Some(ip), Some(p)) = (ip, part) {
            if rec.get(ip) != Some(p) {
                continue;
            }
        }
        let num = |i: usize, name: &str| -> Result<f64> {
            let cell = rec.get(i).unwrap_or("");
            let v: f64 = cell.parse().map_err(|_| {
                data_err(
                    format!("row {row}, column `{name}`"),
                    format!("expected a number, got `{cell}`"),
                )
            })?;
            if !v.is_finite() {
                return Err(data_err(
                    format!("row {row}, column `{name}`"),
                    format!("expected a finite number, got `{cell}`"),
                ));
            }
            Ok(v)
        };
        us.push(num(iu, u)?);
        ys.push(num(iy, y)?);
    }
    Ok((us, ys))
}

/// One dynamic record named by a spec: columns `u`, `y` of `c.file` (relative to `base`), the
/// rows `c.rows` (`[start, end)` of the data rows after `part`), block means of `c.decimate`
/// samples; sample time `dt · decimate`; constant noise bound `delta`. Errors name the file.
pub fn read_record(
    base: &Path,
    c: &crate::spec::CsvColumns,
    delta: f64,
    dt: f64,
) -> Result<crate::model::Record> {
    let file = base.join(&c.file);
    let (mut u, mut y) = read_columns(&file, &c.u, &c.y, c.part.as_deref())?;
    let mut name = file
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| file.display().to_string());
    if let Some([a, b]) = c.rows {
        if !(a < b && b <= u.len()) {
            return Err(SmidError::Data {
                file: file.clone(),
                location: "rows".into(),
                message: format!(
                    "expected 0 <= start < end <= {} (the data rows), got [{a}, {b}]",
                    u.len()
                ),
            });
        }
        u = u[a..b].to_vec();
        y = y[a..b].to_vec();
        name = format!("{name} rows {a}..{b}");
    }
    decimated(&file, name, u, y, c.decimate.unwrap_or(1), delta, dt)
}

/// A measured record from columns, with the spec's `decimate`: block means of `k` samples
/// (sample time `dt·k`; a last incomplete block is left out and the name says so). `file`
/// names the origin in errors.
pub fn decimated(
    file: &Path,
    mut name: String,
    mut u: Vec<f64>,
    mut y: Vec<f64>,
    k: usize,
    delta: f64,
    dt: f64,
) -> Result<crate::model::Record> {
    if k == 0 || k > u.len() {
        return Err(SmidError::Data {
            file: file.to_path_buf(),
            location: "decimate".into(),
            message: format!(
                "expected 1 <= decimate <= {} (the samples), got {k}",
                u.len()
            ),
        });
    }
    if k > 1 {
        let rest = u.len() % k;
        if rest > 0 {
            name = format!("{name} (last {rest} raw samples left out)");
        }
        let mean = |v: &[f64]| -> Vec<f64> {
            v.chunks_exact(k)
                .map(|c| c.iter().sum::<f64>() / k as f64)
                .collect()
        };
        u = mean(&u);
        y = mean(&y);
        name = format!("{name}, means of {k}");
    }
    Ok(crate::model::Record::measured(
        name,
        u,
        y,
        delta,
        dt * k as f64,
    ))
}
