//! Section 6 of the paper: the filter pole of the Appendix, insta snapshots pinning the bounds
//! of `examples/paper.yaml` at fixed seeds, and the agreement with Tables I-II that the
//! output-backlash issue asks for (medians over seeds, n_bit = 15 and 12).
use smid::reproduce::{paper_spec, TABLE_I, TABLE_II};
use smid_core::pipeline;
use smid_core::spec::EivMethod;
use std::path::Path;

fn run(bits: u32, seed: u64) -> pipeline::Identification {
    let mut spec = paper_spec(bits, seed).unwrap();
    spec.method.eiv = EivMethod::Classical;
    pipeline::run(&spec, Path::new(".")).unwrap().unwrap()
}

#[test]
fn appendix_search_returns_the_papers_pole() {
    let id = run(15, 1);
    let f = id.data.filter.as_ref().unwrap();
    assert_eq!(f.pole, 0.8125, "trials: {:?}", f.trials);
    // the last pole tried passed here; the pole returned is the last one that passed
    assert!(f.trials.iter().any(|t| t.pole == 0.75 && !t.passed));
}

/// Rounded view of the bounds for snapshots (6 significant digits).
fn view(id: &pipeline::Identification) -> Vec<String> {
    id.parameters()
        .iter()
        .map(|p| {
            format!(
                "{:<3} [{:.6e}, {:.6e}] contains={:?}",
                p.name, p.lower, p.upper, p.contains
            )
        })
        .collect()
}

#[test]
fn paper_bounds_are_pinned() {
    for (bits, seed) in [(15, 1), (12, 2), (8, 3)] {
        insta::assert_yaml_snapshot!(
            format!("paper_{bits}bit_seed{seed}"),
            view(&run(bits, seed))
        );
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
fn tables_one_and_two_are_reproduced_at_15_and_12_bits() {
    for bits in [15u32, 12] {
        let runs: Vec<_> = (1..=9).map(|s| run(bits, s)).collect();
        for r in &runs {
            assert_eq!(
                r.all_contain_truth(),
                Some(true),
                "n_bit {bits}: {}",
                smid_core::report::table(r)
            );
        }
        let med = |name: &str, f: fn(&pipeline::ParamResult) -> f64| {
            median(runs.iter().map(|r| f(r.parameter(name).unwrap())).collect())
        };
        for &(b, name, _c, paper_radius) in TABLE_I.iter().filter(|r| r.0 == bits) {
            let radius = med(name, |p| p.radius);
            let center = med(name, |p| p.center);
            let truth = runs[0].parameter(name).unwrap().truth.unwrap();
            assert!(
                radius < 10.0 * paper_radius && radius > paper_radius / 10.0,
                "{b} bits {name}: radius {radius:e} vs paper {paper_radius:e}"
            );
            assert!(
                (center - truth).abs() <= radius.max(paper_radius),
                "{b} bits {name}: center {center} vs truth {truth}"
            );
        }
        for &(b, _snr, name, _c, paper_radius) in TABLE_II.iter().filter(|r| r.0 == bits) {
            let radius = med(name, |p| p.radius);
            let center = med(name, |p| p.center);
            let truth = runs[0].parameter(name).unwrap().truth.unwrap();
            assert!(
                radius < 3.0 * paper_radius && radius > paper_radius / 3.0,
                "{b} bits {name}: radius {radius:e} vs paper {paper_radius:e}"
            );
            // Table II shows three decimals
            assert!(
                (center - truth).abs() < 5e-4 + radius / 2.0,
                "{b} bits {name}: center {center} vs truth {truth}"
            );
        }
    }
}

#[test]
fn snr_lands_near_table_two() {
    for &(bits, snr) in &[(15u32, 73.2), (12, 56.2), (10, 43.0), (8, 30.9)] {
        let s = median((1..=5).map(|seed| run(bits, seed).snr_db).collect());
        assert!((s - snr).abs() < 2.0, "{bits} bits: SNR {s} vs paper {snr}");
    }
}

/// The stage-3 issue's criterion: on the Section 6 example, for n_bit in {12, 10, 8}, the
/// default method's median radius per parameter is within 1.25 times the exact set's. The exact
/// set's radius is measured from below by the inner hull of consistent points (so the ratio
/// checked is an upper bound of the true one). 5 seeds here; `smid reproduce paper --methods
/// shared,exact-grid` runs 20.
#[test]
fn default_method_is_within_1_25_of_the_exact_set() {
    use smid::compare::{compare, COMPARE_BITS};
    let methods = [EivMethod::default(), EivMethod::ExactGrid];
    let c = compare(5, &COMPARE_BITS, &methods, || {}).unwrap();
    assert!(c.errors.is_empty(), "{:?}", c.errors);
    let default = methods[0].name();
    let mut checked = 0;
    for r in c
        .rows
        .iter()
        .filter(|r| r.method == default && r.median_radius > 0.0)
    {
        let exact = c
            .rows
            .iter()
            .find(|e| e.method == "exact-grid" && e.bits == r.bits && e.name == r.name)
            .and_then(|e| e.median_inner_radius)
            .unwrap_or_else(|| panic!("no exact inner hull for {} at {} bits", r.name, r.bits));
        let ratio = r.median_radius / exact;
        assert!(
            ratio <= 1.25,
            "{} at {} bits: {default} radius {:.3e} is {ratio:.2}x the exact set's {exact:.3e}",
            r.name,
            r.bits,
            r.median_radius
        );
        assert_eq!(r.contained, r.runs, "{} at {} bits", r.name, r.bits);
        checked += 1;
    }
    assert_eq!(
        checked,
        4 * COMPARE_BITS.len(),
        "a1, a2, b1, b2 at each n_bit"
    );
}

/// With the feature `sdp`: `examples/paper-sdp.yaml` contains the truth and is never wider than
/// the default (shared) method on the same data.
#[test]
fn sdp_on_the_paper_example_is_within_shared_and_contains_the_truth() {
    if !smid::sdp::AVAILABLE {
        println!("skipped: this build has no feature `sdp`");
        return;
    }
    let sdp = smid::run_spec_file(Path::new("examples/paper-sdp.yaml"))
        .unwrap()
        .unwrap();
    let mut spec = smid::load_spec(Path::new("examples/paper-sdp.yaml")).unwrap();
    spec.method.eiv = EivMethod::Shared;
    let shared = pipeline::run(&spec, Path::new("examples"))
        .unwrap()
        .unwrap();
    assert_eq!(sdp.all_contain_truth(), Some(true));
    for name in ["a1", "a2", "b1", "b2"] {
        let (s, h) = (
            sdp.parameter(name).unwrap(),
            shared.parameter(name).unwrap(),
        );
        assert!(
            h.lower <= s.lower && s.upper <= h.upper,
            "{name}: sdp [{}, {}] wider than shared [{}, {}]",
            s.lower,
            s.upper,
            h.lower,
            h.upper
        );
    }
}
