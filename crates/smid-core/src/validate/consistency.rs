//! The set-membership verdict on fresh records ([`consistency`]) and the smallest noise bound
//! at which the relaxation admits them ([`smallest_bound`]).
//!
//! The verdict is settled where it can be, and says so where it cannot:
//!
//! * **Proven**: a point of the identified set satisfies the training and the fresh
//!   equations together inside their noise bounds, certified by the exact LP at that fixed
//!   point: the certified simulation member, or the point phase 1 of the member search
//!   reaches from it on the joint records ([`members::certificate_on`]).
//! * **Consistent**: no contradiction found. Some cell's relaxation admits the joint
//!   equations with its rounds settled, and the identified set is known to be non-empty, or
//!   its own rounds settled. A relaxation is a necessary condition, so this is not a proof.
//! * **Undecided**: neither. The identified set may be empty (its stage-3 rounds stopped at
//!   their cap while a radius still shrank, and no certified member proves it non-empty), or
//!   the cells that admit the fresh data do so only with capped rounds, or the solver could
//!   not check the cells that no proof rejects ([`Undecided`] says which).
//! * **Falsified**: every cell is contradicted, a proof, with the first offending sample.
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use crate::members;
use crate::model::{ModelSet, Record};
use crate::outcome::{lift, Outcome};
use crate::pipeline::{relabel, stage2, stage3};
use crate::settings::Check;
use crate::stage3::certify::CERTIFIED;
use rayon::prelude::*;
use serde::Serialize;
use std::sync::atomic::{AtomicBool, Ordering};

/// The set-membership verdict on fresh records, in order of strength.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// A point of the set (the certified simulation member, or one found from it) satisfies
    /// the training and the fresh equations together: the fresh data are consistent with the
    /// set, proven.
    Proven,
    /// No contradiction found: a cell's relaxation admits the joint equations with settled
    /// rounds (a necessary condition, not a proof).
    Consistent,
    /// Neither proven nor falsified ([`Consistency::undecided`] says why).
    Undecided,
    /// Every cell is contradicted (a proof; [`Consistency::falsified_at`] says where).
    Falsified,
}

impl Verdict {
    /// The verdict in capitals, as the reports print it.
    pub fn word(self) -> &'static str {
        match self {
            Verdict::Proven | Verdict::Consistent => "CONSISTENT",
            Verdict::Undecided => "UNDECIDED",
            Verdict::Falsified => "FALSIFIED",
        }
    }
}

/// Why a verdict is undecided.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "cause", rename_all = "snake_case")]
pub enum Undecided {
    /// The identified set may be empty: its stage-3 rounds stopped at their cap while the
    /// last still shrank a radius by `shrink` (relative), and no certified member proves it
    /// non-empty.
    SetUnsettled {
        /// The last training round's largest relative shrinkage.
        shrink: f64,
    },
    /// The cells that admit the fresh data do so only with stage-3 rounds that stopped at
    /// their cap while the last still shrank a radius by `shrink`: more rounds may falsify
    /// them.
    Capped {
        /// The last round's largest relative shrinkage, over the admitting cells checked.
        shrink: f64,
    },
    /// `cells` cells could not be checked (LP solver trouble) and no other cell admits the
    /// fresh data.
    Unchecked {
        /// Cells the solver could not check.
        cells: usize,
    },
}

impl Undecided {
    /// Why, in words.
    pub fn describe(&self) -> String {
        match self {
            Undecided::SetUnsettled { shrink } => format!(
                "the identified set may be empty: its stage-3 rounds stopped at their cap while the last still shrank a radius by {:.1} %, and no certified member proves it non-empty; raise `method.options.max_rounds` to know",
                100.0 * shrink
            ),
            Undecided::Capped { shrink } => format!(
                "the cells admit the fresh data only with stage-3 rounds stopped at their cap (the last still shrank a radius by {:.1} %): more rounds may falsify them; raise `method.options.max_rounds` to know",
                100.0 * shrink
            ),
            Undecided::Unchecked { cells } => format!(
                "{cells} cell(s) could not be checked (LP solver trouble) and no other cell admits the fresh data"
            ),
        }
    }
}

/// The set-membership verdict on fresh records.
#[derive(Debug, Clone, Serialize)]
pub struct Consistency {
    /// The verdict.
    pub verdict: Verdict,
    /// The verdict is [`Verdict::Proven`] or [`Verdict::Consistent`].
    pub consistent: bool,
    /// Why the verdict is [`Verdict::Undecided`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub undecided: Option<Undecided>,
    /// Where the fresh data contradict every cell (the latest first offending sample).
    pub falsified_at: Option<Falsification>,
    /// Cells whose check the LP solver could not complete (never counted as contradicted).
    pub unchecked: usize,
}

impl Consistency {
    fn of(
        verdict: Verdict,
        undecided: Option<Undecided>,
        falsified_at: Option<Falsification>,
        unchecked: usize,
    ) -> Consistency {
        Consistency {
            verdict,
            consistent: matches!(verdict, Verdict::Proven | Verdict::Consistent),
            undecided,
            falsified_at,
            unchecked,
        }
    }

    /// The verdict in one line for a table: `CONSISTENT (proven)`, `CONSISTENT`,
    /// `UNDECIDED (cause)`, `FALSIFIED (record r, sample t)`.
    pub fn brief(&self) -> String {
        match (self.verdict, &self.undecided, &self.falsified_at) {
            (Verdict::Proven, ..) => "CONSISTENT (proven)".into(),
            (Verdict::Undecided, Some(u), _) => format!(
                "UNDECIDED ({})",
                match u {
                    Undecided::SetUnsettled { .. } => "set not settled",
                    Undecided::Capped { .. } => "rounds capped",
                    Undecided::Unchecked { .. } => "cells unchecked",
                }
            ),
            (Verdict::Falsified, _, Some(f)) => {
                format!("FALSIFIED (record {}, sample {})", f.record, f.sample)
            }
            (v, ..) => v.word().into(),
        }
    }
}

pub use crate::outcome::Falsification;

/// The cells of a model set from the centre outwards (the centre cells are the likeliest to
/// admit fresh data, which ends a consistency search early).
fn centre_out(model: &ModelSet) -> Vec<usize> {
    members::cells_from_centre(model)
}

/// A cell that the relaxation did not contradict.
struct Admitted {
    /// Stage 3's θ bounds of the joint equations, `None` when unbounded.
    bounds: Option<Vec<Interval>>,
    /// Stage 3's rounds stopped at their cap before they settled: the last round's largest
    /// relative shrinkage ([`crate::stage3::EivResult::unsettled`]).
    unsettled: Option<f64>,
}

/// One cell against the training records plus `fresh`: `Ok(admitted)` when the relaxation
/// does not contradict it, else where the fresh data contradict it (the first offending
/// sample with `locate`; a verdict alone does not look for it).
///
/// `warm`: a box known to hold every θ of the cell consistent with these records (the bounds
/// of the same cell at a larger fresh bound: the set only shrinks with the bound), intersected
/// with the model's prior for stage 3 to start from. A tighter start proves no contradiction
/// that is not there; it may prove one a wider start misses. (The cell's own training bounds
/// are not used so: a stage 3 restarted from its own bounds tightens further, and on the
/// measured examples proves their training records inconsistent at the estimated bound.)
fn check_cell(
    model: &ModelSet,
    k: usize,
    records: &[Record],
    locate: bool,
    warm: Option<&[Interval]>,
) -> Result<std::result::Result<Admitted, Falsification>> {
    let layout = model.layout()?;
    let nt = model.training.records.len();
    let c = &model.cells[k];
    let prior = warm.map(|w| match &layout.theta_prior {
        Some(p) if p.len() == w.len() => w
            .iter()
            .zip(p)
            .map(|(a, b)| a.intersect(b).unwrap_or(*a))
            .collect::<Vec<_>>(),
        _ => w.to_vec(),
    });
    let found = (|| {
        let sig = stage2(
            &model.model,
            layout,
            c.nonlinearity.as_ref(),
            &c.cell,
            records,
        )?;
        match stage3(
            &model.model,
            layout,
            &model.method,
            &sig,
            prior.as_deref(),
            locate,
        ) {
            Ok(r) => Ok(Admitted {
                bounds: Some(r.bounds),
                unsettled: r.unsettled,
            }),
            // Unbounded is not a contradiction.
            Err(SmidError::Unbounded { .. }) => Ok(Admitted {
                bounds: None,
                unsettled: None,
            }),
            Err(e) => Err(relabel(e, &sig)),
        }
    })();
    // `(record, sample)` in the joint records: a fresh record's index follows the training
    // records'. An inconsistency inside the training records (possible only when the training
    // set changed) is reported as record 0 and named in the detail.
    let falsified = match lift(found)? {
        Outcome::Consistent(admitted) => return Ok(Ok(admitted)),
        Outcome::Falsified(f) => f,
    };
    Ok(Err(if falsified.record < nt {
        Falsification {
            detail: format!(
                "in the training record {}: {}",
                falsified.record, falsified.detail
            ),
            record: 0,
            ..falsified
        }
    } else {
        Falsification {
            record: falsified.record - nt,
            ..falsified
        }
    }))
}

fn joint(model: &ModelSet, fresh: &[Record]) -> Vec<Record> {
    let mut records = model.training.records.clone();
    records.extend(fresh.iter().cloned());
    records
}

/// The verdict on the fresh records (with their own noise bounds): whether the model set
/// admits them (see the module doc). The relaxation's check first: some cell admits one `θ`
/// for the training and fresh equations together (cells in parallel, centre first, stopping
/// at the first that admits them). Unless it falsifies them, a point of the set is then
/// looked for from the certified simulation member and checked exactly on the joint records,
/// which proves the verdict where it holds.
pub fn consistency(model: &ModelSet, fresh: &[Record]) -> Result<Consistency> {
    consistency_with(model, fresh, true)
}

/// [`consistency`], where the relaxation's verdict is settled (CONSISTENT) searching for a
/// proving point only with `prove` (else checking the simulation member itself there); where
/// it would be undecided the search always runs.
pub fn consistency_with(model: &ModelSet, fresh: &[Record], prove: bool) -> Result<Consistency> {
    let clock = std::time::Instant::now();
    let relaxed = consistency_located(model, fresh, true)?;
    log::debug!(target: "smid::validate", "the relaxation's verdict {:?}: {:.2} s", relaxed.verdict, clock.elapsed().as_secs_f64());
    let clock = std::time::Instant::now();
    if relaxed.verdict == Verdict::Falsified {
        return Ok(relaxed);
    }
    let search = prove || relaxed.verdict != Verdict::Consistent;
    if proof(model, fresh, search)?.is_some_and(|s| s <= CERTIFIED) {
        log::debug!(target: "smid::validate", "proven: {:.2} s", clock.elapsed().as_secs_f64());
        return Ok(Consistency::of(
            Verdict::Proven,
            None,
            None,
            relaxed.unchecked,
        ));
    }
    // Not proven: a verdict resting on a set that may be empty is undecided.
    match model.undecided() {
        Some(shrink) if relaxed.verdict == Verdict::Consistent => Ok(Consistency::of(
            Verdict::Undecided,
            Some(Undecided::SetUnsettled { shrink }),
            None,
            relaxed.unchecked,
        )),
        _ => Ok(relaxed),
    }
}

/// The consistency measure of a point of the set on the joint records, found from the
/// certified simulation member (with `search`, by the member search's phase 1, else the member
/// itself): `None` without a certified member, or when it could not be checked (logged; a
/// proof not found is no verdict). Invalid member settings are an error.
fn proof(model: &ModelSet, fresh: &[Record], search: bool) -> Result<Option<f64>> {
    let Some(m) = model.simulation_member.as_ref().filter(|m| m.certified) else {
        return Ok(None);
    };
    let opts = model.method.member.check()?;
    let measure = members::certificate_on(model, m, &joint(model, fresh), &opts, search);
    log::debug!(target: "smid::validate", "a point from the simulation member on the joint records: {measure:?}");
    Ok(measure.unwrap_or_else(|e| {
        log::info!(target: "smid::validate", "the simulation member was not checked on the joint records: {e}");
        None
    }))
}

/// The relaxation's verdict ([`consistency`] without the member's proof and without the
/// identified set's own settling), with the first offending sample of each cell looked for
/// only with `locate`. It stops at the first cell that admits the fresh records; a cell
/// admitting them with settled rounds makes it [`Verdict::Consistent`], one with capped rounds
/// only [`Undecided::Capped`], and cells the solver could not check, with none admitting,
/// [`Undecided::Unchecked`].
fn consistency_located(model: &ModelSet, fresh: &[Record], locate: bool) -> Result<Consistency> {
    let records = joint(model, fresh);
    let found = AtomicBool::new(false);
    let results: Vec<Result<Option<std::result::Result<Admitted, Falsification>>>> =
        centre_out(model)
            .par_iter()
            .map(|&k| {
                if found.load(Ordering::Relaxed) {
                    return Ok(None);
                }
                let r = check_cell(model, k, &records, locate, None);
                if matches!(r, Ok(Ok(_))) {
                    found.store(true, Ordering::Relaxed);
                }
                r.map(Some)
            })
            .collect();
    let mut worst: Option<Falsification> = None;
    let mut unchecked = 0;
    let mut capped: Option<f64> = None;
    for r in results {
        let r = match r {
            Err(SmidError::Solver(_)) => {
                unchecked += 1;
                continue;
            }
            r => r?,
        };
        match r {
            None => {}
            Some(Ok(Admitted {
                unsettled: None, ..
            })) => return Ok(Consistency::of(Verdict::Consistent, None, None, 0)),
            Some(Ok(Admitted {
                unsettled: Some(g), ..
            })) => capped = Some(capped.map_or(g, |c| c.min(g))),
            Some(Err(f)) => {
                if worst
                    .as_ref()
                    .is_none_or(|w| (f.record, f.sample) > (w.record, w.sample))
                {
                    worst = Some(f);
                }
            }
        }
    }
    Ok(match (capped, unchecked) {
        (Some(shrink), _) => Consistency::of(
            Verdict::Undecided,
            Some(Undecided::Capped { shrink }),
            None,
            unchecked,
        ),
        (None, 0) => Consistency::of(Verdict::Falsified, None, worst, 0),
        (None, cells) => Consistency::of(
            Verdict::Undecided,
            Some(Undecided::Unchecked { cells }),
            None,
            cells,
        ),
    })
}

/// Below this fraction of the model's bound, a cell that still admits the fresh records is
/// taken to admit them at any bound ([`smallest_bound`] answers `(0, 0)`).
pub const VACUOUS_BELOW: f64 = 1e-9;

/// One cell's verdict at one bound of the [`smallest_bound`] search.
enum CellCheck {
    /// The cell admits the records: stage 3's θ bounds of the joint equations, `None` when
    /// unbounded (a box to start the same cell's check at a smaller bound from: the set only
    /// shrinks with the bound).
    Admits(Option<Vec<Interval>>),
    /// The records contradict the cell, or the solver could not check it.
    Refuses,
}

/// The smallest noise bound of the fresh records for which they are consistent with the
/// model set, as a bracket `[lo, hi]` (relative width `resolution`): the data provably
/// contradict every cell below `lo`, and some cell admits them at `hi`. `None` when even
/// `2^30` times the model's bound is inconsistent. `(0, 0)` when some cell admits them down
/// to [`VACUOUS_BELOW`] of the model's bound (0 itself is never checked): noise-free records
/// in a cell that holds the truth, or a cell whose stage-2 intervals (a sensor drift's
/// `offset + drift·t` over its cell) are wider than the noise, where the records test little;
/// the search stops at once instead of halving towards 0 cell after cell: a cell halved below
/// a thousandth of the bound without being contradicted (records consistent at the model's
/// own bound) is checked once at half that vacuous end, and if it admits the records there
/// the search ends. The cell's exact set only shrinks with the bound, so it admits them at
/// every bound the halving would still try; the check is a relaxation started from the last
/// admitting bound's box, so where it depends on that box, the halving (tightening the box
/// step by step) might have been contradicted in between and given a positive bound.
///
/// It is the smallest of the cells' own smallest bounds: the cells are visited centre first;
/// a cell is bisected only when it admits the data just below the best bound found so far
/// (one check otherwise), so most cells cost one stage-3 call. `consistent_at_delta`: the
/// verdict at the model's own bound when the caller has it (the check is not repeated).
pub fn smallest_bound(
    model: &ModelSet,
    fresh: &[Record],
    resolution: f64,
    consistent_at_delta: Option<bool>,
) -> Result<Option<(f64, f64)>> {
    let with = |d: f64| -> Vec<Record> {
        let recs: Vec<Record> = fresh.iter().map(|r| r.with_bound(d)).collect();
        joint(model, &recs)
    };
    let ok_set = |d: f64| -> Result<bool> {
        let recs: Vec<Record> = fresh.iter().map(|r| r.with_bound(d)).collect();
        Ok(consistency_located(model, &recs, false)?.verdict != Verdict::Falsified)
    };
    // A bound at which some cell admits the data.
    let d0 = model.delta;
    let mut lo_set = 0.0;
    let mut hi = d0;
    let mut steps = 0;
    let mut known = consistent_at_delta;
    while !match known.take() {
        Some(v) => v,
        None => ok_set(hi)?,
    } {
        steps += 1;
        if steps > 30 {
            return Ok(None);
        }
        lo_set = hi;
        hi *= 2.0;
    }
    let res = resolution.max(1e-6);
    // A cell's check. A cell the solver cannot check counts as contradicted here (its own
    // bound stays unknown).
    let check = |k: usize, d: f64, warm: Option<&[Interval]>| -> Result<CellCheck> {
        match check_cell(model, k, &with(d), false, warm) {
            Ok(Ok(admitted)) => Ok(CellCheck::Admits(admitted.bounds)),
            Ok(Err(_)) | Err(SmidError::Solver(_)) => Ok(CellCheck::Refuses),
            Err(e) => Err(e),
        }
    };
    // Each cell: can it go below the best bound so far? The candidates are checked in
    // parallel in chunks at the current target, then bisected one by one.
    let order = centre_out(model);
    for chunk in order.chunks(16) {
        let target = hi * (1.0 - res);
        if target <= lo_set {
            break;
        }
        let pass: Vec<Result<CellCheck>> =
            chunk.par_iter().map(|&k| check(k, target, None)).collect();
        for (&k, p) in chunk.iter().zip(pass) {
            let CellCheck::Admits(mut warm) = p? else {
                continue;
            };
            // Bisect this cell between the set's lower end and the target.
            let (mut a, mut b) = (lo_set, hi * (1.0 - res));
            if b <= a {
                continue;
            }
            // The best bound may have dropped since the chunk was checked: check again.
            if b < target {
                match check(k, b, warm.as_deref())? {
                    CellCheck::Admits(bounds) => warm = bounds,
                    CellCheck::Refuses => continue,
                }
            }
            let mut n = 0;
            let mut vacuous_asked = false;
            while b - a > res * b && n < 40 {
                let mid = 0.5 * (a + b);
                match check(k, mid, warm.as_deref())? {
                    CellCheck::Admits(bounds) => {
                        b = mid;
                        warm = bounds;
                    }
                    CellCheck::Refuses => a = mid,
                }
                n += 1;
                // Never contradicted down to a thousandth of the bound: heading for the vacuous
                // end. The cell's set only shrinks with the bound, so a cell admitting the
                // records below that end admits them at every bound the halving would still
                // try (as far as the check, a relaxation from `warm`, is monotone): one check
                // instead of twenty.
                if a == 0.0 && b < 1e-3 * d0 && !vacuous_asked {
                    vacuous_asked = true;
                    if let CellCheck::Admits(_) =
                        check(k, 0.5 * VACUOUS_BELOW * d0, warm.as_deref())?
                    {
                        return Ok(Some((0.0, 0.0)));
                    }
                }
                if a == 0.0 && b < VACUOUS_BELOW * d0 {
                    // Never contradicted down to a vanishing bound: reported as 0.
                    return Ok(Some((0.0, 0.0)));
                }
            }
            hi = b;
        }
    }
    Ok(Some(((hi * (1.0 - res)).max(lo_set), hi)))
}
