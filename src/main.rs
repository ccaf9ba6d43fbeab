//! The `smid` command line: `run` a YAML spec, `simulate` its plant to CSV, `reproduce paper`
//! (Tables I-II), `check` (Monte Carlo containment). anyhow is used only here, at the edge.
#![forbid(unsafe_code)]

/// The CLI's report on stdout. Once the reader has closed stdout (`smid run … | head`) the
/// report is dropped and the command goes on, so the files it writes are still written; any
/// other failure to write is reported on stderr once, and the program ends with status 1.
macro_rules! println {
    ($($arg:tt)*) => {
        crate::report_line(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// [`println!`] without the line end.
macro_rules! print {
    ($($arg:tt)*) => {
        crate::report_line(format_args!($($arg)*))
    };
}

/// Whether stdout can no longer be written: the reader closed it, or a write failed.
static STDOUT_GONE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
/// Whether a write to stdout failed for another reason than a closed reader.
static STDOUT_FAILED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Writes `text` to stdout unless it is gone (see [`println!`]).
fn report_line(text: std::fmt::Arguments) {
    use std::io::Write as _;
    use std::sync::atomic::Ordering::Relaxed;
    if STDOUT_GONE.load(Relaxed) {
        return;
    }
    if let Err(e) = std::io::stdout().lock().write_fmt(text) {
        STDOUT_GONE.store(true, Relaxed);
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            STDOUT_FAILED.store(true, Relaxed);
            eprintln!("error: cannot write to stdout: {e}");
        }
    }
}

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(
    name = "smid",
    version,
    about = "Set-membership identification of block-oriented nonlinear systems"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Identify from a YAML spec: print the bounds, write result.json, data.csv and SVG plots.
    Run {
        spec: PathBuf,
        /// Output directory (default: out/<spec name>).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Run the spec's dynamic experiment (PRBS) through its plant (simulator or FMU) without
    /// identifying; add the spec's bounded noise; write `DIR/NAME.csv` with columns t, u, y, w
    /// (y = w + noise, w noise-free), readable by a diagnosis spec. With --experiment: the
    /// spec's whole training experiment and held-out records as measured data (CSV files and a
    /// spec that reads them).
    Simulate {
        spec: PathBuf,
        /// Write the spec's whole training experiment instead: `steady.csv` (the designed
        /// steady-state points, columns u, y, t, step), `train.csv` (its dynamic record),
        /// `holdout0.csv`, `holdout1.csv` (the records `smid diagnose` holds out by default)
        /// and `spec.yaml` (the spec with `plant.data` reading them, the plant's truth as
        /// `plant.truth`, a designed filter pole written down and a `design` α as `bias`),
        /// in `--out` (default: out/<spec name>/experiment).
        #[arg(long, conflicts_with_all = ["name", "length", "seed"])]
        experiment: bool,
        /// Output directory (default: out/<spec name>; with --experiment
        /// out/<spec name>/experiment).
        #[arg(long)]
        out: Option<PathBuf>,
        /// File name without `.csv` (default: `seed-<S>` with --seed, else `dynamic`).
        #[arg(long)]
        name: Option<String>,
        /// Number of samples (default: the spec's experiment.dynamic.length).
        #[arg(long)]
        length: Option<usize>,
        /// Seed of the PRBS and the noise (default: the spec's experiment.seed).
        #[arg(long)]
        seed: Option<u64>,
    },
    /// Reproduce a reference result.
    Reproduce {
        /// What to reproduce: `paper` (Section 6, Tables I-II).
        what: String,
        /// Number of seeds per noise level.
        #[arg(long, default_value_t = 20)]
        seeds: usize,
        /// Also write the medians as JSON (with `--shard`: the shard's runs, for
        /// `reproduce-merge`).
        #[arg(long)]
        json: Option<PathBuf>,
        /// Run shard K of M (1-based) of the seeds (every M-th seed from the K-th) and write its
        /// runs with `--json`; join the shards with `reproduce-merge`.
        #[arg(long, value_parser = parse_shard, requires = "json", conflicts_with = "methods")]
        shard: Option<(usize, usize)>,
        /// Also compare stage-3 methods on the same data (comma-separated registered names):
        /// a radius table per method and n_bit, with the ratio to the exact set.
        #[arg(long, value_delimiter = ',', help = methods_help("Also compare stage-3 methods on the same data, comma-separated; a radius table per method and n_bit, with the ratio to the exact set"))]
        methods: Vec<String>,
    },
    /// Print the JSON Schema of the spec (every registered plugin and effect `type`); the
    /// committed copy is `schemas/smid-spec.schema.json`.
    Schema {
        /// Print the spec reference instead: every field with its type, default, description
        /// and an example from the bundled specs, in Markdown (the committed copy is
        /// `docs/reference/spec.md`).
        #[arg(long)]
        markdown: bool,
    },
    /// Monte Carlo containment check: random systems, backlash and noise; every bound must hold.
    Check {
        #[arg(long, default_value_t = 1000)]
        trials: usize,
        #[arg(long, default_value_t = 1)]
        first_seed: u64,
        /// Check case: a registered plugin that offers a random trial, with `_input` /
        /// `_output` where it is checked on both sides (`smid check --list` names them).
        #[arg(long, default_value = "output_backlash")]
        plugin: String,
        /// Stage-3 method (default: the spec default).
        #[arg(long, help = methods_help("Stage-3 method (default: the spec default)"))]
        method: Option<String>,
        /// Identification from any record: no steady-state experiment, a PRBS of 400 samples,
        /// the nonlinearity bisected over a random prior box around the truth (stage 3
        /// classical unless --method).
        #[arg(long)]
        any_record: bool,
        /// Trials run in parallel (default: the number of cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// Run shard K of M (1-based) of the trials: every M-th seed from the K-th, for
        /// machines or workers of a distributed engine; join the shards with `check-merge`.
        #[arg(long, value_parser = parse_shard)]
        shard: Option<(usize, usize)>,
        /// Also write the summary (counts, missed seeds, errors) as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
        /// List the check cases (derived from the plugin registry) and exit.
        #[arg(long)]
        list: bool,
    },
    /// Containment check of block chains generated from the registry (`smid::chain_check`):
    /// random linear blocks with a random model nonlinearity, input-side block and block after
    /// the nonlinearity, bisected over random prior boxes; exit code 1 when a trial missed.
    CheckChains {
        #[arg(long, default_value_t = 100)]
        trials: usize,
        #[arg(long, default_value_t = 1)]
        first_seed: u64,
    },
    /// Join the `--json` summaries of the shards of one `check` run into its table, the same as
    /// one machine's run of all the seeds; exit code 1 when a trial missed the truth.
    CheckMerge {
        /// The shard summaries (`smid check --shard K/M --json FILE`).
        #[arg(required = true)]
        files: Vec<PathBuf>,
    },
    /// Join the `--json` files of the shards of one `reproduce paper --shard K/M` run into
    /// Tables I-II, the same as one machine's run of all the seeds.
    ReproduceMerge {
        /// The shard files (`smid reproduce paper --seeds S --shard K/M --json FILE`).
        #[arg(required = true)]
        files: Vec<PathBuf>,
    },
    /// Validate the model set of a run spec (identified now) or of a `result.json` on fresh
    /// records: set-membership verdict, smallest consistent noise bound (PASS/FAIL), free-run
    /// simulation with an envelope, k-step prediction, residual correlations, the ARX baseline;
    /// SVG plots. Exit code 3 when the fresh data falsify the model.
    Validate {
        /// A run spec (YAML) or a `result.json` of `smid run`.
        spec: PathBuf,
        /// Fresh records (CSV, `PATH@START..END` for a row range; repeat for several). Default:
        /// a record of the spec's plant with another seed.
        #[arg(long)]
        data: Vec<PathBuf>,
        /// Output directory (default: out/<spec name>/validate).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Horizon of the k-step-ahead prediction.
        #[arg(long, default_value_t = 5)]
        k: usize,
        /// Seed of the fresh record drawn from the plant (default: experiment.seed + 1000).
        #[arg(long)]
        seed: Option<u64>,
        /// Length of the fresh record drawn from the plant (default: experiment.dynamic.length).
        #[arg(long)]
        length: Option<usize>,
    },
    /// Trace what the model lacks to an effect: every registered effect is added in turn and
    /// re-identified on the training records only; the choice is made on them; then the
    /// held-out records are read once for the before/after table. Writes the augmented spec.
    Diagnose {
        /// A run spec (YAML; its data are the training records) or a `result.json`.
        spec: PathBuf,
        /// Held-out records (CSV, `PATH@START..END` for a row range; repeat for several).
        /// Default: two records of the spec's plant with other seeds.
        #[arg(long)]
        holdout: Vec<PathBuf>,
        /// Output directory (default: out/<spec name>/diagnose).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Effects added at most.
        #[arg(long, default_value_t = 2)]
        max_effects: usize,
        /// Only these candidates (comma-separated): effect types, plugin types, or `feedback` (the output side inside the loop).
        #[arg(long, value_delimiter = ',')]
        only: Vec<String>,
    },
    /// Release-mode check of the diagnosis on the paper's plant: each effect present but
    /// undeclared must be named in at least 9 of 10 trials, with the after-model consistent on
    /// held-out records and its bounds around the truth.
    DiagnoseCheck {
        #[arg(long, default_value_t = 10)]
        trials: usize,
        #[arg(long, default_value_t = 1)]
        first_seed: u64,
        /// Only these cases (comma-separated: none, an effect's tag, or `<plugin>@input` /
        /// `<plugin>@output`; the matrix is generated from the registries).
        #[arg(long, value_delimiter = ',')]
        only: Vec<String>,
        /// Give the diagnosis every record through CSV files (steady-state points with time
        /// and step-height columns, the dynamic records), as measured data.
        #[arg(long)]
        csv: bool,
        /// Keep each trial's records and spec, as measured data, in `DIR/<case>-<seed>/` (rerun
        /// one with `smid diagnose DIR/<case>-<seed>/spec.yaml --holdout ...`).
        #[arg(long, value_name = "DIR")]
        keep: Option<PathBuf>,
        /// Trials run in parallel (default: the number of cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// Run the cases the FMU fmus/paper_effects offers (none, offset, drift, delay) on it
        /// instead of the built-in simulator (needs the `fmu` feature).
        #[arg(long)]
        fmu: bool,
    },
}

fn progress(n: usize, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(n as u64);
    if std::io::stderr().is_terminal() {
        pb.set_style(
            ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} ({eta})")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        pb.set_message(what.to_string());
    } else {
        pb.set_draw_target(ProgressDrawTarget::hidden());
    }
    pb
}

/// Show the branch and bound's progress: cells done and queued, the current hull.
fn cell_progress(pb: &ProgressBar, p: &smid::core::cells::Progress) {
    pb.set_length((p.evaluated + p.queued) as u64);
    pb.set_position(p.evaluated as u64);
    pb.set_message(format!(
        "cells (kept {}; hull {})",
        p.kept,
        p.hull
            .iter()
            .map(|i| format!("[{:.3e}, {:.3e}]", i.lo, i.hi))
            .collect::<Vec<_>>()
            .join(" × ")
    ));
}

/// The table `smid check` prints; an error when a trial missed the truth.
fn report_check(run: &smid::sweep::CheckRun) -> anyhow::Result<()> {
    print!("{}", smid::sweep::format_check(run));
    anyhow::ensure!(
        run.summary.missed.is_empty(),
        "{} trials missed the truth",
        run.summary.missed.len()
    );
    Ok(())
}

/// The shard files of a merge, each named by its path; `what` says what a file should be.
fn read_shards<T: serde::de::DeserializeOwned>(
    files: &[PathBuf],
    what: &str,
) -> Result<Vec<(String, T)>> {
    files
        .iter()
        .map(|f| {
            let text =
                std::fs::read_to_string(f).with_context(|| format!("reading {}", f.display()))?;
            let v = serde_json::from_str(&text)
                .with_context(|| format!("{}: not {what}", f.display()))?;
            Ok((f.display().to_string(), v))
        })
        .collect()
}

/// `--shard K/M`: 1 <= K <= M.
fn parse_shard(s: &str) -> Result<(usize, usize), String> {
    let bad = || format!("`{s}`: expected K/M with 1 <= K <= M, e.g. 2/4");
    let (k, m) = s.split_once('/').ok_or_else(bad)?;
    let (k, m): (usize, usize) = (
        k.trim().parse().map_err(|_| bad())?,
        m.trim().parse().map_err(|_| bad())?,
    );
    if k == 0 || k > m {
        return Err(bad());
    }
    Ok((k, m))
}

/// `--jobs`, else the number of cores.
fn jobs_or_cores(jobs: Option<usize>) -> usize {
    jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1)
}

/// A `--method` help line naming the registered stage-3 methods.
fn methods_help(what: &str) -> String {
    format!("{what}: {}", smid::core::stage3::names().join(", "))
}

fn parse_method(m: &str) -> Result<smid::core::spec::EivMethod> {
    Ok(smid::core::spec::EivMethod::parse(m)?)
}

/// `out/<spec stem>/<what>`.
fn out_dir(spec: &std::path::Path, what: &str) -> PathBuf {
    let stem = spec
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "smid".into());
    PathBuf::from("out").join(stem).join(what)
}

fn join(files: &[PathBuf]) -> String {
    files
        .iter()
        .map(|f| f.display().to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The CLI's logger: the core's diagnostics (the `log` facade; solvers never read the
/// environment) printed on stderr at the level `SMID_LOG` names (`error` .. `trace`; off when
/// unset).
struct StderrLog;

impl log::Log for StderrLog {
    fn enabled(&self, m: &log::Metadata) -> bool {
        m.level() <= log::max_level()
    }
    fn log(&self, r: &log::Record) {
        if self.enabled(r.metadata()) {
            eprintln!("[{} {}] {}", r.level(), r.target(), r.args());
        }
    }
    fn flush(&self) {}
}

fn init_log() {
    let level = std::env::var("SMID_LOG")
        .ok()
        .and_then(|v| v.trim().parse::<log::LevelFilter>().ok())
        .unwrap_or(log::LevelFilter::Off);
    if log::set_logger(&StderrLog).is_ok() {
        log::set_max_level(level);
    }
}

fn main() {
    init_log();
    if let Err(e) = real_main() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
    if STDOUT_FAILED.load(std::sync::atomic::Ordering::Relaxed) {
        std::process::exit(1);
    }
}

fn real_main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Schema { markdown } => {
            smid::link_plugins();
            if markdown {
                print!("{}", smid::spec_reference::reference()?)
            } else {
                print!("{}", smid::core::registry::spec_schema())
            }
        }
        Command::Check {
            trials,
            first_seed,
            ref plugin,
            ref method,
            any_record,
            jobs,
            shard,
            ref json,
            list,
        } => {
            if list {
                for name in smid::plugin_check::plugins() {
                    println!("{name}");
                }
                return Ok(());
            }
            let method = method.as_deref().map(parse_method).transpose()?;
            let opts = smid::sweep::CheckOptions {
                plugin: plugin.clone(),
                method,
                any_record,
                first_seed,
                trials,
                shard,
                jobs: jobs_or_cores(jobs),
            };
            let n = smid::montecarlo::shard_seeds(first_seed, trials, shard).len();
            let pb = progress(n, plugin);
            let run = smid::sweep::check(&opts, || pb.inc(1))?;
            pb.finish_and_clear();
            if let Some(path) = json {
                std::fs::write(path, serde_json::to_string_pretty(&run)?)
                    .with_context(|| format!("writing {}", path.display()))?;
            }
            report_check(&run)?;
        }
        Command::CheckChains { trials, first_seed } => {
            use smid::chain_check::Outcome;
            let pb = progress(trials, "chains");
            let (mut contained, mut missed, mut no_bound) = (0, Vec::new(), Vec::new());
            let mut shapes: std::collections::BTreeMap<String, (usize, usize, usize)> =
                Default::default();
            for seed in first_seed..first_seed + trials as u64 {
                let (spec, outcome) = smid::chain_check::trial(seed)?;
                let m = &spec.model;
                let tags = |v: &[Box<dyn smid::core::nonlinearity::NonlinearityModel>]| {
                    v.iter()
                        .map(|b| smid::core::nonlinearity::tag_of_model(b.as_ref()))
                        .collect::<Vec<_>>()
                        .join(",")
                };
                let shape = format!(
                    "[{}] -> L -> {} -> [{}]",
                    tags(&m.input),
                    m.nonlinearity_tag(),
                    tags(&m.output)
                );
                let e = shapes.entry(shape).or_default();
                match outcome {
                    Outcome::Contained => {
                        contained += 1;
                        e.0 += 1;
                    }
                    Outcome::Missed(why) => {
                        missed.push((seed, why));
                        e.1 += 1;
                    }
                    Outcome::NoBound(why) => {
                        no_bound.push((seed, why));
                        e.2 += 1;
                    }
                }
                pb.inc(1);
            }
            pb.finish_and_clear();
            println!("| chain | contained | missed | no finite bound |");
            println!("|---|---|---|---|");
            for (shape, (c, m, n)) in &shapes {
                println!("| {shape} | {c} | {m} | {n} |");
            }
            println!(
                "\n{trials} trials (seeds {first_seed}..{}): {contained} contained, {} missed, {} without a finite bound",
                first_seed + trials as u64 - 1,
                missed.len(),
                no_bound.len()
            );
            for (seed, why) in &no_bound {
                println!("no bound, seed {seed}: {why}");
            }
            for (seed, why) in &missed {
                println!("MISSED, seed {seed}: {why}");
            }
            if !missed.is_empty() {
                std::process::exit(1);
            }
        }
        Command::CheckMerge { files } => {
            let shards = read_shards(&files, "a `smid check --json` summary")?;
            report_check(&smid::sweep::merge_checks(&shards)?)?;
        }
        Command::ReproduceMerge { files } => {
            let shards = read_shards(&files, "a `smid reproduce paper --shard K/M --json` file")?;
            print!(
                "{}",
                smid::reproduce::format_tables(&smid::sweep::merge_paper(&shards)?)
            );
        }
        Command::Validate {
            spec,
            data,
            out,
            k,
            seed,
            length,
        } => {
            let dir = out.unwrap_or_else(|| out_dir(&spec, "validate"));
            let mut src = smid::closeloop::load_source(&spec)
                .with_context(|| format!("reading {}", spec.display()))?;
            let model = match src.model.take() {
                Some(m) => m,
                None => {
                    let pb = progress(0, "cells");
                    let id = smid::run_spec(&src.spec, &src.base, &|p| cell_progress(&pb, p));
                    pb.finish_and_clear();
                    match id {
                        Ok(smid::Outcome::Consistent(id)) => id.model,
                        Ok(smid::Outcome::Falsified(f)) => {
                            eprintln!("identification on the training data: {}", f.message());
                            std::process::exit(2);
                        }
                        Err(e) => {
                            return Err(e)
                                .with_context(|| format!("identifying {}", spec.display()))
                        }
                    }
                }
            };
            let seed = seed.unwrap_or(src.spec.experiment.seed + 1000);
            let length = length.unwrap_or(src.spec.experiment.dynamic.length);
            let fresh =
                smid::closeloop::fresh_records(&src.spec, &src.base, &data, seed, length, 1)
                    .context("reading the fresh records")?;
            let v = smid::core::validate::validate(
                &model,
                &fresh,
                &smid::core::validate::Options {
                    k,
                    ..Default::default()
                },
            )
            .with_context(|| format!("validating {}", spec.display()))?;
            print!("{}", smid::closeloop::format_validation(&v, &fresh));
            let files = smid::closeloop::write_validation(&v, &dir, "")?;
            println!("wrote {}", join(&files));
            if v.consistency.verdict == smid::core::validate::Verdict::Falsified {
                std::process::exit(3);
            }
        }
        Command::Diagnose {
            spec,
            holdout,
            out,
            max_effects,
            only,
        } => {
            let dir = out.unwrap_or_else(|| out_dir(&spec, "diagnose"));
            let mut src = smid::closeloop::load_source(&spec)
                .with_context(|| format!("reading {}", spec.display()))?;
            let training =
                smid::closeloop::training_data(&mut src).context("acquiring the training data")?;
            let opts = smid::core::diagnose::Options {
                max_effects,
                only,
                ..Default::default()
            };
            // The held-out files are parsed and checked now (a bad path or row fails at
            // once, not after the search); their values reach only the table below.
            let seed = src.spec.experiment.seed + 1000;
            let length = src.spec.experiment.dynamic.length;
            let held =
                smid::closeloop::fresh_records(&src.spec, &src.base, &holdout, seed, length, 2)
                    .context("reading the held-out records")?
                    .iter()
                    .map(smid::core::model::Record::without_history)
                    .collect::<Vec<_>>();
            smid::core::validate::check_fresh(src.spec.model.layout()?.orders, &held)
                .context("checking the held-out records")?;
            let pb = progress(1, "candidates (training data)");
            let t0 = std::time::Instant::now();
            let mut choice = smid::core::diagnose::choose(&src.spec, &training, &opts, &|d, t| {
                pb.set_length(t as u64);
                pb.set_position(d as u64);
            })
            .with_context(|| format!("diagnosing {}", spec.display()))?;
            pb.finish_and_clear();
            log::info!(target: "smid::diagnose", "training data and choice: {:.2} s", t0.elapsed().as_secs_f64());
            print!("{}", smid::closeloop::format_choice(&choice));
            // Only now do the held-out records enter anything.
            let (before, after) =
                smid::core::diagnose::assess(&src.spec, &training, &mut choice, &held, opts.k)
                    .context("the before/after table")?;
            log::info!(target: "smid::diagnose", "held-out records and the before/after table: {:.2} s", t0.elapsed().as_secs_f64());
            print!("{}", smid::closeloop::format_table(&before, &after));
            let files =
                smid::closeloop::write_diagnosis(&src.spec, &choice, &before, &after, &dir)?;
            println!("wrote {}", join(&files));
        }
        Command::DiagnoseCheck {
            trials,
            first_seed,
            only,
            jobs,
            fmu,
            csv,
            keep,
        } => {
            let plant = if fmu {
                smid::diagnose_check::PlantKind::Fmu
            } else {
                smid::diagnose_check::PlantKind::Simulator
            };
            let n = smid::diagnose_check::case_count(&only);
            let pb = progress(n * trials, "diagnosis trials");
            let r = smid::diagnose_check::run(
                trials,
                first_seed,
                &only,
                plant,
                smid::diagnose_check::TrialIo {
                    csv,
                    keep: keep.as_deref(),
                },
                jobs_or_cores(jobs),
                || pb.inc(1),
            )?;
            pb.finish_and_clear();
            print!("{}", smid::diagnose_check::format(&r));
            anyhow::ensure!(
                smid::diagnose_check::meets_bar(&r),
                "a case was named in fewer than 9 of 10 trials, or a named after-model failed on held-out data or missed the truth"
            );
        }
        Command::Simulate {
            spec,
            experiment: true,
            out,
            ..
        } => {
            let dir = out.unwrap_or_else(|| out_dir(&spec, "experiment"));
            let src = smid::closeloop::load_source(&spec)
                .with_context(|| format!("reading {}", spec.display()))?;
            let e = smid::simulate::export_experiment(&src.spec, &src.base, 2, &dir)
                .with_context(|| format!("simulating {}", spec.display()))?;
            println!("wrote {}", join(&e.files));
            for n in &e.notes {
                println!("the spec states {n}");
            }
            let held = |k: usize| dir.join(format!("holdout{k}.csv")).display().to_string();
            println!(
                "diagnose them as measured data: smid diagnose {} --holdout {} --holdout {}",
                dir.join("spec.yaml").display(),
                held(0),
                held(1)
            );
        }
        Command::Simulate {
            spec,
            experiment: false,
            out,
            name,
            length,
            seed,
        } => {
            let r = smid::simulate::simulate_spec_file(&spec, length, seed)
                .with_context(|| format!("simulating {}", spec.display()))?;
            let dir = out.unwrap_or_else(|| {
                let stem = spec.file_stem().map(|s| s.to_string_lossy().into_owned());
                PathBuf::from("out").join(stem.unwrap_or_else(|| "smid".into()))
            });
            let name = name.unwrap_or_else(|| match seed {
                Some(s) => format!("seed-{s}"),
                None => "dynamic".into(),
            });
            let path = dir.join(format!("{name}.csv"));
            smid::simulate::write_csv(&r, &path)?;
            println!(
                "{} samples, noise added |η| <= {:.4e} (Δη = {:.4e}); wrote {}",
                r.u.len(),
                r.added,
                r.delta,
                path.display()
            );
        }
        Command::Run { spec, out } => {
            let pb = progress(0, "cells");
            let id = smid::run_spec_file_with(&spec, &|p| cell_progress(&pb, p));
            pb.finish_and_clear();
            let id = match id {
                Ok(smid::Outcome::Consistent(id)) => id,
                Ok(smid::Outcome::Falsified(f)) => {
                    // A finding, not a crash: say so plainly and exit with a distinct code.
                    eprintln!("{}", f.message());
                    std::process::exit(2);
                }
                Err(e) => return Err(e).with_context(|| format!("identifying {}", spec.display())),
            };
            print!("{}", smid::core::report::table(&id));
            let stem = spec
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "smid".into());
            let dir = out.unwrap_or_else(|| PathBuf::from("out").join(stem));
            let parsed = smid::load_spec(&spec)?;
            let files =
                smid::write_run(&id, &parsed, spec.parent().unwrap_or(Path::new(".")), &dir)?;
            println!(
                "wrote {}",
                files
                    .iter()
                    .map(|f| f.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        Command::Reproduce {
            what,
            seeds,
            json,
            shard,
            methods,
        } => {
            anyhow::ensure!(
                what == "paper",
                "unknown reproduction `{what}`; expected one of: paper"
            );
            anyhow::ensure!(seeds >= 1, "--seeds must be at least 1");
            if let (Some(shard), Some(path)) = (shard, &json) {
                let n = smid::montecarlo::shard_seeds(1, seeds, Some(shard)).len();
                let pb = progress(n * smid::reproduce::BITS.len(), "paper Section 6 (shard)");
                let s = smid::sweep::paper_shard(seeds, Some(shard), || pb.inc(1))?;
                pb.finish_and_clear();
                std::fs::write(path, serde_json::to_string_pretty(&s)?)
                    .with_context(|| format!("writing {}", path.display()))?;
                println!(
                    "shard {}/{}: {} runs; wrote {}",
                    shard.0,
                    shard.1,
                    s.runs.len(),
                    path.display()
                );
                return Ok(());
            }
            let pb = progress(seeds * smid::reproduce::BITS.len(), "paper Section 6");
            let r = smid::reproduce::reproduce(seeds, || pb.inc(1))?;
            pb.finish_and_clear();
            print!("{}", smid::reproduce::format_tables(&r));
            if let Some(path) = &json {
                std::fs::write(path, serde_json::to_string_pretty(&r)?)
                    .with_context(|| format!("writing {}", path.display()))?;
            }
            if !methods.is_empty() {
                let ms = methods
                    .iter()
                    .map(|m| parse_method(m))
                    .collect::<Result<Vec<_>>>()?;
                let bits = smid::compare::COMPARE_BITS;
                let pb = progress(seeds * bits.len(), "stage-3 methods");
                let c = smid::compare::compare(seeds, &bits, &ms, || pb.inc(1))?;
                pb.finish_and_clear();
                print!("{}", smid::compare::format_comparison(&c));
                if let Some(path) = json {
                    let path = path.with_extension("methods.json");
                    std::fs::write(&path, serde_json::to_string_pretty(&c)?)
                        .with_context(|| format!("writing {}", path.display()))?;
                }
            }
        }
    }
    Ok(())
}
