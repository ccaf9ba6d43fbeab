//! `smid reproduce paper`: Section 6 of the paper for `n_bit` in {15, 12, 10, 8} over several
//! seeds, laid out like Tables I and II with the paper's values beside the medians over seeds and
//! the count of runs whose bounds contain the truth.
use smid_core::pipeline;
use smid_core::spec::Spec;
use smid_core::Result;
use std::fmt::Write as _;
use std::path::Path;

/// The bundled Section 6 spec.
pub const PAPER_SPEC: &str = include_str!("../examples/paper.yaml");

/// Table I: (n_bit, name, center, radius) from the paper.
pub const TABLE_I: &[(u32, &str, f64, f64)] = &[
    (15, "m_l", 0.2481, 1.1e-4),
    (15, "c_l", 0.0702, 4.8e-4),
    (15, "m_r", 0.2520, 2.1e-5),
    (15, "c_r", 0.0349, 1.0e-4),
    (12, "m_l", 0.2474, 6.6e-4),
    (12, "c_l", 0.0678, 2.4e-3),
    (12, "m_r", 0.2521, 1.3e-4),
    (12, "c_r", 0.0354, 7.0e-4),
    (10, "m_l", 0.2503, 2.8e-3),
    (10, "c_l", 0.0825, 1.6e-2),
    (10, "m_r", 0.2513, 8.0e-4),
    (10, "c_r", 0.0306, 5.2e-3),
    (8, "m_l", 0.2475, 2.9e-3),
    (8, "c_l", 0.0655, 1.8e-2),
    (8, "m_r", 0.2615, 1.1e-2),
    (8, "c_r", 0.0625, 3.7e-2),
];

/// Table II: (n_bit, SNR, name, center, radius); θ1..θ4 are a1, a2, b1, b2.
pub const TABLE_II: &[(u32, f64, &str, f64, f64)] = &[
    (15, 73.2, "a1", 0.500, 4.3e-4),
    (15, 73.2, "a2", 0.700, 2.5e-4),
    (15, 73.2, "b1", 1.400, 4.3e-4),
    (15, 73.2, "b2", 0.800, 7.2e-4),
    (12, 56.2, "a1", 0.500, 4.8e-3),
    (12, 56.2, "a2", 0.700, 2.8e-3),
    (12, 56.2, "b1", 1.400, 8.7e-3),
    (12, 56.2, "b2", 0.800, 1.0e-2),
    (10, 43.0, "a1", 0.503, 1.8e-2),
    (10, 43.0, "a2", 0.698, 1.9e-2),
    (10, 43.0, "b1", 1.400, 4.2e-2),
    (10, 43.0, "b2", 0.806, 4.6e-2),
    (8, 30.9, "a1", 0.510, 6.9e-2),
    (8, 30.9, "a2", 0.706, 5.3e-2),
    (8, 30.9, "b1", 1.410, 1.1e-1),
    (8, 30.9, "b2", 0.805, 1.2e-1),
];

/// The bit counts of the tables.
pub const BITS: [u32; 4] = [15, 12, 10, 8];

/// The Section 6 spec at `bits` and `seed`.
pub fn paper_spec(bits: u32, seed: u64) -> Result<Spec> {
    let mut spec = Spec::parse(PAPER_SPEC, Path::new("examples/paper.yaml"))?;
    spec.noise.encoder_bits = Some(bits);
    spec.noise.delta = None;
    spec.experiment.seed = seed;
    Ok(spec)
}

/// Medians over seeds of one parameter at one bit count.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Row {
    /// Encoder resolution `n_bit` (15, 12, 10 or 8).
    pub bits: u32,
    /// The parameter's name.
    pub name: String,
    /// The parameter's true value.
    pub truth: f64,
    /// The centre the paper's Table I or II reports.
    pub paper_center: f64,
    /// The radius the paper's Table I or II reports.
    pub paper_radius: f64,
    /// Median over seeds of smid's centre.
    pub median_center: f64,
    /// Median over seeds of smid's radius.
    pub median_radius: f64,
    /// Runs whose bound contains the truth.
    pub contained: usize,
    /// Runs at this bit count (one per seed).
    pub runs: usize,
}

/// All results of a reproduction.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Reproduction {
    /// Seeds run per bit count.
    pub seeds: usize,
    /// One row per bit count and parameter, in table order.
    pub rows: Vec<Row>,
    /// Median SNR per bit count.
    pub snr: Vec<(u32, f64)>,
    /// Runs that ended in an error: (bits, seed, message).
    pub errors: Vec<(u32, u64, String)>,
}

/// Median (NaN for no values).
pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// One identification of the reproduction: Section 6 at one bit count and seed.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PaperRun {
    /// Encoder resolution `n_bit`.
    pub bits: u32,
    /// The experiment's seed.
    pub seed: u64,
    /// `Err`: the message of a run that ended in an error.
    pub outcome: std::result::Result<PaperBounds, String>,
}

/// The figures Tables I-II take from one identification.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PaperBounds {
    /// Signal-to-noise ratio of the dynamic record, in dB.
    pub snr_db: f64,
    /// (name, truth, center, radius) of each parameter of the tables.
    pub parameters: Vec<(String, Option<f64>, f64, f64)>,
    /// Every bound contains the truth.
    pub contained: bool,
}

/// The names of the tables' parameters, in table order.
fn table_names() -> Vec<&'static str> {
    let mut names: Vec<&str> = Vec::new();
    for n in TABLE_I
        .iter()
        .map(|r| r.1)
        .chain(TABLE_II.iter().map(|r| r.2))
    {
        if !names.contains(&n) {
            names.push(n);
        }
    }
    names
}

/// Identify Section 6 for every bit count and each of `seeds`, calling `tick` after each run.
pub fn runs(seeds: &[u64], tick: &mut dyn FnMut()) -> Result<Vec<PaperRun>> {
    let names = table_names();
    let mut out = Vec::new();
    for bits in BITS {
        for &seed in seeds {
            let spec = paper_spec(bits, seed)?;
            let outcome = match pipeline::run(&spec, Path::new("."))
                .and_then(smid_core::Outcome::into_result)
            {
                Ok(id) => Ok(PaperBounds {
                    snr_db: id.snr_db,
                    parameters: names
                        .iter()
                        .filter_map(|n| {
                            id.parameter(n)
                                .map(|p| (n.to_string(), p.truth, p.center, p.radius))
                        })
                        .collect(),
                    contained: id.all_contain_truth() == Some(true),
                }),
                Err(e) => Err(e.to_string()),
            };
            out.push(PaperRun {
                bits,
                seed,
                outcome,
            });
            tick();
        }
    }
    Ok(out)
}

/// Tables I-II (medians over the runs of each bit count) from the runs of seeds `1..=seeds`,
/// in any order: the runs are taken in seed order, so shards merge into the one-machine tables.
pub fn tables(seeds: usize, runs: &[PaperRun]) -> Reproduction {
    let mut sorted: Vec<&PaperRun> = runs.iter().collect();
    sorted.sort_by_key(|r| (r.bits, r.seed));
    let mut rows = Vec::new();
    let mut snr = Vec::new();
    let mut errors = Vec::new();
    for bits in BITS {
        let mut ok: Vec<&PaperBounds> = Vec::new();
        for r in sorted.iter().filter(|r| r.bits == bits) {
            match &r.outcome {
                Ok(b) => ok.push(b),
                Err(e) => errors.push((bits, r.seed, e.clone())),
            }
        }
        snr.push((
            bits,
            median(&mut ok.iter().map(|r| r.snr_db).collect::<Vec<_>>()),
        ));
        let paper: Vec<(&str, f64, f64)> = TABLE_I
            .iter()
            .filter(|r| r.0 == bits)
            .map(|r| (r.1, r.2, r.3))
            .chain(
                TABLE_II
                    .iter()
                    .filter(|r| r.0 == bits)
                    .map(|r| (r.2, r.3, r.4)),
            )
            .collect();
        for (name, pc, pr) in paper {
            let ps: Vec<_> = ok
                .iter()
                .filter_map(|r| r.parameters.iter().find(|p| p.0 == name))
                .collect();
            rows.push(Row {
                bits,
                name: name.to_string(),
                truth: ps.first().and_then(|p| p.1).unwrap_or(f64::NAN),
                paper_center: pc,
                paper_radius: pr,
                median_center: median(&mut ps.iter().map(|p| p.2).collect::<Vec<_>>()),
                median_radius: median(&mut ps.iter().map(|p| p.3).collect::<Vec<_>>()),
                contained: ok.iter().filter(|r| r.contained).count(),
                runs: seeds,
            });
        }
    }
    Reproduction {
        seeds,
        rows,
        snr,
        errors,
    }
}

/// Run the paper for every bit count and seeds `1..=seeds`, calling `tick` after each run.
pub fn reproduce(seeds: usize, mut tick: impl FnMut()) -> Result<Reproduction> {
    let all: Vec<u64> = (1..=seeds as u64).collect();
    Ok(tables(seeds, &runs(&all, &mut tick)?))
}

/// Tables I and II side by side with the paper.
pub fn format_tables(r: &Reproduction) -> String {
    let mut s = String::new();
    for (title, names) in [
        ("Table I: nonlinear block (γ)", ["m_l", "c_l", "m_r", "c_r"]),
        (
            "Table II: linear block (θ), N = 100",
            ["a1", "a2", "b1", "b2"],
        ),
    ] {
        let _ = writeln!(s, "{title}; medians over {} seeds", r.seeds);
        let _ = writeln!(
            s,
            "{:>5} {:>9} {:>5} {:>8} {:>9} {:>9} {:>9} {:>9} {:>10}",
            "n_bit",
            "SNR(dB)",
            "param",
            "true",
            "paper c",
            "smid c",
            "paper Δ",
            "smid Δ",
            "contained"
        );
        for bits in BITS {
            let snr = r
                .snr
                .iter()
                .find(|x| x.0 == bits)
                .map(|x| x.1)
                .unwrap_or(f64::NAN);
            let paper_snr = TABLE_II
                .iter()
                .find(|x| x.0 == bits)
                .map(|x| x.1)
                .unwrap_or(f64::NAN);
            for row in r
                .rows
                .iter()
                .filter(|x| x.bits == bits && names.contains(&x.name.as_str()))
            {
                let _ = writeln!(
                    s,
                    "{:>5} {:>9} {:>5} {:>8.4} {:>9.4} {:>9.4} {:>9.1e} {:>9.1e} {:>10}",
                    bits,
                    format!("{snr:.1}/{paper_snr:.1}"),
                    row.name,
                    row.truth,
                    row.paper_center,
                    row.median_center,
                    row.paper_radius,
                    row.median_radius,
                    format!("{}/{}", row.contained, row.runs)
                );
            }
        }
        s.push('\n');
    }
    if !r.errors.is_empty() {
        let _ = writeln!(s, "runs that ended in an error:");
        for (b, seed, e) in &r.errors {
            let _ = writeln!(s, "  n_bit {b}, seed {seed}: {e}");
        }
    }
    s
}
