//! `smid reproduce paper --methods ...`: the stage-3 methods side by side on the Section 6
//! example. For each `n_bit` and seed the pipeline runs once (stages 1-2, the paper's classical
//! stage 3), then every requested stage-3 method bounds θ from the same inner-signal bounds. The
//! table gives per method and `n_bit` the median radius per parameter and its ratio to the
//! exact set measured by `exact-grid` (to its inner hull, which lies inside the exact set, so the
//! ratio shown is an upper bound of the true ratio), and how many runs contained the truth.
use smid_core::interval::Interval;
use smid_core::nonlinearity::Structure;
use smid_core::pipeline;
use smid_core::spec::EivMethod;
use smid_core::stage3::exact_grid::{self, ExactOptions};
use smid_core::stage3::{self, theta_names, EivProblem, EivResult};
use smid_core::Result;
use std::fmt::Write as _;
use std::path::Path;

/// Medians over seeds of one parameter, one method, one bit count.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MethodRow {
    /// Encoder resolution `n_bit` of the run (sets the noise bound).
    pub bits: u32,
    /// The stage-3 method's name (`classical`, `shared`, `sdp`, `exact-grid`).
    pub method: String,
    /// The parameter's name (`a1`, `b1`, ...).
    pub name: String,
    /// Median over seeds of the radius of the parameter's bound.
    pub median_radius: f64,
    /// For `exact-grid`: median radius of the inner hull (consistent points of the exact set).
    pub median_inner_radius: Option<f64>,
    /// Runs whose bound on this parameter contains the truth.
    pub contained: usize,
    /// Runs (seeds) behind the medians.
    pub runs: usize,
}

/// The whole comparison.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Comparison {
    /// Seeds run per bit count.
    pub seeds: usize,
    /// The compared methods, in column order.
    pub methods: Vec<String>,
    /// One row per bit count, method and parameter.
    pub rows: Vec<MethodRow>,
    /// Runs that ended in an error: (bits, seed, method, message).
    pub errors: Vec<(u32, u64, String, String)>,
}

fn median(mut v: Vec<f64>) -> f64 {
    crate::reproduce::median(&mut v)
}

/// Bit counts of the comparison.
pub const COMPARE_BITS: [u32; 3] = [12, 10, 8];

/// Stage 3 of `method` on the same data; for `exact-grid` also the inner hull.
fn stage3(
    method: EivMethod,
    prob: &EivProblem,
) -> Result<(EivResult, Option<Vec<Option<Interval>>>)> {
    match method {
        EivMethod::ExactGrid => {
            let shared = stage3::solve(EivMethod::Shared, prob)?;
            let ex = exact_grid::solve_from(prob, &shared, &ExactOptions::default(), || {})?;
            Ok((ex.to_eiv(), Some(ex.inner)))
        }
        m => Ok((stage3::solve(m, prob)?, None)),
    }
}

/// Compare `methods` on `bits` x seeds `1..=seeds`, calling `tick` after each (bits, seed).
pub fn compare(
    seeds: usize,
    bits: &[u32],
    methods: &[EivMethod],
    mut tick: impl FnMut(),
) -> Result<Comparison> {
    let mut rows = Vec::new();
    let mut errors = Vec::new();
    for &b in bits {
        // results[method][param] = (radii, inner radii, contained)
        let mut acc: Vec<Vec<(Vec<f64>, Vec<f64>, usize)>> = Vec::new();
        let mut names = Vec::new();
        for seed in 1..=seeds as u64 {
            let spec = crate::reproduce::paper_spec(b, seed)?;
            let id = match pipeline::run(&spec, Path::new("."))
                .and_then(smid_core::Outcome::into_result)
            {
                Ok(id) => id,
                Err(e) => {
                    errors.push((b, seed, "pipeline".into(), e.to_string()));
                    tick();
                    continue;
                }
            };
            let (na, nb) = (spec.model.na, spec.model.nb);
            names = theta_names(na, nb);
            if acc.is_empty() {
                acc = vec![vec![(vec![], vec![], 0); names.len()]; methods.len()];
            }
            let input: Vec<Interval> = id.data.records[0]
                .u
                .iter()
                .map(|&v| Interval::new(v, v))
                .collect();
            if spec.model.structure != Structure::Wiener {
                errors.push((
                    b,
                    seed,
                    "all".into(),
                    "comparison needs a Wiener spec".into(),
                ));
                continue;
            }
            let fixed = spec.fixed_theta()?;
            for (mi, &m) in methods.iter().enumerate() {
                let prob = EivProblem {
                    locate: true,
                    na,
                    nb,
                    fixed: fixed.clone(),
                    unit_gain: spec.model.unit_gain,
                    output: &id.inner,
                    input: &input,
                    use_band_samples: spec
                        .method
                        .band_samples
                        .unwrap_or(m != EivMethod::Classical),
                    lagged: None,
                    extra: &[],
                    prior: None,
                };
                match stage3(m, &prob) {
                    Ok((r, inner)) => {
                        for (k, name) in names.iter().enumerate() {
                            let truth = id.parameter(name).and_then(|p| p.truth);
                            let cell = &mut acc[mi][k];
                            cell.0.push(r.bounds[k].radius());
                            if let Some(Some(i)) = inner.as_ref().map(|v| v[k]) {
                                cell.1.push(i.radius());
                            }
                            if truth.is_some_and(|t| r.bounds[k].contains(t)) {
                                cell.2 += 1;
                            }
                        }
                    }
                    Err(e) => errors.push((b, seed, m.name().into(), e.to_string())),
                }
            }
            tick();
        }
        for (mi, &m) in methods.iter().enumerate() {
            for (k, name) in names.iter().enumerate() {
                let (r, inner, c) = acc[mi][k].clone();
                rows.push(MethodRow {
                    bits: b,
                    method: m.name().into(),
                    name: name.clone(),
                    median_radius: median(r),
                    median_inner_radius: (!inner.is_empty()).then(|| median(inner)),
                    contained: c,
                    runs: seeds,
                });
            }
        }
    }
    Ok(Comparison {
        seeds,
        methods: methods.iter().map(|m| m.name().to_string()).collect(),
        rows,
        errors,
    })
}

/// The radius table: one line per n_bit and parameter, one column group per method.
pub fn format_comparison(c: &Comparison) -> String {
    let mut s = String::new();
    let has_exact = c.methods.iter().any(|m| m == "exact-grid");
    let _ = writeln!(
        s,
        "Stage-3 methods on the Section 6 example; median radius over {} seeds{}",
        c.seeds,
        if has_exact {
            "; ratio = radius / exact-set radius (inner hull of consistent points, so the ratio is an upper bound of the true one; the exact-grid column's own radius is its guaranteed outer hull)"
        } else {
            ""
        }
    );
    let mut head = format!("{:>5} {:>5}", "n_bit", "param");
    for m in &c.methods {
        head += &format!(" {:>10} {:>6}", m, if has_exact { "ratio" } else { "" });
    }
    if has_exact {
        head += &format!(" {:>11}", "exact inner");
    }
    head += &format!(" {:>10}", "contained");
    let _ = writeln!(s, "{head}");
    let mut bits: Vec<u32> = c.rows.iter().map(|r| r.bits).collect();
    bits.dedup();
    for b in bits {
        let names: Vec<String> = {
            let mut v: Vec<String> = Vec::new();
            for r in c.rows.iter().filter(|r| r.bits == b) {
                if !v.contains(&r.name) {
                    v.push(r.name.clone());
                }
            }
            v
        };
        for name in names {
            let get = |m: &str| {
                c.rows
                    .iter()
                    .find(|r| r.bits == b && r.method == m && r.name == name)
            };
            let exact = get("exact-grid").and_then(|r| r.median_inner_radius);
            if get(c.methods[0].as_str()).is_some_and(|r| r.median_radius == 0.0) {
                continue; // a fixed coefficient
            }
            let mut line = format!("{b:>5} {name:>5}");
            let mut contained = Vec::new();
            for m in &c.methods {
                match get(m) {
                    Some(r) => {
                        let ratio = exact
                            .filter(|e| *e > 0.0)
                            .map(|e| format!("{:.2}", r.median_radius / e))
                            .unwrap_or_default();
                        line += &format!(" {:>10.2e} {:>6}", r.median_radius, ratio);
                        contained.push(format!("{}", r.contained));
                    }
                    None => line += &format!(" {:>10} {:>6}", "-", ""),
                }
            }
            if has_exact {
                line += &format!(
                    " {:>11}",
                    exact.map(|e| format!("{e:.2e}")).unwrap_or("-".into())
                );
            }
            let runs = get(c.methods[0].as_str()).map(|r| r.runs).unwrap_or(0);
            line += &format!(" {:>10}", format!("{}/{runs}", contained.join(",")));
            let _ = writeln!(s, "{line}");
        }
    }
    if !c.errors.is_empty() {
        let _ = writeln!(s, "runs that ended in an error:");
        for (b, seed, m, e) in &c.errors {
            let _ = writeln!(s, "  n_bit {b}, seed {seed}, {m}: {e}");
        }
    }
    s
}
