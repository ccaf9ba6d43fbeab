//! Diagnosis: trace a failed validation to missing effects. Greedy forward selection over the
//! registered effect plugins: in each round every candidate (its settings tuned on the training
//! records by least squares) is added to the current structure, the structure is re-identified
//! (minimax LP on the training records) and scored on the held-out records by
//! `J = RMS_holdout · (1 + penalty)^k`, `k` = parameters added (coefficients plus tuned
//! settings). The best candidate is kept if it lowers `J`; candidates that explain the data
//! equally well (same `J` to 1e-6) are reported as equivalent and the one registered with the
//! higher priority is preferred. The evidence shown is the correlation of the current held-out
//! residual with each candidate's signature. The before/after comparison is a full
//! [`validate::assess`] of the declared and of the augmented structure at the same bound Δ.
use crate::effect::{effects, Effect, Record};
use crate::lip::{self, Structure};
use crate::spec::DiagSpec;
use crate::validate::{self, g, Assessment};
use crate::DiagError;
use serde::Serialize;

/// One candidate in one round.
#[derive(Debug, Clone, Serialize)]
pub struct Ranked {
    pub tag: String,
    pub label: String,
    pub settings: Vec<(String, f64)>,
    /// Parameters added (coefficients + tuned settings).
    pub added: usize,
    pub rms_holdout: f64,
    /// `J` with the penalty.
    pub penalized: f64,
    /// |correlation| of the current held-out residual with the candidate's signature.
    pub evidence: f64,
    /// Smallest consistent bound on the training records.
    pub dstar_train: f64,
    /// Least-squares RMS on the training records (equal for equal regressor spans).
    #[serde(skip)]
    pub ls_train: f64,
    /// Labels of candidates found equivalent (same training fit, same parameter count).
    pub equivalent: Vec<String>,
    /// Position in the registration order (priority).
    #[serde(skip)]
    pub order: usize,
}

/// One greedy round.
#[derive(Debug, Clone, Serialize)]
pub struct Round {
    /// `J` of the current structure.
    pub current: f64,
    pub ranking: Vec<Ranked>,
    /// Label of the effect added in this round (None: none lowered J; the search stopped).
    pub added: Option<String>,
    /// Candidates that did not apply to the data (e.g. a quantizer on unquantized data).
    pub not_applicable: Vec<String>,
}

/// The whole diagnosis.
#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    pub name: String,
    pub train: Vec<String>,
    pub holdout: Vec<String>,
    pub delta_how: String,
    pub rounds: Vec<Round>,
    /// Tags of the effects added, in order.
    pub added_tags: Vec<String>,
    pub before: Assessment,
    pub after: Assessment,
    #[serde(skip)]
    pub augmented: Option<DiagSpec>,
}

fn count_settings(e: &dyn Effect) -> usize {
    e.settings().len()
}

/// Training LS RMS of a structure (fast score for tuning).
fn ls_rms(s: &Structure, train: &[Record]) -> f64 {
    match s.regression(train) {
        Ok(reg) => {
            let th = lip::least_squares(&reg.phi, &reg.y);
            let r = lip::residuals(&reg.phi, &reg.y, &th);
            (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt()
        }
        Err(_) => f64::INFINITY,
    }
}

/// Held-out residual of a fit (concatenated) and the matching signature of an effect.
fn holdout_residual(f: &validate::Fit, hold: &[Record]) -> Vec<(usize, usize, f64)> {
    let mut out = Vec::new();
    for (ri, rec) in hold.iter().enumerate() {
        let (phi, y, st) = f.structure.rows_for(rec, &f.names);
        let r = lip::residuals(&phi, &y, &f.theta);
        out.extend(r.into_iter().enumerate().map(|(i, v)| (ri, st + i, v)));
    }
    out
}

fn corr(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    if n < 2 {
        return 0.0;
    }
    let ma = a[..n].iter().sum::<f64>() / n as f64;
    let mb = b[..n].iter().sum::<f64>() / n as f64;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (x, y) = (a[i] - ma, b[i] - mb);
        sab += x * y;
        saa += x * x;
        sbb += y * y;
    }
    if saa <= 0.0 || sbb <= 0.0 {
        0.0
    } else {
        (sab / (saa * sbb).sqrt()).abs()
    }
}

fn score(f: &validate::Fit, hold: &[Record]) -> f64 {
    let r = holdout_residual(f, hold);
    (r.iter()
        .map(|(_, _, v)| (v.abs() - f.extra).max(0.0).powi(2))
        .sum::<f64>()
        / r.len().max(1) as f64)
        .sqrt()
}

fn n_params(f: &validate::Fit) -> usize {
    f.names.len()
        + f.structure
            .effects
            .iter()
            .map(|e| count_settings(e.as_ref()))
            .sum::<usize>()
}

/// Run the diagnosis. `progress(done, total)` is called after each candidate.
pub fn diagnose(
    spec: &DiagSpec,
    train: &[Record],
    hold: &[Record],
    mut progress: impl FnMut(usize, usize),
) -> Result<Diagnosis, DiagError> {
    let pen = 1.0 + spec.diagnose.penalty;
    let base = validate::tune_declared(
        &Structure {
            base: spec.model.orders(),
            effects: spec.model.effects.clone(),
        },
        train,
    );
    let mut current = validate::fit(&base, train)?;
    let mut j_cur = score(&current, hold);
    let entries: Vec<_> = effects()
        .into_iter()
        .filter(|e| spec.diagnose.only.is_empty() || spec.diagnose.only.iter().any(|t| t == e.tag))
        .collect();
    let n_cand: usize = entries.iter().map(|e| (e.candidates)().len()).sum();
    let total = n_cand * spec.diagnose.max_effects.max(1);
    let mut done = 0;
    let mut rounds = Vec::new();
    let mut added_tags = Vec::new();
    for _ in 0..spec.diagnose.max_effects {
        let res = holdout_residual(&current, hold);
        let r: Vec<f64> = res.iter().map(|x| x.2).collect();
        let mut ranking: Vec<(Ranked, Option<validate::Fit>)> = Vec::new();
        let mut not_applicable = Vec::new();
        let mut order = 0usize;
        for entry in &entries {
            for cand in (entry.candidates)() {
                done += 1;
                order += 1;
                let present = current
                    .structure
                    .effects
                    .iter()
                    .any(|e| e.label() == cand.label());
                if present {
                    progress(done, total);
                    continue;
                }
                let orders = current.structure.orders();
                let cur_s = current.structure.clone();
                let tuned = cand.tune(train, &orders, &|e: &dyn Effect| {
                    let mut s = cur_s.clone();
                    s.effects.push(e.boxed());
                    ls_rms(&s, train)
                });
                let Some(tuned) = tuned else {
                    not_applicable.push(cand.label());
                    progress(done, total);
                    continue;
                };
                let mut s = current.structure.clone();
                s.effects.push(tuned.boxed());
                let f = match validate::fit(&s, train) {
                    Ok(f) => f,
                    Err(_) => {
                        not_applicable.push(cand.label());
                        progress(done, total);
                        continue;
                    }
                };
                let rms = score(&f, hold);
                let added = n_params(&f).saturating_sub(n_params(&current));
                // Signature on the held-out rows of the current residual.
                let sig: Vec<f64> = {
                    let o = current.structure.orders();
                    let sigs: Vec<Vec<f64>> = hold.iter().map(|h| tuned.signature(h, &o)).collect();
                    res.iter()
                        .map(|(ri, t, _)| sigs[*ri].get(*t).copied().unwrap_or(0.0))
                        .collect()
                };
                ranking.push((
                    Ranked {
                        tag: entry.tag.to_string(),
                        label: tuned.label(),
                        settings: tuned.settings(),
                        added,
                        rms_holdout: rms,
                        penalized: rms * pen.powi(added as i32),
                        evidence: corr(&r, &sig),
                        dstar_train: f.dstar_train,
                        ls_train: ls_rms(&f.structure, train),
                        equivalent: Vec::new(),
                        order,
                    },
                    Some(f),
                ));
                progress(done, total);
            }
        }
        ranking.sort_by(|a, b| {
            a.0.penalized
                .partial_cmp(&b.0.penalized)
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        // Candidates that fit the training data identically with as many parameters (the same
        // regressor span, e.g. viscous friction on the output velocity and one more pole) are
        // indistinguishable: the one registered with the higher priority is preferred, and the
        // others are named as equivalent to it.
        if let Some(top) = ranking.first().map(|r| r.0.clone()) {
            let same = |r: &Ranked| {
                r.added == top.added
                    && (r.dstar_train - top.dstar_train).abs() <= 1e-6 * top.dstar_train.abs()
                    && (r.ls_train - top.ls_train).abs() <= 1e-6 * top.ls_train.abs()
                    && r.penalized <= top.penalized * 1.05
            };
            let mut group: Vec<usize> = (0..ranking.len())
                .filter(|&i| same(&ranking[i].0))
                .collect();
            group.sort_by_key(|&i| ranking[i].0.order);
            if let Some(&lead) = group.first() {
                let eq: Vec<String> = group[1..]
                    .iter()
                    .map(|&i| ranking[i].0.label.clone())
                    .collect();
                let mut lead_item = ranking.remove(lead);
                lead_item.0.equivalent = eq;
                ranking.insert(0, lead_item);
            }
        }
        let accept = ranking
            .first()
            .map(|r| r.0.penalized < j_cur * (1.0 - 1e-3))
            .unwrap_or(false);
        let mut round = Round {
            current: j_cur,
            ranking: ranking.iter().map(|r| r.0.clone()).collect(),
            added: None,
            not_applicable,
        };
        if accept {
            let (best, f) = ranking.swap_remove(0);
            if let Some(f) = f {
                j_cur = best.rms_holdout;
                round.added = Some(best.label.clone());
                added_tags.push(best.tag.clone());
                current = f;
            }
        }
        let stop = round.added.is_none();
        rounds.push(round);
        if stop {
            break;
        }
    }
    progress(total, total);
    let before_fit = validate::fit(&base, train)?;
    let (delta, delta_how) = match spec.noise.bound {
        Some(d) => (d, "declared in the spec".to_string()),
        None => (
            spec.noise.estimate_margin * current.dstar_train,
            format!(
                "estimated: {} × the smallest bound for which the training records are consistent with the augmented model",
                spec.noise.estimate_margin
            ),
        ),
    };
    let before = validate::assess(&before_fit, train, hold, delta)?;
    let after = validate::assess(&current, train, hold, delta)?;
    let mut augmented = spec.clone();
    augmented.model.effects = current.structure.effects.clone();
    if let Some(n) = &spec.name {
        augmented.name = Some(format!("{n} (augmented by smid diagnose)"));
    }
    Ok(Diagnosis {
        name: spec.name.clone().unwrap_or_else(|| "smid".into()),
        train: train.iter().map(|r| r.name.clone()).collect(),
        holdout: hold.iter().map(|r| r.name.clone()).collect(),
        delta_how,
        rounds,
        added_tags,
        before,
        after,
        augmented: Some(augmented),
    })
}

fn pct(v: f64) -> String {
    format!("{:.2}%", 100.0 * v)
}

/// The before/after table (Markdown).
pub fn before_after_table(b: &Assessment, a: &Assessment) -> String {
    let width = |x: &Assessment| match x.mean_width {
        Some(w) => g(w),
        None => "empty (inconsistent)".into(),
    };
    let fals = |x: &Assessment| {
        if x.empty_on_train {
            "100% (feasible set empty)".to_string()
        } else {
            pct(x.falsified)
        }
    };
    let rows: Vec<(&str, String, String)> = vec![
        ("parameters", b.n_params.to_string(), a.n_params.to_string()),
        ("RMS residual (held-out)", g(b.rms), g(a.rms)),
        ("max abs residual (held-out)", g(b.max_abs), g(a.max_abs)),
        ("falsified share (held-out)", fals(b), fals(a)),
        (
            "smallest consistent Δ (train)",
            g(b.dstar_train),
            g(a.dstar_train),
        ),
        (
            "smallest consistent Δ (held-out)",
            g(b.dstar_holdout),
            g(a.dstar_holdout),
        ),
        ("noise bound Δ used", g(b.delta), g(a.delta)),
        ("mean a/b bound width at Δ", width(b), width(a)),
        (
            "residual autocorr lags outside 99%",
            format!("{}/{}", b.correlations.auto_outside, validate::MAX_LAG),
            format!("{}/{}", a.correlations.auto_outside, validate::MAX_LAG),
        ),
        (
            "input cross-corr lags outside 99%",
            format!(
                "{}/{}",
                b.correlations.cross_outside,
                2 * validate::MAX_LAG + 1
            ),
            format!(
                "{}/{}",
                a.correlations.cross_outside,
                2 * validate::MAX_LAG + 1
            ),
        ),
    ];
    let mut s = String::from("| quantity | before | after |\n|---|---|---|\n");
    for (k, x, y) in rows {
        s.push_str(&format!("| {k} | {x} | {y} |\n"));
    }
    s
}

/// The full report.
pub fn format_report(d: &Diagnosis) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "# smid diagnose: {}", d.name);
    let _ = writeln!(s, "train: {}", d.train.join(", "));
    let _ = writeln!(s, "held-out: {}", d.holdout.join(", "));
    let _ = writeln!(s, "noise bound: {}", d.delta_how);
    let _ = writeln!(s, "before: {}", d.before.model);
    let _ = writeln!(
        s,
        "validation before: {}",
        if validate::passes(&d.before) {
            "PASS"
        } else {
            "FAIL"
        }
    );
    for (i, r) in d.rounds.iter().enumerate() {
        let _ = writeln!(
            s,
            "\n## round {} (current held-out score {})",
            i + 1,
            g(r.current)
        );
        let _ = writeln!(
            s,
            "| rank | effect | settings | +params | held-out RMS | penalised | evidence abs(corr) |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|");
        for (k, c) in r.ranking.iter().enumerate() {
            let set = c
                .settings
                .iter()
                .map(|(n, v)| format!("{n}={}", g(*v)))
                .collect::<Vec<_>>()
                .join(" ");
            let _ = writeln!(
                s,
                "| {} | {}{} | {} | {} | {} | {} | {:.3} |",
                k + 1,
                c.label,
                if c.equivalent.is_empty() {
                    String::new()
                } else {
                    format!(" (≡ {})", c.equivalent.join(", "))
                },
                if set.is_empty() { "-".into() } else { set },
                c.added,
                g(c.rms_holdout),
                g(c.penalized),
                c.evidence
            );
        }
        if !r.not_applicable.is_empty() {
            let _ = writeln!(s, "not applicable: {}", r.not_applicable.join(", "));
        }
        let _ = writeln!(
            s,
            "-> {}",
            match &r.added {
                Some(l) => format!("added: {l}"),
                None => "nothing lowers the penalised held-out error: stop".into(),
            }
        );
    }
    let _ = writeln!(s, "\nafter: {}", d.after.model);
    let _ = writeln!(s, "\n{}", before_after_table(&d.before, &d.after));
    let _ = writeln!(
        s,
        "validation after: {}",
        if validate::passes(&d.after) {
            "PASS"
        } else {
            "FAIL"
        }
    );
    s
}
