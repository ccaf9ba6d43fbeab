//! Finds the plugin crates the facade links: every `[dependencies]` entry of this package's
//! `Cargo.toml` whose path lies under `plugins/` (given here, or through
//! `[workspace.dependencies]` with `workspace = true`). It writes `$OUT_DIR/plugins.rs`, which
//! `src/lib.rs` includes: one `pub use` per crate (`smid-dead-zone` becomes `smid::dead_zone`),
//! which links the crate and with it its registrations, and the list of their package names.
use std::path::Path;

fn main() {
    let manifest =
        Path::new(&std::env::var("CARGO_MANIFEST_DIR").expect("set by cargo")).join("Cargo.toml");
    println!("cargo:rerun-if-changed={}", manifest.display());
    let text = std::fs::read_to_string(&manifest)
        .unwrap_or_else(|e| panic!("{}: {e}", manifest.display()));
    let doc: toml_edit::DocumentMut = text
        .parse()
        .unwrap_or_else(|e| panic!("{}: {e}", manifest.display()));
    let mut plugins = plugin_packages(&doc);
    plugins.sort();
    let mut out = String::new();
    for (key, _) in &plugins {
        let krate = key.replace('-', "_");
        let module = krate.strip_prefix("smid_").unwrap_or(&krate);
        out.push_str(&format!("pub use {krate} as {module};\n"));
    }
    out.push_str(
        "/// The Cargo package names of the plugin crates this facade links (every dependency of\n\
         /// its `Cargo.toml` under `plugins/`), sorted.\n\
         pub const PLUGIN_PACKAGES: &[&str] = &[",
    );
    for (_, package) in &plugins {
        out.push_str(&format!("{package:?}, "));
    }
    out.push_str("];\n");
    let dest = Path::new(&std::env::var("OUT_DIR").expect("set by cargo")).join("plugins.rs");
    std::fs::write(&dest, out).unwrap_or_else(|e| panic!("{}: {e}", dest.display()));
}

/// The `[dependencies]` whose path starts with `plugins/`: each one's key (the crate's name in
/// Rust, dashes for underscores) and its package name.
fn plugin_packages(doc: &toml_edit::DocumentMut) -> Vec<(String, String)> {
    let workspace_path = |name: &str| -> Option<String> {
        doc.get("workspace")?
            .get("dependencies")?
            .get(name)?
            .get("path")?
            .as_str()
            .map(str::to_owned)
    };
    let Some(deps) = doc.get("dependencies").and_then(|d| d.as_table_like()) else {
        return Vec::new();
    };
    deps.iter()
        .filter_map(|(name, item)| {
            let path = match item.get("path").and_then(|p| p.as_str()) {
                Some(p) => Some(p.to_owned()),
                None if item.get("workspace").and_then(|w| w.as_bool()) == Some(true) => {
                    workspace_path(name)
                }
                None => None,
            }?;
            let package = item.get("package").and_then(|p| p.as_str()).unwrap_or(name);
            let under = path.trim_start_matches("./").starts_with("plugins/");
            under.then(|| (name.to_owned(), package.to_owned()))
        })
        .collect()
}
