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
    let mut cols = read_table(file, &[u, y], part)?;
    let ys = cols.pop().expect("two columns");
    let us = cols.pop().expect("two columns");
    Ok((us, ys))
}

/// One numeric column of a CSV file (rows whose `part` column equals `part`, when given).
pub fn read_column(file: &Path, name: &str, part: Option<&str>) -> Result<Vec<f64>> {
    Ok(read_table(file, &[name], part)?.pop().expect("one column"))
}

/// The column headers of a CSV file (its first row).
pub fn read_header(file: &Path) -> Result<Vec<String>> {
    let data_err = |location: &str, message: String| SmidError::Data {
        file: file.to_path_buf(),
        location: location.into(),
        message,
    };
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_path(file)
        .map_err(|e| data_err("opening", e.to_string()))?;
    let headers = rdr
        .headers()
        .map_err(|e| data_err("header", e.to_string()))?;
    Ok(headers.iter().map(str::to_string).collect())
}

/// The numeric columns `names` of a CSV file (rows whose `part` column equals `part`, when
/// given); errors name the file, row and column.
pub fn read_table(file: &Path, names: &[&str], part: Option<&str>) -> Result<Vec<Vec<f64>>> {
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
    let idx: Vec<usize> = names.iter().map(|n| col(n)).collect::<Result<_>>()?;
    let ip = part.map(|_| col("part")).transpose()?;
    let mut out: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
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
        for ((o, &i), name) in out.iter_mut().zip(&idx).zip(names) {
            o.push(num(i, name)?);
        }
    }
    if out.first().is_some_and(|c| c.is_empty()) {
        return Err(data_err(
            "rows".into(),
            match part {
                Some(p) => format!("no data rows with `part` = `{p}` after the header"),
                None => "no data rows after the header".into(),
            },
        ));
    }
    Ok(out)
}

/// Sample indices `round(t / dt)` of a time column in seconds: finite, `>= 0` and on the
/// sampling grid (within 1e-6 of a sample); errors name the file, column and data row.
pub fn sample_indices(file: &Path, column: &str, t: &[f64], dt: f64) -> Result<Vec<usize>> {
    t.iter()
        .enumerate()
        .map(|(r, &v)| {
            let k = v / dt;
            if !(k >= 0.0 && k.is_finite() && (k - k.round()).abs() <= 1e-6 * k.abs().max(1.0)) {
                return Err(SmidError::Data {
                    file: file.to_path_buf(),
                    location: format!("data row {r}, column `{column}`"),
                    message: format!(
                        "expected a time >= 0 on the sampling grid (a multiple of dt = {dt} s), got {v}"
                    ),
                });
            }
            Ok(k.round() as usize)
        })
        .collect()
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
    if let Some(sc) = &c.step {
        return Err(SmidError::Data {
            file,
            location: format!("column `{sc}` (`step`)"),
            message: "a step column is read for steady-state points only (`plant.data.steady_state.step`); a dynamic record has none: remove it".into(),
        });
    }
    let (mut u, mut y) = read_columns(&file, &c.u, &c.y, c.part.as_deref())?;
    if let Some(tc) = &c.t {
        // A time column: the samples must be evenly spaced by the declared sample time.
        let t = read_column(&file, tc, c.part.as_deref())?;
        if let Some(k) = (1..t.len()).find(|&k| ((t[k] - t[k - 1]) - dt).abs() > 1e-6 * dt) {
            return Err(SmidError::Data {
                file: file.clone(),
                location: format!("data row {k}, column `{tc}`"),
                message: format!(
                    "samples must be evenly spaced by dt = {dt} s (`plant.data.dt`), got a step of {}",
                    t[k] - t[k - 1]
                ),
            });
        }
    }
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
