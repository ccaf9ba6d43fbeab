//! The plugin registry: every nonlinearity plugin registers, next to its `typetag` name, the
//! JSON Schema of its parameters and an example value. From these the core builds the JSON
//! Schema of the spec (a `oneOf` over the registered `type`s, see [`spec_schema`]), lists the
//! valid `type` names in error messages ([`nonlinearity_types`], [`model_types`]) and lets a test
//! round-trip every registered `type` through YAML. The containment check's cases
//! ([`check_cases`]) derive from it too: each plugin in each structure it offers a random trial
//! in. Registration is link-time (`inventory`), so
//! the core names no plugin: a plugin crate calls [`register_nonlinearity!`](crate::register_nonlinearity) and
//! [`register_model!`](crate::register_model) and is linked into the binary.
use crate::nonlinearity::{CheckDraw, Nonlinearity, NonlinearityModel, Structure};
use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde_json::{json, Map, Value};
use std::borrow::Cow;

/// A registered simulation nonlinearity (`plant.simulator.nonlinearity`).
pub struct NonlinearityEntry {
    /// The `type` tag (must equal the `typetag` name).
    pub tag: &'static str,
    /// The Cargo package that registered it (the macro reads the plugin crate's
    /// `CARGO_PKG_NAME`): how a test tells that every linked plugin crate registered itself.
    pub package: &'static str,
    /// JSON Schema of the plugin's fields (without `type`).
    pub schema: fn(&mut SchemaGenerator) -> Schema,
    /// A valid example value (used by the round-trip test and the extension guide).
    pub example: fn() -> Box<dyn Nonlinearity>,
}

/// A registered model structure (`model.nonlinearity`).
pub struct ModelEntry {
    /// The `type` tag (must equal the `typetag` name).
    pub tag: &'static str,
    /// The Cargo package that registered it (see [`NonlinearityEntry::package`]).
    pub package: &'static str,
    /// JSON Schema of the plugin's options (without `type`).
    pub schema: fn(&mut SchemaGenerator) -> Schema,
    /// A valid example value.
    pub example: fn() -> Box<dyn NonlinearityModel>,
}

inventory::collect!(NonlinearityEntry);
inventory::collect!(ModelEntry);

/// Registered simulation nonlinearities, sorted by tag.
pub fn nonlinearities() -> Vec<&'static NonlinearityEntry> {
    let mut v: Vec<_> = inventory::iter::<NonlinearityEntry>.into_iter().collect();
    v.sort_by_key(|e| e.tag);
    v
}

/// Registered model structures, sorted by tag.
pub fn models() -> Vec<&'static ModelEntry> {
    let mut v: Vec<_> = inventory::iter::<ModelEntry>.into_iter().collect();
    v.sort_by_key(|e| e.tag);
    v
}

/// The valid `type` names of `plant.simulator.nonlinearity`.
pub fn nonlinearity_types() -> Vec<&'static str> {
    nonlinearities().iter().map(|e| e.tag).collect()
}

/// The valid `type` names of `model.nonlinearity`.
pub fn model_types() -> Vec<&'static str> {
    models().iter().map(|e| e.tag).collect()
}

/// A simulation nonlinearity of the registered `type` with the given parameter values (by
/// name, as [`Nonlinearity::parameters`] reports them), built through its serialised form, so
/// a plugin needs no extra code for its members to be simulated.
pub fn instantiate(tag: &str, values: &[(String, f64)]) -> crate::Result<Box<dyn Nonlinearity>> {
    let mut obj = Map::new();
    obj.insert("type".into(), json!(tag));
    for (k, v) in values {
        obj.insert(k.clone(), json!(v));
    }
    serde_json::from_value(Value::Object(obj)).map_err(|e| crate::SmidError::Unsupported {
        plugin: tag.to_string(),
        what: format!("simulation from its identified parameters ({e})"),
    })
}

/// The parameter names of a plugin `type`, in report order (from its registered example).
pub fn parameter_names(tag: &str) -> Vec<String> {
    nonlinearities()
        .iter()
        .find(|e| e.tag == tag)
        .map(|e| {
            (e.example)()
                .parameters()
                .into_iter()
                .map(|(n, _)| n)
                .collect()
        })
        .unwrap_or_default()
}

/// One containment check case: a registered model plugin in one structure where it offers a
/// random trial ([`NonlinearityModel::check_draw`]).
#[derive(Debug, Clone)]
pub struct CheckCase {
    /// The case's name on the command line (`smid check --plugin NAME`): the plugin's tag
    /// where it is checked in one structure, `TAG_input` / `TAG_output` where in both.
    pub name: String,
    /// The plugin's `type` tag.
    pub tag: &'static str,
    /// Where the block sits.
    pub structure: Structure,
}

impl CheckCase {
    /// A random trial of this case from `rng` (the plugin's own draw).
    pub fn draw(&self, rng: &mut dyn rand::RngCore) -> Option<CheckDraw> {
        let m = models().into_iter().find(|m| m.tag == self.tag)?;
        (m.example)().check_draw(self.structure, rng)
    }
}

/// Every check case, derived from the registry: each registered model plugin in each structure
/// it supports and offers a trial in (probed with a fixed draw), sorted by name. A plugin joins
/// `smid check --plugin`, the band tests and the benches by implementing `check_draw`.
pub fn check_cases() -> Vec<CheckCase> {
    use rand::SeedableRng;
    let mut cases = Vec::new();
    for m in models() {
        let ex = (m.example)();
        let sides: Vec<Structure> = [Structure::Hammerstein, Structure::Wiener]
            .into_iter()
            .filter(|&s| {
                let mut probe = rand_chacha::ChaCha8Rng::seed_from_u64(0);
                ex.supports(s) && ex.check_draw(s, &mut probe).is_some()
            })
            .collect();
        for &s in &sides {
            let name = match (sides.len(), s) {
                (1, _) => m.tag.to_string(),
                (_, Structure::Hammerstein) => format!("{}_input", m.tag),
                (_, Structure::Wiener) => format!("{}_output", m.tag),
            };
            cases.push(CheckCase {
                name,
                tag: m.tag,
                structure: s,
            });
        }
    }
    cases.sort_by(|a, b| a.name.cmp(&b.name));
    cases
}

/// The check case called `name`: an error listing every valid name otherwise.
pub fn check_case(name: &str) -> crate::Result<CheckCase> {
    let cases = check_cases();
    let names: Vec<String> = cases.iter().map(|c| c.name.clone()).collect();
    cases
        .into_iter()
        .find(|c| c.name == name.trim())
        .ok_or_else(|| {
            crate::SmidError::invalid(
                "--plugin",
                format!(
                    "unknown check case `{name}`; expected one of: {} (every registered plugin that offers a random trial, `NonlinearityModel::check_draw`)",
                    names.join(", ")
                ),
            )
        })
}

/// Register a simulation nonlinearity: `register_nonlinearity!("tag", Type, example_expr)`.
/// `Type` must implement `schemars::JsonSchema` and `Nonlinearity` (with the same tag).
#[macro_export]
macro_rules! register_nonlinearity {
    ($tag:literal, $ty:ty, $example:expr) => {
        $crate::inventory::submit! {
            $crate::registry::NonlinearityEntry {
                tag: $tag,
                package: ::std::env!("CARGO_PKG_NAME"),
                schema: |g| <$ty as $crate::schemars::JsonSchema>::json_schema(g),
                example: || -> ::std::boxed::Box<dyn $crate::nonlinearity::Nonlinearity> {
                    ::std::boxed::Box::new($example)
                },
            }
        }
    };
}

/// Register a model structure: `register_model!("tag", Type, example_expr)`.
#[macro_export]
macro_rules! register_model {
    ($tag:literal, $ty:ty, $example:expr) => {
        $crate::inventory::submit! {
            $crate::registry::ModelEntry {
                tag: $tag,
                package: ::std::env!("CARGO_PKG_NAME"),
                schema: |g| <$ty as $crate::schemars::JsonSchema>::json_schema(g),
                example: || -> ::std::boxed::Box<dyn $crate::nonlinearity::NonlinearityModel> {
                    ::std::boxed::Box::new($example)
                },
            }
        }
    };
}

/// One `oneOf` branch: the plugin's object schema with `type: const tag` added.
fn tagged(tag: &str, schema: Schema) -> Value {
    let mut v = schema.to_value();
    if !v.is_object() {
        // `true` or a non-object schema: accept any fields beside the tag.
        v = json!({});
    }
    let obj = v.as_object_mut().expect("object checked above");
    obj.insert("type".into(), json!("object"));
    obj.insert("title".into(), json!(tag));
    let props = obj
        .entry("properties")
        .or_insert_with(|| Value::Object(Map::new()));
    if let Some(p) = props.as_object_mut() {
        p.insert("type".into(), json!({ "const": tag }));
    }
    let req = obj.entry("required").or_insert_with(|| json!([]));
    if let Some(r) = req.as_array_mut() {
        r.insert(0, json!("type"));
    }
    v
}

fn one_of(branches: Vec<Value>, what: &str, tags: &[&str]) -> Schema {
    let v = json!({
        "description": format!("{what}: one of the registered plugin types ({})", tags.join(", ")),
        "type": "object",
        "required": ["type"],
        "oneOf": branches,
    });
    Schema::try_from(v).unwrap_or_default()
}

impl JsonSchema for dyn Nonlinearity {
    fn schema_name() -> Cow<'static, str> {
        "Nonlinearity".into()
    }
    fn json_schema(g: &mut SchemaGenerator) -> Schema {
        let entries = nonlinearities();
        let tags: Vec<&str> = entries.iter().map(|e| e.tag).collect();
        let branches = entries
            .iter()
            .map(|e| tagged(e.tag, (e.schema)(g)))
            .collect();
        one_of(branches, "A nonlinearity with known parameters", &tags)
    }
}

impl JsonSchema for dyn NonlinearityModel {
    fn schema_name() -> Cow<'static, str> {
        "NonlinearityModel".into()
    }
    fn json_schema(g: &mut SchemaGenerator) -> Schema {
        let entries = models();
        let tags: Vec<&str> = entries.iter().map(|e| e.tag).collect();
        let branches = entries
            .iter()
            .map(|e| tagged(e.tag, (e.schema)(g)))
            .collect();
        one_of(
            branches,
            "The model structure's nonlinearity (a type and its options)",
            &tags,
        )
    }
}

impl JsonSchema for dyn crate::effect::Effect {
    fn schema_name() -> Cow<'static, str> {
        "Effect".into()
    }
    fn json_schema(g: &mut SchemaGenerator) -> Schema {
        let entries = crate::effect::effects();
        let tags: Vec<&str> = entries.iter().map(|e| e.tag).collect();
        let branches = entries
            .iter()
            .map(|e| tagged(e.tag, (e.schema)(g)))
            .collect();
        one_of(
            branches,
            "An effect: one more term of the model (true values in a simulator, open in a model)",
            &tags,
        )
    }
}

/// The JSON Schema of the whole spec ([`crate::spec::Spec`]) covering every plugin linked into
/// this binary, pretty-printed with a trailing newline (the committed
/// `schemas/smid-spec.schema.json`).
pub fn spec_schema() -> String {
    let schema = schemars::schema_for!(crate::spec::Spec);
    let mut s = serde_json::to_string_pretty(&schema).unwrap_or_default();
    s.push('\n');
    s
}
