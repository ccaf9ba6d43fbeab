//! The stage-3 scaling table (docs/performance.md): for each method and record length `N`, the whole
//! identification of `examples/paper.yaml` (na = nb = 2) or `examples/order4.yaml`
//! (na = nb = 4) with `experiment.dynamic.length = N`, run as `smid run` does it (experiments,
//! stages 1-3, `result.json`, `data.csv`, plots) in a **child process**; the table gives its
//! wall time, its peak memory (the child's `VmHWM` from `/proc/self/status`) and the growth
//! exponent `log10(t(10N) / t(N))` (1 is linear).
//!
//! ```sh
//! cargo run --release --example scaling                      # every method, N = 1e3, 1e4, 1e5
//! cargo run --release --example scaling -- --methods shared --sizes 1000,10000 --order 4
//! cargo run --release --features sdp --example scaling       # with the moment relaxation
//! ```
//!
//! Options: `--methods a,b` (default: every method this build has), `--sizes n1,n2,...`
//! (default 1000,10000,100000), `--order 2|4` (default 2), `--limit SECONDS` (a run still
//! going after this is stopped and shown as `>limit`; default 600). Each run is one process,
//! so one method's memory does not count against another's.
use smid::core::spec::EivMethod;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Peak resident memory of this process (kB), from `/proc/self/status`.
fn vm_hwm_kb() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    s.lines()
        .find(|l| l.starts_with("VmHWM:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()
}

/// The child: identify `spec` with method `m` and length `n`, write the outputs to a
/// temporary directory, print `ok <peak kB>` (or `err <message>`).
fn child(spec_path: &str, m: &str, n: usize) {
    smid::link_plugins();
    let run = || -> smid::Result<()> {
        let path = Path::new(spec_path);
        let mut spec = smid::load_spec(path)?;
        spec.experiment.dynamic.length = n;
        spec.method.eiv = EivMethod::from_name(m)
            .ok_or_else(|| smid::SmidError::invalid("method", format!("unknown method {m}")))?;
        let id = smid::run_spec(&spec, path.parent().unwrap_or(Path::new(".")), &|_| {})?
            .into_result()?;
        let dir = std::env::temp_dir().join(format!("smid-scaling-{}", std::process::id()));
        smid::write_run(
            &id,
            &spec,
            path.parent().unwrap_or(std::path::Path::new(".")),
            &dir,
        )?;
        let _ = std::fs::remove_dir_all(&dir);
        Ok(())
    };
    match run() {
        Ok(()) => println!("ok {}", vm_hwm_kb().unwrap_or(0)),
        Err(e) => println!("err {e}"),
    }
}

struct Cell {
    secs: Option<f64>,
    kb: Option<u64>,
    note: String,
}

fn measure(spec: &str, m: &str, n: usize, limit: Duration) -> Cell {
    let exe = std::env::current_exe().expect("own path");
    let start = Instant::now();
    let mut c = match Command::new(exe)
        .args(["--child", spec, m, &n.to_string()])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
    {
        Ok(c) => c,
        Err(e) => {
            return Cell {
                secs: None,
                kb: None,
                note: e.to_string(),
            }
        }
    };
    loop {
        match c.try_wait() {
            Ok(Some(_)) => break,
            Ok(None) if start.elapsed() > limit => {
                let _ = c.kill();
                let _ = c.wait();
                return Cell {
                    secs: None,
                    kb: None,
                    note: format!(">{}s", limit.as_secs()),
                };
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => {
                return Cell {
                    secs: None,
                    kb: None,
                    note: e.to_string(),
                }
            }
        }
    }
    let secs = start.elapsed().as_secs_f64();
    let mut out = String::new();
    use std::io::Read;
    if let Some(mut o) = c.stdout.take() {
        let _ = o.read_to_string(&mut out);
    }
    let out = out.trim();
    match out.strip_prefix("ok ") {
        Some(kb) => Cell {
            secs: Some(secs),
            kb: kb.parse().ok(),
            note: String::new(),
        },
        None => Cell {
            secs: None,
            kb: None,
            note: out.chars().take(60).collect(),
        },
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("--child") {
        let n = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(1000);
        child(&args[2], &args[3], n);
        return;
    }
    let opt = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let methods: Vec<String> = opt("--methods")
        .map(|s| s.split(',').map(str::to_string).collect())
        .unwrap_or_else(|| {
            EivMethod::registered()
                .into_iter()
                .filter(|m| m.available())
                .map(|m| m.name().to_string())
                .collect()
        });
    let sizes: Vec<usize> = opt("--sizes")
        .map(|s| s.split(',').filter_map(|v| v.parse().ok()).collect())
        .unwrap_or_else(|| vec![1000, 10_000, 100_000]);
    let order = opt("--order").unwrap_or_else(|| "2".into());
    let spec = if order == "4" {
        "examples/order4.yaml"
    } else {
        "examples/paper.yaml"
    };
    let limit = Duration::from_secs(opt("--limit").and_then(|s| s.parse().ok()).unwrap_or(600));
    println!(
        "stage-3 scaling: {spec} (na = nb = {order}), whole process per run, {} cores",
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    println!(
        "{:<12} {:>8} {:>10} {:>10} {:>9}",
        "method", "N", "time [s]", "peak [MB]", "exponent"
    );
    for m in &methods {
        let mut prev: Option<(usize, f64)> = None;
        for &n in &sizes {
            let c = measure(spec, m, n, limit);
            let exp = match (prev, c.secs) {
                (Some((pn, pt)), Some(t)) if pt > 0.0 => {
                    format!("{:.2}", (t / pt).ln() / (n as f64 / pn as f64).ln())
                }
                _ => String::new(),
            };
            println!(
                "{:<12} {:>8} {:>10} {:>10} {:>9} {}",
                m,
                n,
                c.secs.map_or("-".into(), |t| format!("{t:.2}")),
                c.kb.map_or("-".into(), |k| format!("{:.0}", k as f64 / 1024.0)),
                exp,
                c.note
            );
            prev = c.secs.map(|t| (n, t));
        }
    }
}
