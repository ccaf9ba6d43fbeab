//! Sweeps over seeds, split into shards: the containment check (`smid check`) and the paper's
//! Tables I-II (`smid reproduce paper`). Shard K of M runs every M-th seed from the K-th
//! ([`montecarlo::shard_seeds`]); merging the shards of one run gives, bit for bit, what one
//! machine computes for all the seeds, because every trial depends on its seed alone and the
//! merge orders by seed. The CLI (`--shard K/M --json`, `check-merge`, `reproduce-merge`) and the
//! Python package's Dask runner both go through this module.
use crate::montecarlo::{self, Summary};
use crate::reproduce::{self, PaperRun, Reproduction};
use smid_core::spec::EivMethod;
use smid_core::{Result, SmidError};

/// What one containment check runs (the whole run's seeds, and which shard of them).
#[derive(Debug, Clone)]
pub struct CheckOptions {
    /// A check case of [`crate::plugin_check::plugins`].
    pub plugin: String,
    /// Stage-3 method (`None`: the spec default; classical with `any_record`).
    pub method: Option<EivMethod>,
    /// Identification from one dynamic record (no steady-state experiment).
    pub any_record: bool,
    /// The first seed of the whole run.
    pub first_seed: u64,
    /// Trials (seeds) in the whole run, all shards together.
    pub trials: usize,
    /// `(K, M)`, 1-based; `None` is the whole run.
    pub shard: Option<(usize, usize)>,
    /// Threads on this machine.
    pub jobs: usize,
}

/// One `smid check` run (or shard): what was checked and the outcome, as `--json` writes it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CheckRun {
    /// The check case (plugin) that was checked.
    pub plugin: String,
    /// The stage-3 method's name.
    pub method: String,
    /// Identification from one dynamic record (no steady-state experiment).
    pub any_record: bool,
    /// The whole run's seeds are `first_seed..first_seed + trials`.
    pub first_seed: u64,
    /// Trials (seeds) in the whole run.
    pub trials: usize,
    /// This shard `(K, M)`, 1-based (`(1, 1)`: the whole run).
    pub shard: (usize, usize),
    /// The outcome counts of this shard's trials.
    pub summary: Summary,
}

/// Check that a shard `(K, M)` is well formed.
pub fn check_shard(shard: Option<(usize, usize)>) -> Result<()> {
    match shard {
        Some((k, m)) if k == 0 || k > m => Err(SmidError::invalid(
            "shard",
            format!("{k}/{m}: expected K/M with 1 <= K <= M"),
        )),
        _ => Ok(()),
    }
}

/// The shards `(name, (K, M))` of one run (same M, checked by the caller): none given twice
/// and none missing, else an error naming the shard (`what` is the merged result's name).
fn complete<'a>(shards: impl Iterator<Item = (&'a str, (usize, usize))>, what: &str) -> Result<()> {
    let shards: Vec<_> = shards.collect();
    let Some(&(_, (_, m))) = shards.first() else {
        return Err(SmidError::invalid("shards", "no shard to merge"));
    };
    for (i, (name, (k, _))) in shards.iter().enumerate() {
        if *k == 0 || *k > m {
            return Err(SmidError::invalid(
                *name,
                format!("shard {k}/{m}: expected K/M with 1 <= K <= M"),
            ));
        }
        if shards[..i].iter().any(|(_, s)| s.0 == *k) {
            return Err(SmidError::invalid(
                *name,
                format!("shard {k}/{m} is given twice"),
            ));
        }
    }
    let missing: Vec<String> = (1..=m)
        .filter(|k| !shards.iter().any(|(_, s)| s.0 == *k))
        .map(|k| format!("{k}/{m}"))
        .collect();
    if missing.is_empty() {
        Ok(())
    } else {
        Err(SmidError::invalid(
            "shards",
            format!(
                "shard(s) {} missing: the merged {what} would not be the whole run's",
                missing.join(", ")
            ),
        ))
    }
}

/// Run the trials of one check (or shard), calling `tick` after each trial.
pub fn check(opts: &CheckOptions, tick: impl Fn() + Sync) -> Result<CheckRun> {
    check_shard(opts.shard)?;
    let seeds = montecarlo::shard_seeds(opts.first_seed, opts.trials, opts.shard);
    let summary = crate::plugin_check::run(
        &opts.plugin,
        &seeds,
        opts.method,
        opts.any_record,
        opts.jobs.max(1),
        tick,
    )?;
    let default = if opts.any_record {
        EivMethod::Classical
    } else {
        EivMethod::default()
    };
    Ok(CheckRun {
        plugin: opts.plugin.clone(),
        method: opts.method.unwrap_or(default).name().to_string(),
        any_record: opts.any_record,
        first_seed: opts.first_seed,
        trials: opts.trials,
        shard: opts.shard.unwrap_or((1, 1)),
        summary,
    })
}

/// Join the shards of one check, each with a name for errors (its file): refused when a shard
/// belongs to another run (plugin, method, any-record, seeds, M), is given twice, or is missing.
pub fn merge_checks(shards: &[(String, CheckRun)]) -> Result<CheckRun> {
    let Some((_, first)) = shards.first() else {
        return Err(SmidError::invalid("shards", "no shard to merge"));
    };
    let key = |r: &CheckRun| {
        (
            r.plugin.clone(),
            r.method.clone(),
            r.any_record,
            r.first_seed,
            r.trials,
            r.shard.1,
        )
    };
    let describe = |r: &CheckRun| {
        format!(
            "{} / {} / any_record {} / seeds {}.. x {} / {} shards",
            r.plugin, r.method, r.any_record, r.first_seed, r.trials, r.shard.1
        )
    };
    for (name, run) in shards {
        if key(run) != key(first) {
            return Err(SmidError::invalid(
                name.clone(),
                format!(
                    "a shard of another check ({}), expected {}",
                    describe(run),
                    describe(first)
                ),
            ));
        }
    }
    complete(shards.iter().map(|(n, r)| (n.as_str(), r.shard)), "table")?;
    for (name, run) in shards {
        let n = montecarlo::shard_seeds(run.first_seed, run.trials, Some(run.shard)).len();
        if run.summary.trials != n {
            return Err(SmidError::invalid(
                name.clone(),
                format!(
                    "shard {}/{} holds {} trials, expected {n} (its seeds of the run)",
                    run.shard.0, run.shard.1, run.summary.trials
                ),
            ));
        }
    }
    let parts: Vec<Summary> = shards.iter().map(|(_, r)| r.summary.clone()).collect();
    Ok(CheckRun {
        shard: (1, 1),
        summary: Summary::merge(&parts),
        ..first.clone()
    })
}

/// The table `smid check` prints for a run.
pub fn format_check(run: &CheckRun) -> String {
    format!(
        "stage-3 method: {}{}\n{}",
        run.method,
        if run.any_record {
            "; from any record (no steady-state data, N = 400, prior box around the truth)"
        } else {
            ""
        },
        crate::plugin_check::report(&run.plugin, &run.summary)
    )
}

/// A shard of `smid reproduce paper --seeds S`: its runs, as `--shard K/M --json` writes them.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PaperShard {
    /// Seeds of the whole reproduction (`1..=seeds`).
    pub seeds: usize,
    /// This shard `(K, M)`, 1-based (`(1, 1)`: the whole run).
    pub shard: (usize, usize),
    /// This shard's identifications, one per bit count and seed.
    pub runs: Vec<PaperRun>,
}

/// Run shard `shard` of the reproduction with seeds `1..=seeds` (every bit count for each of
/// its seeds), calling `tick` after each identification.
pub fn paper_shard(
    seeds: usize,
    shard: Option<(usize, usize)>,
    mut tick: impl FnMut(),
) -> Result<PaperShard> {
    check_shard(shard)?;
    let runs = reproduce::runs(&montecarlo::shard_seeds(1, seeds, shard), &mut tick)?;
    Ok(PaperShard {
        seeds,
        shard: shard.unwrap_or((1, 1)),
        runs,
    })
}

/// Join the shards of one reproduction (each named for errors) into its tables: refused when
/// a shard has other seeds or M, is given twice or is missing.
pub fn merge_paper(shards: &[(String, PaperShard)]) -> Result<Reproduction> {
    let Some((_, first)) = shards.first() else {
        return Err(SmidError::invalid("shards", "no shard to merge"));
    };
    for (name, s) in shards {
        if (s.seeds, s.shard.1) != (first.seeds, first.shard.1) {
            return Err(SmidError::invalid(
                name.clone(),
                format!(
                    "a shard of another reproduction ({} seeds, {} shards), expected {} seeds, {} shards",
                    s.seeds, s.shard.1, first.seeds, first.shard.1
                ),
            ));
        }
    }
    complete(shards.iter().map(|(n, r)| (n.as_str(), r.shard)), "tables")?;
    for (name, s) in shards {
        let mut want: Vec<(u32, u64)> = reproduce::BITS
            .iter()
            .flat_map(|&b| {
                montecarlo::shard_seeds(1, s.seeds, Some(s.shard))
                    .into_iter()
                    .map(move |seed| (b, seed))
            })
            .collect();
        let mut have: Vec<(u32, u64)> = s.runs.iter().map(|r| (r.bits, r.seed)).collect();
        want.sort_unstable();
        have.sort_unstable();
        if have != want {
            return Err(SmidError::invalid(
                name.clone(),
                format!(
                    "shard {}/{} does not hold exactly its runs (each of its seeds at n_bit {:?})",
                    s.shard.0,
                    s.shard.1,
                    reproduce::BITS
                ),
            ));
        }
    }
    let mut runs: Vec<PaperRun> = shards.iter().flat_map(|(_, s)| s.runs.clone()).collect();
    runs.sort_by_key(|r| r.seed);
    Ok(reproduce::tables(first.seeds, &runs))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(shard: (usize, usize), trials_in_shard: usize) -> (String, CheckRun) {
        (
            format!("s{}", shard.0),
            CheckRun {
                plugin: "output_backlash".into(),
                method: "classical".into(),
                any_record: false,
                first_seed: 1,
                trials: 4,
                shard,
                summary: Summary {
                    trials: trials_in_shard,
                    contained: trials_in_shard,
                    ..Default::default()
                },
            },
        )
    }

    #[test]
    fn merges_refuse_shards_out_of_range_and_wrong_counts() {
        let ok = merge_checks(&[run((2, 2), 2), run((1, 2), 2)]).unwrap();
        assert_eq!((ok.summary.trials, ok.shard), (4, (1, 1)));
        let extra = merge_checks(&[run((1, 2), 2), run((2, 2), 2), run((3, 2), 2)]);
        assert!(extra.unwrap_err().to_string().contains("3/2"));
        let zero = merge_checks(&[run((0, 2), 2), run((1, 2), 2), run((2, 2), 2)]);
        assert!(zero.unwrap_err().to_string().contains("0/2"));
        let short = merge_checks(&[run((1, 2), 1), run((2, 2), 2)]);
        assert!(short.unwrap_err().to_string().contains("holds 1 trials"));
        assert!(merge_checks(&[]).is_err());
    }

    #[test]
    fn a_paper_shard_must_hold_exactly_its_runs() {
        let shard = |k: usize, seeds: &[u64]| {
            (
                format!("p{k}"),
                PaperShard {
                    seeds: 3,
                    shard: (k, 2),
                    runs: reproduce::BITS
                        .iter()
                        .flat_map(|&bits| {
                            seeds.iter().map(move |&seed| PaperRun {
                                bits,
                                seed,
                                outcome: Err("not run".into()),
                            })
                        })
                        .collect(),
                },
            )
        };
        // Seeds 1..=3 in 2 shards: {1, 3} and {2}.
        let r = merge_paper(&[shard(1, &[1, 3]), shard(2, &[2])]).unwrap();
        assert_eq!(r.errors.len(), 3 * reproduce::BITS.len());
        let wrong = merge_paper(&[shard(1, &[1]), shard(2, &[2, 3])]);
        assert!(wrong.unwrap_err().to_string().contains("exactly its runs"));
    }
}
