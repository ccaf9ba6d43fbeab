//! Reports of an identification: the parameter table printed by `smid run` (true value, center,
//! radius, lower, upper: the columns of Tables I-II), `result.json`, `data.csv` holding the
//! experiment's data so anyone can rerun on the same data, and the SVG plots.
use crate::error::{Result, SmidError};
use crate::inversion::InnerKind;
use crate::pipeline::Identification;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn fmt_opt(v: Option<f64>) -> String {
    v.map(|x| format!("{x:.6}")).unwrap_or_else(|| "-".into())
}

/// The parameter table.
pub fn table(id: &Identification) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: Δη = {:.3e}, SNR = {:.1} dB",
        id.name, id.delta_eta, id.snr_db
    );
    if let Some(f) = &id.data.filter {
        let _ = writeln!(
            s,
            "filter pole a = {}{}",
            f.pole,
            if f.trials.is_empty() {
                " (given)"
            } else {
                " (Appendix search)"
            }
        );
    }
    let _ = writeln!(
        s,
        "{:<6} {:>10} {:>10} {:>10} {:>10} {:>10} {:>6} {:>10}",
        "param", "true", "center", "radius", "lower", "upper", "inside", "member"
    );
    let member = id.model.simulation_member.as_ref();
    for p in id.parameters() {
        let value = member.and_then(|m| m.values.iter().find(|(n, _)| *n == p.name).map(|v| v.1));
        let _ = writeln!(
            s,
            "{:<6} {:>10} {:>10.6} {:>10.2e} {:>10.6} {:>10.6} {:>6} {:>10}",
            p.name,
            fmt_opt(p.truth),
            p.center,
            p.radius,
            p.lower,
            p.upper,
            match p.contains {
                Some(true) => "yes",
                Some(false) => "NO",
                None => "-",
            },
            fmt_opt(value)
        );
    }
    match member {
        Some(m) if m.certified => {
            let _ = writeln!(
                s,
                "member: the simulation member (certified consistent, cell {}): training free-run fit {:.2} % (the centre: {:.2} %)",
                m.cell, m.training_fit, m.centre_training_fit
            );
        }
        Some(m) => {
            let _ = writeln!(
                s,
                "member: no point certified consistent within the search budget (the exact LP at fixed θ found none); the best training free run within the outer bounds of cell {} stands in, NOT certified: training free-run fit {:.2} % (the centre: {:.2} %)",
                m.cell, m.training_fit, m.centre_training_fit
            );
        }
        None => {
            let _ = writeln!(
                s,
                "member: no point certified consistent within the search budget (the exact LP at fixed θ found none); the centre (not certified) stands in for free runs"
            );
        }
    }
    if let Some(e) = member.and_then(|m| m.within) {
        let _ = writeln!(
            s,
            "member: its free run lies within {e:.3e} of every training sample, so the model's exact smallest consistent bound is at most {e:.3e} (a bound stage 3's relaxation falsifies is a lower end)"
        );
    }
    if let Some(w) = id.model.unsettled_warning() {
        let _ = writeln!(s, "warning: {w}");
    }
    let count = |k: InnerKind| id.inner.iter().filter(|b| b.kind == k).count();
    let (inverted, mirrored) = (count(InnerKind::Inverted), count(InnerKind::Mirrored));
    let signs = if mirrored > 0 {
        format!(" ({mirrored} more up to their sign, decided by the sign search)")
    } else {
        String::new()
    };
    let _ = writeln!(
        s,
        "inner signal: {inverted} of {} samples inverted{signs}; {} equations in stage 3",
        id.inner.len(),
        id.equations.len()
    );
    if !id.model.dims.is_empty() {
        let m = &id.model;
        let _ = writeln!(
            s,
            "branch and bound over {}: {} cells evaluated, {} discarded, {} kept{}",
            m.dims
                .iter()
                .map(|d| format!("{} ∈ [{:.3e}, {:.3e}]", d.name, d.prior.lo, d.prior.hi))
                .collect::<Vec<_>>()
                .join(", "),
            m.search.evaluated,
            m.search.discarded,
            m.cells.len(),
            if m.search.budget_stopped {
                " (the cell budget stopped the bisection: the hull holds, looser)"
            } else {
                ""
            }
        );
        if m.search.refined > 0 {
            let _ = writeln!(
                s,
                "{} undecided cell(s) halved further (stage 3 unbounded or a solver failure over them)",
                m.search.refined
            );
        }
        if !m.search.unbounded.is_empty() {
            let _ = writeln!(
                s,
                "{} cell(s) left without a finite θ bound when the refinement budget was spent \
                 (raise method.cells.max_leaves): every θ bound is infinite; the bounds of the \
                 bisected parameters hold. First: {} ({})",
                m.search.unbounded.len(),
                m.search.unbounded[0].cell,
                m.search.unbounded[0].detail
            );
        }
        if let Some(screen) = m.search.screened_by {
            let _ = writeln!(
                s,
                "the cells' θ bounds are `{}`'s: `{}` starts from them and cannot bound the cells \
                 they leave unbounded, so it cannot change a θ bound, and was not run",
                screen.name(),
                m.method.eiv.name()
            );
        }
    }
    if let Some(all) = id.all_contain_truth() {
        let _ = writeln!(
            s,
            "truth inside every bound: {}",
            if all { "yes" } else { "NO" }
        );
    }
    s
}

/// `result.json` content, stamped with its format ([`crate::output::OutputKind::Result`]); every
/// field is described in `docs/reference/outputs.md`.
pub fn result_json(id: &Identification) -> serde_json::Value {
    let kind = crate::output::OutputKind::Result;
    serde_json::json!({
        "format": kind.tag(),
        "format_version": kind.version(),
        "smid_version": env!("CARGO_PKG_VERSION"),
        "name": id.name,
        "consistent": true,
        "delta_eta": id.delta_eta,
        "snr_db": id.snr_db,
        "filter": id.data.filter,
        "parameters": id.parameters(),
        "truth_in_nonlinearity_set": id.truth_in_nonlinearity_set,
        "inner_signal": {
            "samples": id.inner.len(),
            "inverted": id.inner.iter().filter(|b| b.kind == InnerKind::Inverted).count(),
            "mirrored": id.inner.iter().filter(|b| b.kind == InnerKind::Mirrored).count(),
            "truth_violations": id.inner_violations,
            "bounds": id.inner,
        },
        "equations": id.equations,
        "regions": id.set().regions(None),
        "model": id.model,
    })
}

fn cell(v: Option<f64>) -> String {
    v.map(|x| format!("{x:.17e}")).unwrap_or_default()
}

/// `data.csv`: rows `part,index,t,u,y,w,x,step` for the steady-state samples (`part = steady`,
/// `u = ū`, `y = ȳ`, `step` the height of the step that led to the point) and the dynamic
/// records (`part = dynamic` for the first, `dynamic_k` for record `k > 0`; no step). Rerun
/// with a `plant.data` spec selecting `part: steady` (with `step: step`) and `part: dynamic`.
pub fn data_csv(id: &Identification) -> String {
    let mut s = String::from("part,index,t,u,y,w,x,step\n");
    let d = &id.data;
    let none = crate::nonlinearity::SteadyStateData::default();
    for p in &d.steady.as_ref().unwrap_or(&none).points {
        let (t, w) = match &d.steady_record {
            Some(r) => {
                let t = r.samples[p.index].0;
                (t.to_string(), Some(r.w[t]))
            }
            None => (String::new(), None),
        };
        let _ = writeln!(
            s,
            "steady,{},{},{:.17e},{:.17e},{},,{:.17e}",
            p.index,
            t,
            p.u,
            p.y,
            cell(w),
            p.step_height()
        );
    }
    for (k, r) in d.records.iter().enumerate() {
        let part = if k == 0 {
            "dynamic".to_string()
        } else {
            format!("dynamic_{k}")
        };
        for t in 0..r.u.len() {
            let w = r.w.as_ref().map(|w| w[t]);
            let x = r.x.as_ref().map(|x| x[t]);
            let _ = writeln!(
                s,
                "{part},{t},{t},{:.17e},{:.17e},{},{},",
                r.u[t],
                r.y[t],
                cell(w),
                cell(x)
            );
        }
    }
    s
}

fn write(path: &Path, text: &str) -> Result<PathBuf> {
    std::fs::write(path, text).map_err(|source| SmidError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(path.to_path_buf())
}

/// Write `result.json`, `data.csv` and the SVG plots into `dir`; returns the files written.
pub fn write_all(id: &Identification, dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|source| SmidError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut out = vec![
        write(
            &dir.join("result.json"),
            &serde_json::to_string_pretty(&result_json(id)).unwrap_or_default(),
        )?,
        write(&dir.join("data.csv"), &data_csv(id))?,
    ];
    let truth: Option<Vec<f64>> = id
        .set()
        .parameters()
        .iter()
        .map(|b| id.parameter(&b.name).and_then(|p| p.truth))
        .collect();
    for region in id.set().regions(truth.as_deref()) {
        let path = dir.join(format!("region_{}.svg", region.name));
        crate::plot::region_svg(&region, &path)?;
        out.push(path);
    }
    let path = dir.join("inner_signal.svg");
    let x = id.data.records.first().and_then(|r| r.x.as_deref());
    crate::plot::inner_svg(&id.inner, x, &path)?;
    out.push(path);
    Ok(out)
}
