//! `smid check --shard K/M --json` and `smid check-merge`: the shards of a run
//! are disjoint, cover it, and merge into exactly the table of one machine's run of all the
//! seeds; a shard of another check is refused, and a malformed `--shard` is a clear error.
use std::path::Path;
use std::process::{Command, Output};

fn smid(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_smid"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("smid runs")
}

fn text(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn shards_merge_into_the_one_machine_table() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let common = [
        "check",
        "--trials",
        "7",
        "--method",
        "classical",
        "--jobs",
        "1",
    ];
    let whole = smid(&[&common[..], &["--json", "whole.json"]].concat(), d);
    assert!(
        whole.status.success(),
        "{}",
        String::from_utf8_lossy(&whole.stderr)
    );
    let mut counts = 0;
    for k in 1..=3 {
        let shard = format!("{k}/3");
        let file = format!("s{k}.json");
        let o = smid(
            &[&common[..], &["--shard", &shard, "--json", &file]].concat(),
            d,
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join(&file)).unwrap()).unwrap();
        counts += v["summary"]["trials"].as_u64().unwrap();
    }
    assert_eq!(counts, 7, "the shards cover the run exactly once");
    // Any order of the shard files gives the same table as the whole run.
    let merged = smid(&["check-merge", "s2.json", "s3.json", "s1.json"], d);
    assert!(
        merged.status.success(),
        "{}",
        String::from_utf8_lossy(&merged.stderr)
    );
    assert_eq!(text(&merged), text(&whole));
    assert!(text(&whole).contains("7 trials"), "{}", text(&whole));
}

#[test]
fn a_shard_of_another_check_and_a_bad_shard_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = [
        "check",
        "--trials",
        "2",
        "--method",
        "classical",
        "--jobs",
        "1",
    ];
    assert!(smid(
        &[&a[..], &["--shard", "1/2", "--json", "a.json"]].concat(),
        d
    )
    .status
    .success());
    let b = smid(
        &[
            "check", "--trials", "2", "--method", "shared", "--jobs", "1", "--shard", "2/2",
            "--json", "b.json",
        ],
        d,
    );
    assert!(b.status.success());
    let m = smid(&["check-merge", "a.json", "b.json"], d);
    assert!(!m.status.success());
    let err = String::from_utf8_lossy(&m.stderr);
    assert!(
        err.contains("b.json") && err.contains("another check"),
        "{err}"
    );
    // The same shard twice, or a missing shard: the merge would not be the whole run.
    let twice = smid(&["check-merge", "a.json", "a.json"], d);
    let err = String::from_utf8_lossy(&twice.stderr);
    assert!(
        !twice.status.success() && err.contains("given twice"),
        "{err}"
    );
    let alone = smid(&["check-merge", "a.json"], d);
    let err = String::from_utf8_lossy(&alone.stderr);
    assert!(
        !alone.status.success() && err.contains("2/2 missing"),
        "{err}"
    );
    let bad = smid(&["check", "--shard", "3/2"], d);
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("--shard") && err.contains("K/M"), "{err}");
}

/// `smid reproduce paper --shard K/M --json` and `reproduce-merge`: Tables I-II from the shards
/// are the tables of one machine's run of all the seeds, whatever the order of the files; a
/// missing shard is refused.
#[test]
fn paper_reproduction_shards_merge_into_the_one_machine_tables() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let whole = smid(&["reproduce", "paper", "--seeds", "3"], d);
    assert!(
        whole.status.success(),
        "{}",
        String::from_utf8_lossy(&whole.stderr)
    );
    let mut runs = 0;
    for k in 1..=2 {
        let (shard, file) = (format!("{k}/2"), format!("p{k}.json"));
        let o = smid(
            &[
                "reproduce",
                "paper",
                "--seeds",
                "3",
                "--shard",
                &shard,
                "--json",
                &file,
            ],
            d,
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join(&file)).unwrap()).unwrap();
        runs += v["runs"].as_array().unwrap().len();
    }
    assert_eq!(runs, 3 * 4, "every seed at every bit count, once");
    let merged = smid(&["reproduce-merge", "p2.json", "p1.json"], d);
    assert!(
        merged.status.success(),
        "{}",
        String::from_utf8_lossy(&merged.stderr)
    );
    assert_eq!(text(&merged), text(&whole));
    assert!(
        text(&whole).contains("medians over 3 seeds"),
        "{}",
        text(&whole)
    );
    let missing = smid(&["reproduce-merge", "p1.json"], d);
    assert!(!missing.status.success());
    let err = String::from_utf8_lossy(&missing.stderr);
    assert!(err.contains("2/2") && err.contains("missing"), "{err}");
}
