//! The plugin registry and the spec's JSON Schema: every registered `type` round-trips through
//! YAML, the committed schema (`schemas/smid-spec.schema.json`) is the one the Rust types
//! generate and its defaults are the spec's, the committed spec reference
//! (`docs/reference/spec.md`) is the one `smid schema --markdown` prints, every example names
//! the schema and validates its `type`s, and the core names no plugin (a plugin, such as
//! `plugins/example-gain`, is added without editing `smid-core`).
use smid::core::nonlinearity::{Nonlinearity, NonlinearityModel};
use smid::core::registry;
use smid::core::spec::Spec;
use std::path::{Path, PathBuf};

mod common;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every plugin crate the `smid` facade links registered itself (a dropped registration fails
/// here): the list is what the facade's `build.rs` read from its `Cargo.toml` (every
/// dependency under `plugins/`), and each package must have registered a model, a simulation
/// nonlinearity or an effect in the binary; every model has its simulation nonlinearity.
#[test]
fn every_bundled_plugin_is_registered() {
    let bundled = smid::bundled_plugins();
    assert!(bundled.len() >= 7, "{bundled:?}");
    let manifest = std::fs::read_to_string(root().join("Cargo.toml")).unwrap();
    for p in &bundled {
        assert!(
            manifest.contains(&format!("{p} = {{ path = \"plugins/"))
                || manifest.contains(&format!("{p}.workspace = true")),
            "{p} is not a dependency of the facade's Cargo.toml"
        );
        let models = registry::models().iter().filter(|e| e.package == p).count();
        let sims = registry::nonlinearities()
            .iter()
            .filter(|e| e.package == p)
            .count();
        let effects = smid::core::effect::effects()
            .iter()
            .filter(|e| e.package == p)
            .count();
        assert!(
            models + sims + effects > 0,
            "{p} is linked but registered nothing"
        );
    }
    for m in registry::models() {
        assert!(
            bundled.iter().any(|p| p == m.package) || m.package == "smid-core",
            "{} registered by {}, which the facade does not list",
            m.tag,
            m.package
        );
        assert!(
            registry::nonlinearity_types().contains(&m.tag),
            "{} (model) has no simulation nonlinearity",
            m.tag
        );
    }
}

#[test]
fn every_registered_type_round_trips_through_yaml() {
    for e in registry::nonlinearities() {
        let v = (e.example)();
        v.validate()
            .unwrap_or_else(|err| panic!("{}: example invalid: {err}", e.tag));
        let yaml = serde_norway::to_string(&v).unwrap();
        assert!(
            yaml.contains(&format!("type: {}", e.tag)),
            "{}: tag mismatch in {yaml}",
            e.tag
        );
        let back: Box<dyn Nonlinearity> = serde_norway::from_str(&yaml).unwrap();
        assert_eq!(serde_norway::to_string(&back).unwrap(), yaml, "{}", e.tag);
        assert_eq!(back.parameters(), v.parameters(), "{}", e.tag);
    }
    for e in registry::models() {
        let v = (e.example)();
        let yaml = serde_norway::to_string(&v).unwrap();
        assert!(
            yaml.contains(&format!("type: {}", e.tag)),
            "{}: tag mismatch in {yaml}",
            e.tag
        );
        let back: Box<dyn NonlinearityModel> = serde_norway::from_str(&yaml).unwrap();
        assert_eq!(serde_norway::to_string(&back).unwrap(), yaml, "{}", e.tag);
    }
}

fn examples() -> Vec<PathBuf> {
    common::yaml_files(&root().join("examples"))
}

const SPEC_SCHEMA_LINE: &str = "# yaml-language-server: $schema=../schemas/smid-spec.schema.json\n";

/// The examples that are identification specs (they name the spec schema; other example files,
/// e.g. diagnosis specs, name their own schema).
fn spec_examples() -> Vec<PathBuf> {
    examples()
        .into_iter()
        .filter(|p| std::fs::read_to_string(p).is_ok_and(|t| t.starts_with(SPEC_SCHEMA_LINE)))
        .collect()
}

#[test]
fn every_example_spec_round_trips_through_yaml() {
    assert!(spec_examples().len() >= 6, "too few spec examples found");
    for path in spec_examples() {
        let spec = Spec::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
        let yaml = serde_norway::to_string(&spec).unwrap();
        let back = Spec::parse(&yaml, Path::new("round-trip.yaml"))
            .unwrap_or_else(|e| panic!("{}: {e}\n{yaml}", path.display()));
        assert_eq!(
            serde_norway::to_string(&back).unwrap(),
            yaml,
            "{}",
            path.display()
        );
    }
}

#[test]
fn committed_schema_is_up_to_date() {
    let path = root().join("schemas/smid-spec.schema.json");
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    let generated = registry::spec_schema();
    assert!(
        committed == generated,
        "{} is stale: regenerate it with `cargo run -- schema > schemas/smid-spec.schema.json`",
        path.display()
    );
}

#[test]
fn committed_spec_reference_is_up_to_date() {
    let path = root().join("docs/reference/spec.md");
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    let generated = smid::spec_reference::reference().unwrap_or_else(|e| panic!("{e}"));
    assert!(
        committed == generated,
        "{} is stale: regenerate it with `{}`",
        path.display(),
        smid::spec_reference::REGENERATE
    );
}

/// The fields of mappings (through `$ref`s and optional values, not into lists, unions or
/// plugin blocks) whose schema states a default, by path.
fn schema_defaults(
    defs: &serde_json::Value,
    node: &serde_json::Value,
    path: &mut Vec<String>,
    out: &mut Vec<(Vec<String>, serde_json::Value)>,
) {
    let mut n = node;
    for _ in 0..8 {
        if let Some(r) = n["$ref"].as_str().and_then(|r| r.strip_prefix("#/$defs/")) {
            n = &defs[r];
        } else if let Some(alts) = n["anyOf"].as_array() {
            let real: Vec<&serde_json::Value> =
                alts.iter().filter(|a| a["type"] != "null").collect();
            if real.len() != 1 || real.len() == alts.len() {
                return;
            }
            n = real[0];
        } else {
            break;
        }
    }
    let Some(props) = n["properties"].as_object() else {
        return;
    };
    for (name, prop) in props {
        path.push(name.clone());
        if let Some(d) = prop.get("default") {
            out.push((path.clone(), d.clone()));
        }
        schema_defaults(defs, prop, path, out);
        path.pop();
    }
}

/// Every default the schema states for a field of a mapping is the one the spec takes when the
/// field is left out: `examples/paper.yaml` with the field set to the schema's default parses to
/// the same spec as with the field removed.
#[test]
fn schema_defaults_are_the_spec_defaults() {
    use serde_norway::Value as Yaml;
    smid::link_plugins();
    let schema: serde_json::Value = serde_json::from_str(&registry::spec_schema()).unwrap();
    let mut fields = Vec::new();
    schema_defaults(&schema["$defs"], &schema, &mut Vec::new(), &mut fields);
    assert!(fields.len() >= 30, "too few defaults found: {fields:?}");
    let text = std::fs::read_to_string(root().join("examples/paper.yaml")).unwrap();
    let base: Yaml = serde_norway::from_str(&text).unwrap();
    let parsed = |v: &Yaml| {
        let yaml = serde_norway::to_string(v).unwrap();
        let spec = Spec::parse(&yaml, Path::new("defaults.yaml"))
            .unwrap_or_else(|e| panic!("{e}\n{yaml}"));
        format!("{spec:?}")
    };
    for (path, default) in fields {
        let (last, parents) = path.split_last().unwrap();
        let mut with = base.clone();
        let mut at = &mut with;
        for p in parents {
            let m = at.as_mapping_mut().unwrap();
            if !m.contains_key(p.as_str()) {
                m.insert(p.as_str().into(), Yaml::Mapping(Default::default()));
            }
            at = m.get_mut(p.as_str()).unwrap();
        }
        at.as_mapping_mut().unwrap().insert(
            last.as_str().into(),
            serde_norway::to_value(&default).unwrap(),
        );
        let mut without = base.clone();
        let mut at = Some(&mut without);
        for p in parents {
            at = at.and_then(|v| v.get_mut(p.as_str()));
        }
        if let Some(m) = at.and_then(|v| v.as_mapping_mut()) {
            m.remove(last.as_str());
        }
        assert_eq!(
            parsed(&with),
            parsed(&without),
            "{}: the schema's default {default} is not the one the spec takes",
            path.join(".")
        );
    }
}

#[test]
fn schema_offers_every_registered_type() {
    let schema: serde_json::Value = serde_json::from_str(&registry::spec_schema()).unwrap();
    let defs = &schema["$defs"];
    for (def, tags) in [
        ("Nonlinearity", registry::nonlinearity_types()),
        ("NonlinearityModel", registry::model_types()),
    ] {
        let consts: Vec<&str> = defs[def]["oneOf"]
            .as_array()
            .unwrap_or_else(|| panic!("{def} has no oneOf"))
            .iter()
            .map(|b| b["properties"]["type"]["const"].as_str().unwrap())
            .collect();
        assert_eq!(consts, tags, "{def}");
    }
}

#[test]
fn every_example_names_a_committed_schema() {
    for path in examples() {
        let text = std::fs::read_to_string(&path).unwrap();
        let first = text.lines().next().unwrap_or_default();
        let schema = first
            .strip_prefix("# yaml-language-server: $schema=../schemas/")
            .unwrap_or_else(|| {
                panic!(
                    "{} does not name a schema on its first line",
                    path.display()
                )
            });
        assert!(
            root().join("schemas").join(schema).is_file(),
            "{} names a missing schema {schema}",
            path.display()
        );
    }
}

/// Recursively collect the Rust sources under `dir`.
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn the_core_names_no_plugin() {
    let mut files = Vec::new();
    sources(&root().join("crates/smid-core/src"), &mut files);
    assert!(!files.is_empty());
    let core_toml = std::fs::read_to_string(root().join("crates/smid-core/Cargo.toml")).unwrap();
    for tag in registry::nonlinearity_types() {
        let krate = format!("smid-{}", tag.replace('_', "-"));
        assert!(!core_toml.contains(&krate), "smid-core depends on {krate}");
        for f in &files {
            let text = std::fs::read_to_string(f).unwrap();
            for needle in [
                format!("\"{tag}\""),
                format!("type: {tag}"),
                format!("smid_{tag}"),
            ] {
                assert!(
                    !text.contains(&needle),
                    "{} names the plugin: {needle}",
                    f.display()
                );
            }
        }
    }
}

#[test]
fn the_example_plugin_runs_end_to_end() {
    let id = smid::run_spec_file(&root().join("examples/example-gain.yaml"))
        .unwrap()
        .unwrap();
    assert_eq!(id.all_contain_truth(), Some(true));
    let k = id.parameter("k").unwrap();
    assert!(k.lower <= 2.0 && 2.0 <= k.upper && k.radius < 1e-3, "{k:?}");
}

/// Every registered block that says it can sit behind a gain ([`Nonlinearity::behind_gain`])
/// does: `N'(k·x)` equals `N(x)` sample by sample, at a random gain, on a random multi-level
/// input with ramps. The blocks are each check case's random true block
/// ([`registry::check_cases`], up to its steady experiment's amplitude) and, for a simulator no case draws,
/// its example with every parameter moved by up to 2.5 %. The diagnosis trusts this trade when it
/// tests two candidates for equivalence.
#[test]
fn a_block_behind_a_gain_maps_the_scaled_input_as_before() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
    let mut blocks: Vec<(String, Box<dyn Nonlinearity>, f64)> = Vec::new();
    for case in registry::check_cases() {
        for _ in 0..20 {
            if let Some(d) = case.draw(&mut rng) {
                // Up to the designed experiment's largest steady input (a saturation's
                // limits lie beyond the dynamic record's amplitude).
                let amplitude = rng.gen_range(d.amplitude..=d.steady.1.max(d.amplitude));
                blocks.push((case.name.clone(), d.nonlinearity, amplitude));
            }
        }
    }
    let tag_of = |n: &dyn Nonlinearity| -> String {
        serde_json::to_value(n).expect("a block serialises")["type"]
            .as_str()
            .expect("a tagged block")
            .to_string()
    };
    let drawn: Vec<String> = blocks.iter().map(|(_, n, _)| tag_of(n.as_ref())).collect();
    // The examples of the simulators no check case draws (the drawn ones are drawn within
    // their range: an input backlash's example, moved, crosses its branches inside the input's
    // range, where rounding picks the branch).
    for e in registry::nonlinearities()
        .into_iter()
        .filter(|e| !drawn.iter().any(|d| d == e.tag))
    {
        for _ in 0..10 {
            let values: Vec<(String, f64)> = (e.example)()
                .parameters()
                .into_iter()
                .map(|(n, v)| (n, v * rng.gen_range(0.975..1.025)))
                .collect();
            let n = registry::instantiate(e.tag, &values).expect("the example's parameters");
            if n.validate().is_ok() {
                blocks.push((e.tag.to_string(), n, rng.gen_range(0.5..3.0)));
            }
        }
    }
    let mut answered = Vec::new();
    for (trial, (name, n, amplitude)) in blocks.iter().enumerate() {
        let k = rng.gen_range(0.2..5.0);
        let Some(moved) = n.behind_gain(k) else {
            continue;
        };
        let tag = tag_of(n.as_ref());
        let names = |v: &[(String, f64)]| v.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
        assert_eq!(
            names(&moved),
            names(&n.parameters()),
            "{name}: behind a gain, its parameters in another order"
        );
        let scaled = registry::instantiate(&tag, &moved).unwrap_or_else(|err| {
            panic!("{name}: its parameters behind a gain {k} are not its own ({err})")
        });
        let mut x = Vec::new();
        let mut level = 0.0;
        for _ in 0..12 {
            let next = amplitude * rng.gen_range(-1.0..1.0);
            let ramp = rng.gen_range(1..8);
            x.extend((1..=ramp).map(|i| level + (next - level) * i as f64 / ramp as f64));
            x.extend(std::iter::repeat_n(next, rng.gen_range(1..6)));
            level = next;
        }
        let before = n.simulate(&x);
        let kx: Vec<f64> = x.iter().map(|v| k * v).collect();
        let after = scaled.simulate(&kx);
        for (t, (a, b)) in before.iter().zip(&after).enumerate() {
            assert!(
                (a - b).abs() <= 1e-9 * (1.0 + a.abs()),
                "{name} (block {trial}), gain {k}, sample {t}: {b} behind the gain, {a} before ({:?} -> {moved:?})",
                n.parameters()
            );
        }
        answered.push(tag);
    }
    for tag in [
        "output_backlash",
        "input_backlash",
        "dead_zone",
        "saturation",
    ] {
        assert!(
            answered.iter().any(|a| a == tag),
            "{tag} never answered a gain it can sit behind"
        );
    }
}
