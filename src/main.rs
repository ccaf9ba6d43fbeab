//! The `smid` command line: `run` a YAML spec, `simulate` its plant to CSV, `reproduce paper`
//! (Tables I-II), `check` (Monte Carlo containment). anyhow is used only here, at the edge.
#![forbid(unsafe_code)]

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;

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
    /// (y = w + noise, w noise-free), readable by a diagnosis spec.
    Simulate {
        spec: PathBuf,
        /// Output directory (default: out/<spec name>).
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
        /// Also write the medians as JSON.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Also compare stage-3 methods on the same data (comma-separated: classical, shared,
        /// sdp, exact-grid): a radius table per method and n_bit, with the ratio to the exact set.
        #[arg(long, value_delimiter = ',')]
        methods: Vec<String>,
    },
    /// Print the JSON Schema of the spec (every registered plugin `type`); the committed copy is
    /// `schemas/smid-spec.schema.json` (with `--diagnose`: of validate/diagnose specs,
    /// `schemas/smid-diagnose.schema.json`).
    Schema {
        #[arg(long)]
        diagnose: bool,
    },
    /// Monte Carlo containment check: random systems, backlash and noise; every bound must hold.
    Check {
        #[arg(long, default_value_t = 1000)]
        trials: usize,
        #[arg(long, default_value_t = 1)]
        first_seed: u64,
        /// Nonlinearity plugin to check: output_backlash, input_backlash, dead_zone_input,
        /// dead_zone_output or saturation.
        #[arg(long, default_value = "output_backlash")]
        plugin: String,
        /// Stage-3 method (classical, shared, sdp, exact-grid; default: the spec default).
        #[arg(long)]
        method: Option<String>,
        /// Trials run in parallel (default: the number of cores).
        #[arg(long)]
        jobs: Option<usize>,
    },
    /// Validate a LIP model set (a diagnosis spec) on fresh data: residual, falsification
    /// share against the guaranteed band ± Δ, residual correlations, smallest consistent bound.
    Validate {
        spec: PathBuf,
        /// Held-out CSV (default: the spec's held-out records).
        #[arg(long)]
        data: Option<PathBuf>,
        /// Output directory (default: out/<spec name>/validate).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Trace a failed validation to missing effects: rank every effect plugin by held-out
    /// error, write the augmented spec and before/after report.
    Diagnose {
        spec: PathBuf,
        /// Training CSV (default: the spec's training records).
        #[arg(long)]
        data: Option<PathBuf>,
        /// Held-out CSV (default: the spec's held-out records, else the last 30% of each).
        #[arg(long)]
        holdout: Option<PathBuf>,
        /// Output directory (default: out/<spec name>/diagnose).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Release-mode check of the diagnosis: per effect, simulated data with the effect present
    /// but undeclared; the diagnosis must name it (>= 9 of 10).
    DiagnoseCheck {
        #[arg(long, default_value_t = 10)]
        trials: usize,
        #[arg(long, default_value_t = 1)]
        first_seed: u64,
        /// Only these effect tags (comma-separated).
        #[arg(long, value_delimiter = ',')]
        only: Vec<String>,
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

/// A stage-3 method by its spec name.
/// `--jobs`, else the number of cores.
fn jobs_or_cores(jobs: Option<usize>) -> usize {
    jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1)
}

fn parse_method(m: &str) -> Result<smid::core::spec::EivMethod> {
    smid::core::spec::EivMethod::from_name(m.trim()).with_context(|| {
        format!("unknown stage-3 method `{m}`; expected one of: classical, shared, sdp, exact-grid")
    })
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

fn main() {
    if let Err(e) = real_main() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn real_main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Schema { diagnose: false } => print!("{}", smid::core::registry::spec_schema()),
        Command::Schema { diagnose: true } => print!("{}", smid_diagnose::spec::schema()),
        Command::Check {
            trials,
            first_seed,
            ref plugin,
            ref method,
            jobs,
        } => {
            let method = method.as_deref().map(parse_method).transpose()?;
            let pb = progress(trials, plugin);
            let s = smid::plugin_check::run(
                plugin,
                first_seed,
                trials,
                method,
                jobs_or_cores(jobs),
                || pb.inc(1),
            )?;
            println!("stage-3 method: {}", method.unwrap_or_default().name());
            pb.finish_and_clear();
            print!("{}", smid::plugin_check::report(plugin, &s));
            anyhow::ensure!(
                s.missed.is_empty(),
                "{} trials missed the truth",
                s.missed.len()
            );
        }
        Command::Validate { spec, data, out } => {
            smid::link_plugins();
            let dir = out.unwrap_or_else(|| out_dir(&spec, "validate"));
            let (text, a, files) = smid::diagnose::commands::validate(&spec, data.as_deref(), &dir)
                .with_context(|| format!("validating {}", spec.display()))?;
            print!("{text}");
            println!("wrote {}", join(&files));
            if !smid::diagnose::validate::passes(&a) {
                std::process::exit(3);
            }
        }
        Command::Diagnose {
            spec,
            data,
            holdout,
            out,
        } => {
            smid::link_plugins();
            let dir = out.unwrap_or_else(|| out_dir(&spec, "diagnose"));
            let pb = progress(1, "candidate effects");
            let (text, _, files) = smid::diagnose::commands::diagnose(
                &spec,
                data.as_deref(),
                holdout.as_deref(),
                &dir,
                |done, total| {
                    pb.set_length(total as u64);
                    pb.set_position(done as u64);
                },
            )
            .with_context(|| format!("diagnosing {}", spec.display()))?;
            pb.finish_and_clear();
            print!("{text}");
            println!("wrote {}", join(&files));
        }
        Command::DiagnoseCheck {
            trials,
            first_seed,
            only,
        } => {
            smid::link_plugins();
            let n = smid::diagnose::effect::effects()
                .iter()
                .filter(|e| only.is_empty() || only.iter().any(|t| t == e.tag))
                .count();
            let pb = progress(n * trials, "diagnosis trials");
            let checks = smid::diagnose::check::run(trials, first_seed, &only, || pb.inc(1))?;
            pb.finish_and_clear();
            print!("{}", smid::diagnose::check::format(&checks));
            let bad: Vec<&str> = checks
                .iter()
                .filter(|c| 10 * c.named < 9 * c.trials)
                .map(|c| c.tag.as_str())
                .collect();
            anyhow::ensure!(
                bad.is_empty(),
                "named in fewer than 9 of 10 trials: {}",
                bad.join(", ")
            );
        }
        Command::Simulate {
            spec,
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
            let id = match smid::run_spec_file(&spec) {
                Ok(id) => id,
                Err(e @ smid::SmidError::Inconsistent { .. }) => {
                    // A finding, not a crash: say so plainly and exit with a distinct code.
                    eprintln!("{e}");
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
            let files = smid::core::report::write_all(&id, &dir)?;
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
            methods,
        } => {
            anyhow::ensure!(
                what == "paper",
                "unknown reproduction `{what}`; expected one of: paper"
            );
            anyhow::ensure!(seeds >= 1, "--seeds must be at least 1");
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
