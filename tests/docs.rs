//! The documentation runs as it reads.
//!
//! Every fenced block of `README.md` and of the guide (`docs/**/*.md`) is read here:
//! - ` ```sh `: each command line (not blank, not starting with `#`) runs from the repository
//!   root with `bash -c`, in order, with the CLI under test first on `PATH` as `smid`; a line
//!   starting with `cargo run --release [--features F] --` runs that binary too. A command must
//!   exit 0, or the code its trailing comment names (`# exit 2`).
//! - ` ```text ` directly after an `sh` block: the standard output of that block's commands,
//!   compared line by line after [`normalise`] (trailing spaces, timings).
//! - ` ```sh,data `: as `sh`, but it reads the measured records beside the clone
//!   (`../shared/data`); without them it is skipped, and the test says so.
//! - ` ```sh,ci `: commands CI runs itself; each line must stand verbatim in `scripts/test`
//!   (or be `scripts/test`, which `.ci/run` runs).
//! - ` ```bash `, ` ```shell `, ` ```console `: refused, so that no shell command escapes the
//!   test by its fence.
//!
//! The other tests here keep the guide whole: every page is in `docs/SUMMARY.md`, every
//! relative link resolves, the README and the code map stay short, and no file speaks of the
//! project's history (build stages, issue numbers).

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// One fenced block of a Markdown file.
#[derive(Debug, Clone)]
struct Block {
    /// The info string after the opening fence, trimmed (`sh`, `text`, `sh,data`, ...).
    info: String,
    /// The lines between the fences.
    body: Vec<String>,
    /// The 1-based line of the opening fence.
    line: usize,
    /// Whether only blank lines separate this block from the previous block's closing fence.
    follows_previous: bool,
}

/// The fenced blocks of a Markdown text, in order. A fence is a line whose first non-space
/// characters are three backticks; the block closes at the next such line without an info
/// string.
fn blocks(text: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut lines = text.lines().enumerate();
    let mut blank_since_close: Option<bool> = None;
    while let Some((i, line)) = lines.next() {
        let trimmed = line.trim_start();
        if let Some(info) = trimmed.strip_prefix("```") {
            let mut body = Vec::new();
            for (_, inner) in lines.by_ref() {
                if inner.trim_start().starts_with("```") {
                    break;
                }
                body.push(inner.to_string());
            }
            out.push(Block {
                info: info.trim().to_string(),
                body,
                line: i + 1,
                follows_previous: blank_since_close == Some(true),
            });
            blank_since_close = Some(true);
        } else if !trimmed.is_empty() {
            blank_since_close = Some(false);
        }
    }
    out
}

/// README.md and every Markdown file of the guide, sorted, as paths relative to the root.
fn documents() -> Vec<PathBuf> {
    let mut files = vec![PathBuf::from("README.md")];
    let mut stack = vec![root().join("docs")];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "md") {
                files.push(path.strip_prefix(root()).unwrap().to_path_buf());
            }
        }
    }
    files.sort();
    files
}

/// What a command's output is compared by: trailing spaces dropped, and every timing (a number
/// followed by `s` or `ms`, with or without a space) written `<t>`.
fn normalise(text: &str) -> Vec<String> {
    text.lines()
        .map(normalise_line)
        .collect::<Vec<_>>()
        .trim_trailing_blank()
}

fn normalise_line(line: &str) -> String {
    let line = line.trim_end();
    let chars: Vec<char> = line.chars().collect();
    let mut out = String::new();
    let mut i = 0;
    while i < chars.len() {
        let starts_number = chars[i].is_ascii_digit() && (i == 0 || !is_word(chars[i - 1]));
        if starts_number {
            let mut j = i;
            while j < chars.len() && (chars[j].is_ascii_digit() || chars[j] == '.') {
                j += 1;
            }
            let mut k = j;
            if k < chars.len() && chars[k] == ' ' {
                k += 1;
            }
            let unit_len = if chars[k..].starts_with(&['m', 's']) {
                2
            } else if chars[k..].starts_with(&['s']) {
                1
            } else {
                0
            };
            let after = k + unit_len;
            if unit_len > 0 && (after == chars.len() || !is_word(chars[after])) {
                out.push_str("<t>");
                i = after;
                continue;
            }
            out.extend(&chars[i..j]);
            i = j;
            continue;
        }
        out.push(chars[i]);
        i += 1;
    }
    out
}

fn is_word(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

trait TrimTrailingBlank {
    fn trim_trailing_blank(self) -> Self;
}

impl TrimTrailingBlank for Vec<String> {
    fn trim_trailing_blank(mut self) -> Self {
        while self.last().is_some_and(|l| l.is_empty()) {
            self.pop();
        }
        self
    }
}

/// The command lines of a shell block: not blank, not a comment.
fn commands(block: &Block) -> Vec<String> {
    block
        .body
        .iter()
        .map(|l| l.trim().to_string())
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .collect()
}

/// A command line split into what runs and the exit code its trailing `# exit N` names.
fn expected_exit(command: &str) -> (String, i32) {
    if let Some((cmd, comment)) = command.rsplit_once(" # ") {
        if let Some(code) = comment.trim().strip_prefix("exit ") {
            if let Ok(code) = code.trim().parse() {
                return (cmd.trim().to_string(), code);
            }
        }
        return (cmd.trim().to_string(), 0);
    }
    (command.to_string(), 0)
}

/// `cargo run --release [--features F] -- ARGS` runs the binary under test as `smid ARGS`.
fn as_binary(command: &str) -> String {
    let Some(rest) = command.strip_prefix("cargo run --release") else {
        return command.to_string();
    };
    let rest = rest.trim_start();
    let rest = match rest.strip_prefix("--features ") {
        Some(r) => r.split_once(' ').map_or("", |(_, tail)| tail).trim_start(),
        None => rest,
    };
    match rest.strip_prefix("--") {
        Some(args) => format!("smid{args}"),
        None => command.to_string(),
    }
}

/// A folder holding `smid`, a link to the binary under test, to put first on `PATH`.
fn bin_dir() -> PathBuf {
    let dir = root().join("target").join("docs-bin");
    std::fs::create_dir_all(&dir).unwrap();
    let link = dir.join("smid");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_smid"), &link).unwrap();
    dir
}

fn data_present() -> bool {
    root().join("../shared/data").is_dir()
}

/// Runs one shell block; returns its standard output, or the failures it met.
fn run_block(doc: &Path, block: &Block, path_var: &str, failures: &mut Vec<String>) -> String {
    let mut stdout = String::new();
    for command in commands(block) {
        let (command, code) = expected_exit(&command);
        let command = as_binary(&command);
        let output = Command::new("bash")
            .arg("-c")
            .arg(&command)
            .current_dir(root())
            .env("PATH", path_var)
            .output()
            .unwrap_or_else(|e| panic!("cannot start bash for `{command}`: {e}"));
        let got = output.status.code().unwrap_or(-1);
        println!("{}:{}: `{command}` exit {got}", doc.display(), block.line);
        if got != code {
            failures.push(format!(
                "{}:{}: `{command}` exited {got}, the docs expect {code}\nstderr:\n{}",
                doc.display(),
                block.line,
                String::from_utf8_lossy(&output.stderr)
            ));
        }
        stdout.push_str(&String::from_utf8_lossy(&output.stdout));
    }
    stdout
}

fn compare(doc: &Path, block: &Block, got: &str, failures: &mut Vec<String>) {
    let want = normalise(&block.body.join("\n"));
    let got = normalise(got);
    if want != got {
        let first = want
            .iter()
            .zip(&got)
            .position(|(w, g)| w != g)
            .unwrap_or(want.len().min(got.len()));
        failures.push(format!(
            "{}:{}: the output shown is not what the commands print (first difference at its \
             line {}):\n--- shown\n{}\n--- printed\n{}",
            doc.display(),
            block.line,
            first + 1,
            want.join("\n"),
            got.join("\n")
        ));
    }
}

#[test]
fn every_command_the_docs_show_runs_and_prints_what_they_show() {
    let path_var = format!(
        "{}:{}",
        bin_dir().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let scripts_test = std::fs::read_to_string(root().join("scripts/test")).unwrap();
    let ci_run = std::fs::read_to_string(root().join(".ci/run")).unwrap();
    let mut failures = Vec::new();
    let mut ran = 0;
    for doc in documents() {
        let text = std::fs::read_to_string(root().join(&doc)).unwrap();
        let all = blocks(&text);
        let mut last_output: Option<String> = None;
        for block in &all {
            let kind = block.info.split_whitespace().next().unwrap_or("");
            match kind {
                "bash" | "shell" | "console" | "zsh" => failures.push(format!(
                    "{}:{}: a ```{kind} block; shell commands go in ```sh, ```sh,data or ```sh,ci \
                     blocks, which this test runs or checks",
                    doc.display(),
                    block.line
                )),
                "sh,ci" => {
                    for command in commands(block) {
                        // `scripts/test` itself is what `.ci/run` runs.
                        let in_ci = if command == "scripts/test" {
                            ci_run.lines().any(|l| l.trim() == "exec scripts/test")
                        } else {
                            scripts_test.lines().any(|l| l.trim() == command)
                        };
                        if !in_ci {
                            failures.push(format!(
                                "{}:{}: `{command}` is shown as run by CI, but scripts/test has \
                                 no such line",
                                doc.display(),
                                block.line
                            ));
                        }
                    }
                    last_output = None;
                    continue;
                }
                "sh" | "sh,data" => {
                    if kind == "sh,data" && !data_present() {
                        println!(
                            "{}:{}: skipped: the measured data (../shared/data) are not beside \
                             this clone",
                            doc.display(),
                            block.line
                        );
                        last_output = None;
                        continue;
                    }
                    last_output = Some(run_block(&doc, block, &path_var, &mut failures));
                    ran += 1;
                    continue;
                }
                "text" if block.follows_previous => {
                    if let Some(got) = &last_output {
                        compare(&doc, block, got, &mut failures);
                    }
                }
                _ => {}
            }
            last_output = None;
        }
    }
    println!("{ran} shell blocks run");
    assert!(ran > 0, "no shell block found in README.md or docs/");
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn the_output_comparison_ignores_timings_only() {
    assert_eq!(
        normalise_line("took 1.25 s, 30ms and 4s."),
        "took <t>, <t> and <t>."
    );
    assert_eq!(
        normalise_line("91 equations, 3 samples  "),
        "91 equations, 3 samples"
    );
    assert_eq!(normalise_line("m_l 0.248000 2s1"), "m_l 0.248000 2s1");
    assert_eq!(normalise_line("x2 s"), "x2 s");
    assert_ne!(normalise("a\n1.0"), normalise("a\n1.1"));
}

#[test]
fn blocks_are_read_with_their_fences_and_neighbours() {
    let text = "intro\n```sh\nsmid run x # exit 2\n# comment\n\n```\n\n```text\nout\n```\nprose\n```text\nno\n```\n";
    let b = blocks(text);
    assert_eq!(b.len(), 3);
    assert_eq!(b[0].info, "sh");
    assert_eq!(commands(&b[0]), vec!["smid run x # exit 2"]);
    assert_eq!(
        expected_exit("smid run x # exit 2"),
        ("smid run x".to_string(), 2)
    );
    assert!(b[1].follows_previous);
    assert!(!b[2].follows_previous);
    assert_eq!(
        as_binary("cargo run --release -- run a.yaml"),
        "smid run a.yaml"
    );
    assert_eq!(
        as_binary("cargo run --release --features fmu -- run a.yaml"),
        "smid run a.yaml"
    );
    assert_eq!(as_binary("scripts/test"), "scripts/test");
}

/// The relative links of a Markdown text: the targets of `](target)` that are not URLs or
/// anchors within the page, without their `#anchor`.
fn relative_links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find("](") {
        rest = &rest[at + 2..];
        let Some(end) = rest.find(')') else { break };
        let target = rest[..end].split_whitespace().next().unwrap_or("");
        let target = target.split('#').next().unwrap_or("");
        if !target.is_empty() && !target.contains("://") && !target.starts_with("mailto:") {
            out.push(target.to_string());
        }
        rest = &rest[end..];
    }
    out
}

#[test]
fn the_guide_is_whole_every_page_listed_every_link_resolving() {
    let summary = std::fs::read_to_string(root().join("docs/SUMMARY.md"))
        .expect("docs/SUMMARY.md, the guide's table of contents");
    let listed: Vec<String> = relative_links(&summary);
    let mut failures = Vec::new();
    for doc in documents() {
        let text = std::fs::read_to_string(root().join(&doc)).unwrap();
        if let Ok(in_docs) = doc.strip_prefix("docs") {
            let name = in_docs.to_string_lossy().to_string();
            if name != "SUMMARY.md" && !listed.contains(&name) {
                failures.push(format!("{}: not listed in docs/SUMMARY.md", doc.display()));
            }
        }
        let dir = root().join(&doc).parent().unwrap().to_path_buf();
        // Links inside code blocks are code, not links.
        let prose: String = strip_code(&text);
        for link in relative_links(&prose) {
            if !dir.join(&link).exists() {
                failures.push(format!(
                    "{}: the link `{link}` leads nowhere",
                    doc.display()
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn strip_code(text: &str) -> String {
    let mut out = String::new();
    let mut inside = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            inside = !inside;
            continue;
        }
        if !inside {
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}

#[test]
fn the_readme_and_the_code_map_stay_short() {
    for (file, most) in [("README.md", 200), ("ARCHITECTURE.md", 300)] {
        let lines = std::fs::read_to_string(root().join(file))
            .unwrap()
            .lines()
            .count();
        assert!(
            lines <= most,
            "{file} has {lines} lines; it keeps to {most}: depth goes in docs/"
        );
    }
}

/// Whether `text` holds a word `stop` or `issue` (or their plurals) followed by one space and a
/// number, with or without a `#`: the numbering of how the project was built, which no file
/// speaks of.
fn names_history(text: &str) -> Option<String> {
    let lower = text.to_lowercase();
    let bytes = lower.as_bytes();
    for word in ["stops", "stop", "issues", "issue"] {
        let mut from = 0;
        while let Some(at) = lower[from..].find(word) {
            let start = from + at;
            let end = start + word.len();
            from = end;
            let starts_word = start == 0 || !(bytes[start - 1] as char).is_alphanumeric();
            let mut rest = &lower[end..];
            if !starts_word || !rest.starts_with(' ') {
                continue;
            }
            rest = rest[1..].strip_prefix('#').unwrap_or(&rest[1..]);
            if rest.starts_with(|c: char| c.is_ascii_digit()) {
                let number: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
                return Some(format!("{word} {number}"));
            }
        }
    }
    None
}

#[test]
fn no_file_speaks_of_how_the_project_was_built() {
    let Ok(listed) = Command::new("git")
        .arg("ls-files")
        .current_dir(root())
        .output()
    else {
        println!("skipped: git is not available to list the tracked files");
        return;
    };
    if !listed.status.success() {
        println!("skipped: not a git checkout");
        return;
    }
    let mut failures = Vec::new();
    for file in String::from_utf8_lossy(&listed.stdout).lines() {
        let Ok(text) = std::fs::read_to_string(root().join(file)) else {
            continue;
        };
        for (i, line) in text.lines().enumerate() {
            if let Some(words) = names_history(line) {
                failures.push(format!("{file}:{}: `{words}`", i + 1));
            }
        }
    }
    // Built from parts, so that this file holds no such phrase itself.
    assert!(names_history(&format!("the guard of {} 12 holds", "stop")).is_some());
    assert!(names_history(&format!("{} #7", "Issue")).is_some());
    assert!(names_history("a stop condition at 3 rounds").is_none());
    assert!(names_history("below `stop` (0: run to the end)").is_none());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_readme_picture_is_what_the_quickstart_draws() {
    let out = tempfile::tempdir().unwrap();
    let status = Command::new(env!("CARGO_BIN_EXE_smid"))
        .args(["run", "examples/paper.yaml", "--out"])
        .arg(out.path())
        .current_dir(root())
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let drawn = std::fs::read_to_string(out.path().join("region_left_branch.svg")).unwrap();
    let shown = std::fs::read_to_string(root().join("docs/img/paper-left-branch.svg")).unwrap();
    assert!(
        drawn == shown,
        "docs/img/paper-left-branch.svg is stale: regenerate it with `smid run examples/paper.yaml \
         --out out/paper` and copy out/paper/region_left_branch.svg there"
    );
}
