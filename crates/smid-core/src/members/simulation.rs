//! The simulation member: the member of the identified set whose free run (eqs 1-2
//! with the chain's blocks and the effects) fits the training records best, in the
//! least-squares norm: the sum of squared free-run errors over the training records after the
//! warm-start samples (what the fit % of MATLAB's `compare` ranks).
//!
//! The search keeps to points **certified** consistent. Per cell (the central cell first), the
//! nonlinearity and bisected parameters are put at a point of the cell's set, stage 2 bounds
//! the inner signal at that point (eqs 20-27), and a `θ` counts only when the exact LP at
//! fixed `θ` ([`consistency_at`], as exact-grid certifies its inner hull) proves the equations
//! hold inside the stage-2 boxes. Nelder-Mead (argmin) first reaches a certified `θ` from the
//! centre's (minimising the consistency measure), then minimises the free-run error with the
//! uncertified points as an extreme barrier, so the member it returns is certified. With
//! `model.feedback` the certificate is the one of stage 3's problem (each sample's inner value
//! and its measured past output two variables): the member is a point of the identified set,
//! not necessarily a loop that stays within the bound of every record.
//!
//! The search's spaces and measures are in `space`, its certified phases in `certified`, the
//! uncertified stand-in in `uncertified`, and the local searches (Nelder-Mead,
//! Levenberg-Marquardt) in `optimise`.
use super::{cells_from_centre, central_values, inner_estimate, point};
use crate::error::Result;
use crate::model::{CellSet, ModelSet, SimulationMember};
use crate::stage3::certify::{best_at_a, consistency_at, extreme_at_a, CERTIFIED};
use space::{split_values, CellSpace, Search};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

mod certified;
mod optimise;
mod space;
mod uncertified;

pub(crate) use optimise::nelder_mead;

use crate::settings::Checked;
/// How hard the search tries: the spec's `method.member` ([`crate::spec::MemberSpec`]).
pub use crate::spec::MemberSpec as Options;

/// The simulation member of `set` (see the module doc). When no certified point is found in
/// the cells tried, the best free run over the outer bounds of any probed cell, marked
/// `certified: false`; `None` only when even that fails (the centre then stands in). The cells are ranked by
/// the phase-1 measure at their centres (the nearest `opts.probe` to the central cell are
/// probed) and the best `opts.cells` are searched, in that order; when the best-ranked cell
/// gives no certified point, the search stops there.
pub fn simulation_member(
    set: &ModelSet,
    opts: &Checked<Options>,
) -> Result<Option<SimulationMember>> {
    simulation_member_seeded(set, opts, &[])
}

/// [`simulation_member`] that also searches from each of `seeds` (points given by name, as a
/// member's `values`: a simulator found before, at a smaller bound): in the cell that holds
/// the seed's nonlinearity and bisected parameters, from the seed itself where it is
/// certified, else from the certified point nearest it. A seed no cell holds is passed over.
pub fn simulation_member_seeded(
    set: &ModelSet,
    opts: &Checked<Options>,
    seeds: &[Vec<(String, f64)>],
) -> Result<Option<SimulationMember>> {
    if !set.cells.iter().any(|c| c.bounded()) || !opts.search {
        return Ok(None);
    }
    let (search, spaces, centre_values, centre_fit) = prepared(set, opts)?;
    let searched: Vec<&CellSpace> = spaces
        .iter()
        .take(opts.cells.max(1))
        .map(|(_, sp)| sp)
        .collect();
    let found = searched_cells(&search, &searched, opts);
    let (found, quick_known) = from_free_runs(&search, &searched, opts, &centre_values, found);
    let (seeded_spaces, seeded) = seeded_members(set, &search, opts, seeds)?;
    let mut best: Option<(f64, SimulationMember)> = None;
    for (e2, m) in seeded {
        if best.as_ref().is_none_or(|(b, _)| e2 < *b) {
            best = Some((e2, m));
        }
    }
    for (sp, f) in searched.iter().zip(found) {
        log::debug!(target: "smid::members", "cell {}: {}", sp.k, if f.is_some() { "certified member" } else { "nothing certified" });
        if let Some((e2, m)) = f {
            if best.as_ref().is_none_or(|(b, _)| e2 < *b) {
                best = Some((e2, m));
            }
        }
    }
    if best.is_none() {
        // Nothing certified: the best free run over the outer bounds of the probed cells
        // stands in (marked not certified), so a candidate whose centre diverges is judged by
        // a point that simulates, not by its centre. (The ranking above is by nearness to a
        // certificate, not by simulation, and a saturation level's cells differ in how they
        // simulate: every probed cell is tried; free runs only, one LP each for its report.)
        //
        // Every probed cell gets the quick search (one Nelder-Mead run per start); a full
        // search then refines the best `opts.cells` of them with both local searches
        // ([`Search::uncertified_from`]). Refining every probed cell (up to 64) would multiply
        // the cost of an any-record trial several times over. A refined cell keeps the better
        // of its two points, so the ranking only decides where the effort goes.
        //
        // The cells are independent, so both passes run side by side, each kept in the
        // cells' order (the stand-in does not depend on the thread timing).
        best = best_free_run_over(&search, &spaces, opts, &centre_values, &quick_known);
    }
    if let Some((_, m)) = best.as_mut().filter(|(_, m)| opts.spread && m.certified) {
        let sp = spaces
            .iter()
            .map(|(_, sp)| sp)
            .chain(&seeded_spaces)
            .find(|sp| sp.k == m.cell);
        if let Some(sp) = sp {
            let (g, th) = split_values(&search, sp, &m.values);
            m.envelope = search.spread_members(sp, &g, &th);
        }
    }
    Ok(best.map(|(_, mut m)| {
        m.centre_training_fit = centre_fit;
        m.evaluations = search.evaluations.load(Relaxed);
        m.within = super::training_within(set, &m.values).unwrap_or_else(|e| {
            log::warn!(target: "smid::members", "the member's distance from the training records was not computed: {e}");
            None
        });
        m
    }))
}

/// The certified member of each searched cell, in rank order. A ranking search
/// ([`Options::gives_up_early`]) goes one cell at a time and stops after a best-ranked cell
/// that ended far from a certified point; a full search searches the cells side by side.
fn searched_cells(
    search: &Search,
    searched: &[&CellSpace],
    opts: &Options,
) -> Vec<Option<(f64, SimulationMember)>> {
    if opts.gives_up_early() {
        // A ranking search (no spread: the diagnosis's candidates) goes one cell at a time:
        // when its best-ranked cell ended far from a certified point (measure above `far`) it
        // does not search the lower-ranked ones (on the 12-bit diagnoses no such search
        // certified a later cell, and each costs as much as the first).
        let mut out = Vec::new();
        for sp in searched {
            let (f, last) = search.search(sp, opts);
            let stop = f.is_none() && out.iter().all(Option::is_none) && last > opts.far;
            out.push(f);
            if stop {
                break;
            }
        }
        out
    } else {
        // A full search goes on (on examples/hammerstein-wiener.yaml the best-ranked cell's
        // first run ends at 2.1 and never certifies, and the next cell does); its cells are
        // independent, so searched side by side, kept in rank order (the member does not
        // depend on the thread timing).
        use rayon::prelude::*;
        searched
            .par_iter()
            .map(|sp| search.search(sp, opts).0)
            .collect()
    }
}

/// A full search's certified members `found` (per searched cell) after a search from each
/// cell's best free run over its outer bounds, where that run clearly beats the member; and
/// those quick stand-in searches by cell. A ranking search keeps `found` as it is.
#[allow(clippy::type_complexity)]
fn from_free_runs(
    search: &Search,
    searched: &[&CellSpace],
    opts: &Options,
    centre_values: &[(String, f64)],
    found: Vec<Option<(f64, SimulationMember)>>,
) -> (
    Vec<Option<(f64, SimulationMember)>>,
    Vec<(usize, Option<(f64, SimulationMember)>)>,
) {
    // A full search also starts from the best free run over each searched cell's outer
    // bounds (the quick stand-in search) where that run clearly beats the cell's certified
    // member:
    // the certified point nearest a good simulator, or the simulator itself when certified.
    // The quick stand-in search of each searched cell, kept by cell for the stand-in below
    // (the same deterministic search: not run twice when nothing is certified).
    let mut quick_known: Vec<(usize, Option<(f64, SimulationMember)>)> = Vec::new();
    let found: Vec<Option<(f64, SimulationMember)>> = if opts.gives_up_early() {
        found
    } else {
        use rayon::prelude::*;
        let quick: Vec<Option<(f64, SimulationMember)>> = searched
            .par_iter()
            .map(|sp| search.best_uncertified(sp, opts, centre_values, false))
            .collect();
        quick_known = searched
            .iter()
            .map(|sp| sp.k)
            .zip(quick.iter().cloned())
            .collect();
        searched
            .par_iter()
            .zip(found)
            .zip(quick)
            .map(|((sp, f), quick)| {
                let Some((e2u, u)) = quick else {
                    return f;
                };
                // Only a run that beats the certified member clearly (a tenth less squared
                // error) is searched from: near the member the search from it costs as much
                // as the cell's first and finds the same point.
                if f.as_ref().is_some_and(|(e2, _)| *e2 <= e2u / 0.9) {
                    return f;
                }
                let (g, th) = split_values(search, sp, &u.values);
                let from = search.search_from(sp, opts, g, th);
                log::debug!(target: "smid::members", "cell {}: from its best free run ({e2u:.3e}) a certified member at {:?}, from the centre at {:?}", sp.k, from.as_ref().map(|m| m.0), f.as_ref().map(|m| m.0));
                match (f, from) {
                    (Some(a), Some(b)) => Some(if b.0 < a.0 { b } else { a }),
                    (a, b) => a.or(b),
                }
            })
            .collect()
    };
    (found, quick_known)
}

/// The members found from each of `seeds`, each in the first bounded cell that holds it, and
/// the spaces of the cells searched for them (a seed no cell holds is passed over).
#[allow(clippy::type_complexity)]
fn seeded_members<'s>(
    set: &ModelSet,
    search: &Search<'s>,
    opts: &Options,
    seeds: &[Vec<(String, f64)>],
) -> Result<(Vec<CellSpace<'s>>, Vec<(f64, SimulationMember)>)> {
    let layout = search.layout;
    // The seeds, each in the first bounded cell that holds it.
    let mut seeded_spaces: Vec<CellSpace> = Vec::new();
    let mut seeded: Vec<(f64, SimulationMember)> = Vec::new();
    for seed in seeds {
        let get = |n: &str| seed.iter().find(|(k, _)| k == n).map(|v| v.1);
        let get_last = |n: &str| seed.iter().rfind(|(k, _)| k == n).map(|v| v.1);
        let holds = |c: &CellSet| {
            let gamma: Option<Vec<f64>> = c
                .nonlinearity
                .parameters()
                .iter()
                .map(|b| get(&b.name))
                .collect();
            let psi = layout
                .dims
                .iter()
                .zip(&c.cell)
                .all(|(d, b)| get_last(&d.name).is_some_and(|v| b.contains(v)));
            c.bounded() && psi && gamma.is_some_and(|g| c.nonlinearity.contains(&g))
        };
        let mut space = None;
        for k in (0..set.cells.len()).filter(|&k| holds(&set.cells[k])) {
            if let Some(sp) = search.space(k)? {
                space = Some(sp);
                break;
            }
        }
        let Some(sp) = space else {
            log::debug!(target: "smid::members", "a seed no searchable cell holds: passed over");
            continue;
        };
        let k = sp.k;
        let (g, th) = split_values(search, &sp, seed);
        let from = search.search_from(&sp, opts, g, th);
        log::debug!(target: "smid::members", "cell {k}: from a seed, a certified member at {:?}", from.as_ref().map(|m| m.0));
        if let Some(f) = from {
            seeded.push(f);
        }
        seeded_spaces.push(sp);
    }
    Ok((seeded_spaces, seeded))
}

/// A point of the member `m`'s cell of `set` certified on `records` in place of the training
/// records, a proof that they are consistent with the model set (`validate` passes the
/// training records followed by the fresh ones): the exact consistency measure
/// ([`consistency_at`]: stage 2 at the point's nonlinearity and bisected parameters, then the
/// LP at its fixed `θ`) of the member itself, and where it is above [`CERTIFIED`], of the
/// point phase 1 reaches from it (one run of `opts`' Nelder-Mead budget; with `search_on`
/// only). At most
/// [`CERTIFIED`], the point satisfies every equation of `records` inside their noise bounds.
/// `None` when the member's cell has no searchable point.
pub fn certificate_on(
    set: &ModelSet,
    m: &SimulationMember,
    records: &[crate::model::Record],
    opts: &Checked<Options>,
    search_on: bool,
) -> Result<Option<f64>> {
    let mut on = set.duplicate();
    on.training.records = records.to_vec();
    if m.cell >= on.cells.len() {
        return Ok(None);
    }
    let search = Search {
        set: &on,
        layout: on.layout()?,
        x_warm: Vec::new(),
        spread: 0.0,
        evaluations: AtomicUsize::new(0),
    };
    let Some(sp) = search.space(m.cell)? else {
        return Ok(None);
    };
    // A point of the model class: its θ inside the cell's guaranteed bounds and the prior
    // (a point outside them is no member, whatever its equations say).
    let prior = search.layout.theta_prior.as_deref();
    let member_of_the_set = |th: &[f64]| {
        th.iter().enumerate().all(|(i, &v)| {
            sp.cell.theta.get(i).is_some_and(|b| b.contains(v))
                && prior.is_none_or(|p| p.get(i).is_none_or(|b| b.contains(v)))
        })
    };
    let measure = |g: &[f64], th: &[f64]| {
        if member_of_the_set(th) {
            search.certify(&sp, g, th)
        } else {
            f64::INFINITY
        }
    };
    let (g, mut th) = split_values(&search, &sp, &m.values);
    search.fix_gain(&mut th);
    let at_member = measure(&g, &th);
    if at_member <= CERTIFIED || !search_on {
        return Ok(Some(at_member));
    }
    let z = search.coordinates(&sp, &g, &th);
    let one_run = Options {
        restarts: 1,
        ..**opts
    };
    let last = std::cell::Cell::new(f64::INFINITY);
    Ok(Some(
        match search.certified_point(&sp, &one_run, &last, z) {
            Some((g1, th1)) => measure(&g1, &th1).min(at_member),
            None => at_member,
        },
    ))
}

/// What a member search shares: the [`Search`], the probed cells ranked by their phase-1
/// measure at their centres (the nearest `opts.probe` to the central cell), the centre's
/// values and its training fit.
#[allow(clippy::type_complexity)]
fn prepared<'s>(
    set: &'s ModelSet,
    opts: &Options,
) -> Result<(
    Search<'s>,
    Vec<(f64, CellSpace<'s>)>,
    Vec<(String, f64)>,
    f64,
)> {
    let layout = set.layout()?;
    let o = layout.orders;
    let warm = o.na + o.nb + o.nk;
    let centre_values = central_values(set)?;
    let centre = point(set, &centre_values)?;
    let records = &set.training.records;
    let search = Search {
        set,
        x_warm: records
            .iter()
            .map(|r| inner_estimate(set, &centre, r))
            .collect::<Result<_>>()?,
        spread: records
            .iter()
            .map(|r| {
                let y = &r.y[warm.min(r.y.len())..];
                let m = y.iter().sum::<f64>() / y.len().max(1) as f64;
                y.iter().map(|v| (v - m) * (v - m)).sum::<f64>()
            })
            .sum(),
        layout,
        evaluations: AtomicUsize::new(0),
    };
    let centre_fit = search.fit(search.sse(&centre_values));

    // Cells from the centre outwards; the probed ones ranked by their phase-1 measure.
    let order = cells_from_centre(set);
    let mut spaces: Vec<(f64, CellSpace)> = Vec::new();
    let bounded = order.iter().filter(|&&k| set.cells[k].bounded());
    for &k in bounded.take(opts.probe.max(1)) {
        if let Some(sp) = search.space(k)? {
            let z0 = vec![0.0; sp.moved.len() + search.a_free().len()];
            let m = search.measure_at_a(&sp, &z0).0;
            spaces.push((m, sp));
        }
    }
    spaces.sort_by(|a, b| a.0.total_cmp(&b.0));
    log::debug!(target: "smid::members", "probed {} cell(s): {} evaluations", spaces.len(), search.evaluations.load(Relaxed));
    Ok((search, spaces, centre_values, centre_fit))
}

/// The best training free run over the outer bounds of the probed cells of `set` (the search
/// a member falls back to when none is certified; certified or not, as its flag says), from
/// the centre and from the least-squares refit: a simulator of the model class near the set,
/// whose free-run distance from the training records is an upper end of the model's smallest
/// consistent bound (`noise.from: free_run`). `None` when no cell is bounded or no run is
/// finite.
pub fn best_free_run(set: &ModelSet, opts: &Checked<Options>) -> Result<Option<SimulationMember>> {
    if !set.cells.iter().any(|c| c.bounded()) {
        return Ok(None);
    }
    let (search, spaces, centre_values, _) = prepared(set, opts)?;
    Ok(
        best_free_run_over(&search, &spaces, opts, &centre_values, &[]).map(|(_, mut m)| {
            m.within = super::training_within(set, &m.values).ok().flatten();
            m
        }),
    )
}

/// The best free run over the outer bounds of the probed cells `spaces` (not certified):
/// every cell gets the quick search (taken from `known`, by cell, where it was run already),
/// a full search refines the best `opts.cells` of them.
fn best_free_run_over(
    search: &Search,
    spaces: &[(f64, CellSpace)],
    opts: &Options,
    centre: &[(String, f64)],
    known: &[(usize, Option<(f64, SimulationMember)>)],
) -> Option<(f64, SimulationMember)> {
    let mut best: Option<(f64, SimulationMember)> = None;
    use rayon::prelude::*;
    let mut quick: Vec<(f64, &CellSpace, SimulationMember)> = spaces
        .par_iter()
        .filter_map(|(_, sp)| {
            let found = match known.iter().find(|(k, _)| *k == sp.k) {
                Some((_, f)) => f.clone(),
                None => search.best_uncertified(sp, opts, centre, false),
            };
            log::debug!(target: "smid::members", "cell {}: best uncertified point {:?}", sp.k, found.as_ref().map(|f| f.0));
            found.map(|(e2, m)| (e2, sp, m))
        })
        .collect();
    quick.sort_by(|a, b| a.0.total_cmp(&b.0));
    let refine = if opts.gives_up_early() {
        0
    } else {
        opts.cells.max(1).min(quick.len())
    };
    let refined: Vec<Option<(f64, SimulationMember)>> = quick[..refine]
        .par_iter()
        .map(|(_, sp, _)| search.best_uncertified(sp, opts, centre, true))
        .collect();
    let mut refined = refined.into_iter();
    for (e2, _, m) in quick {
        let (e2, m) = match refined.next().flatten() {
            Some((er, mr)) if er < e2 => (er, mr),
            _ => (e2, m),
        };
        if best.as_ref().is_none_or(|(b, _)| e2 < *b) {
            best = Some((e2, m));
        }
    }
    best
}
