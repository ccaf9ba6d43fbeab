//! The spec reference, `docs/reference/spec.md`: Markdown generated from the spec's JSON Schema
//! ([`smid_core::registry::spec_schema`], every linked plugin's `type` included) and the bundled
//! example specs (`examples/**/*.yaml`). `smid schema --markdown` prints it.
//!
//! Every field of the spec is listed by its path in the YAML (`experiment.filter.pole`; `[]`
//! marks the items of a list), with its type (the values of an enumeration, the alternatives of
//! a union), its default, its description (the doc comment, which schemars puts in
//! `description`) and an example. The example is the schema's own (`examples`) when it has one,
//! else the shortest value a bundled spec gives the field other than its default (the first of
//! equal length; the file is named), else the first value a bundled spec gives it; without
//! one, the other value of a boolean or an enumeration, else the default, else a small value
//! made up from the type (each marked so). The plugin unions (blocks and effects, a `oneOf` over `type`) get one section each, listing
//! every `type` with its fields.
//!
//! The output depends only on the schema and the examples' text: mappings list their required
//! fields first (in declaration order, as the schema's `required` keeps it), then the others
//! alphabetically; examples are read in a fixed order (shallower files first, then by path);
//! files are named by their path relative to the repository root.
use serde_json::Value as Json;
use serde_norway::Value as Yaml;
use smid_core::{Result, SmidError};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One example spec: its path relative to the repository root (`examples/paper.yaml`) and its
/// parsed YAML.
#[derive(Debug, Clone)]
pub struct ExampleSpec {
    /// Path relative to the repository root, with `/` separators.
    pub file: String,
    /// The parsed YAML document.
    pub doc: Yaml,
}

/// The command that regenerates the reference (printed in its header and in the staleness test).
pub const REGENERATE: &str = "cargo run -- schema --markdown > docs/reference/spec.md";

/// The reference of this binary's spec: its schema (every linked plugin) and the bundled
/// examples of the checkout this crate is built from (`examples/` beside its `Cargo.toml`).
pub fn reference() -> Result<String> {
    crate::link_plugins();
    let schema: Json = serde_json::from_str(&smid_core::registry::spec_schema())
        .map_err(|e| SmidError::invalid("schema", e.to_string()))?;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let examples = bundled_examples(root)?;
    Ok(render(&schema, &examples))
}

/// The `.yaml` files under `root/examples` (recursively) that are identification specs (their
/// first line names `smid-spec.schema.json`), in the reference's order: fewer path components
/// first, then by path.
pub fn bundled_examples(root: &Path) -> Result<Vec<ExampleSpec>> {
    let mut files = Vec::new();
    collect_yaml(&root.join("examples"), &mut files)?;
    let mut labelled: Vec<(String, PathBuf)> = files
        .into_iter()
        .map(|p| {
            let rel = p.strip_prefix(root).unwrap_or(&p);
            let label = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect::<Vec<_>>()
                .join("/");
            (label, p)
        })
        .collect();
    labelled
        .sort_by(|a, b| (a.0.matches('/').count(), &a.0).cmp(&(b.0.matches('/').count(), &b.0)));
    let mut out = Vec::new();
    for (file, path) in labelled {
        let text = std::fs::read_to_string(&path).map_err(|source| SmidError::Io {
            path: path.clone(),
            source,
        })?;
        if !text
            .lines()
            .next()
            .is_some_and(|l| l.contains("smid-spec.schema.json"))
        {
            continue;
        }
        let doc: Yaml = serde_norway::from_str(&text)
            .map_err(|e| SmidError::invalid(file.clone(), e.to_string()))?;
        out.push(ExampleSpec { file, doc });
    }
    Ok(out)
}

fn collect_yaml(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    let entries = std::fs::read_dir(dir).map_err(|source| SmidError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    for e in entries {
        let p = e
            .map_err(|source| SmidError::Io {
                path: dir.to_path_buf(),
                source,
            })?
            .path();
        if p.is_dir() {
            collect_yaml(&p, out)?;
        } else if p.extension().is_some_and(|x| x == "yaml") {
            out.push(p);
        }
    }
    Ok(())
}

/// A step of a field's path: a mapping key, or the items of a list (`[]`).
#[derive(Debug, Clone, PartialEq)]
enum Seg {
    Key(String),
    Items,
}

fn path_text(path: &[Seg]) -> String {
    let mut s = String::new();
    for seg in path {
        match seg {
            Seg::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(k);
            }
            Seg::Items => s.push_str("[]"),
        }
    }
    s
}

/// The id mdBook gives a heading (lower case; letters, digits, `_` and `-` kept, spaces to
/// `-`, the rest dropped).
fn anchor(heading: &str) -> String {
    heading
        .chars()
        .filter_map(|c| {
            if c.is_alphanumeric() || c == '_' || c == '-' {
                Some(c.to_ascii_lowercase())
            } else if c.is_whitespace() {
                Some('-')
            } else {
                None
            }
        })
        .collect()
}

/// A plugin union (`oneOf` of objects tagged by `type`) met while walking the fields.
struct Union {
    name: String,
    used_at: Vec<Vec<Seg>>,
}

/// Read-only look-ups in the schema (every reference lives as long as the schema).
#[derive(Clone, Copy)]
struct Schema<'a> {
    defs: &'a serde_json::Map<String, Json>,
}

struct Renderer<'a> {
    s: Schema<'a>,
    examples: &'a [ExampleSpec],
    unions: Vec<Union>,
    out: String,
    /// Fields listed (plain fields, and the fields of each union's `type`s).
    fields: usize,
}

/// The Markdown reference of `schema` (a spec's JSON Schema) with examples from `examples`.
pub fn render(schema: &Json, examples: &[ExampleSpec]) -> String {
    let empty = serde_json::Map::new();
    let defs = schema
        .get("$defs")
        .and_then(Json::as_object)
        .unwrap_or(&empty);
    let s = Schema { defs };
    let mut r = Renderer {
        s,
        examples,
        unions: Vec::new(),
        out: String::new(),
        fields: 0,
    };
    r.header(schema);
    if let Some((props, required)) = s.properties(schema) {
        for (name, prop) in ordered(props, &required) {
            let path = vec![Seg::Key(name.clone())];
            r.field(&path, prop, required.contains(&name.as_str()), 2);
        }
    }
    let mut i = 0;
    while i < r.unions.len() {
        r.union_section(i);
        i += 1;
    }
    // The count goes in the header, filled in last so that it is the true one.
    let mut out = r.out.replacen("{FIELDS}", &r.fields.to_string(), 1);
    while out.ends_with("\n\n") {
        out.pop();
    }
    out
}

/// `props` with the `required` ones first (in their order), then the rest by name.
fn ordered<'p>(
    props: &'p serde_json::Map<String, Json>,
    required: &[&str],
) -> Vec<(&'p String, &'p Json)> {
    let mut v: Vec<(&String, &Json)> = required
        .iter()
        .filter_map(|r| props.get_key_value(*r))
        .collect();
    let mut rest: Vec<(&String, &Json)> = props
        .iter()
        .filter(|(k, _)| !required.contains(&k.as_str()))
        .collect();
    rest.sort_by(|a, b| a.0.cmp(b.0));
    v.append(&mut rest);
    v
}

/// The first type name of a node other than `null` (`type: [number, null]` is `number`).
fn type_name(node: &Json) -> &str {
    match node.get("type") {
        Some(Json::String(s)) => s.as_str(),
        Some(Json::Array(ts)) => ts
            .iter()
            .filter_map(Json::as_str)
            .find(|t| *t != "null")
            .unwrap_or("null"),
        _ if node.get("properties").is_some() => "object",
        _ => "",
    }
}

fn is_null(node: &Json) -> bool {
    node.get("type").and_then(Json::as_str) == Some("null")
}

impl<'a> Schema<'a> {
    /// Follow `$ref`s to their definition.
    fn resolve(self, mut node: &'a Json) -> &'a Json {
        for _ in 0..16 {
            match ref_name(node).and_then(|n| self.defs.get(n)) {
                Some(d) => node = d,
                None => break,
            }
        }
        node
    }

    /// The node with an optional `null` taken off: `anyOf [X, null]` is `X`.
    fn non_null(self, node: &'a Json) -> &'a Json {
        let node = self.resolve(node);
        if let Some(alts) = node.get("anyOf").and_then(Json::as_array) {
            let real: Vec<&Json> = alts.iter().filter(|a| !is_null(a)).collect();
            if real.len() == 1 && real.len() < alts.len() {
                return self.resolve(real[0]);
            }
        }
        node
    }

    /// The plugin union a node is (its `$defs` name), if it is one.
    fn union_name(self, node: &'a Json) -> Option<&'a str> {
        let mut n = node;
        if let Some(alts) = n.get("anyOf").and_then(Json::as_array) {
            if let Some(a) = alts.iter().find(|a| !is_null(a)) {
                n = a;
            }
        }
        let name = ref_name(n)?;
        let (name, def) = self.defs.get_key_value(name)?;
        let alts = def.get("oneOf")?.as_array()?;
        (!alts.is_empty()
            && alts
                .iter()
                .all(|a| a.pointer("/properties/type/const").is_some()))
        .then_some(name.as_str())
    }

    /// The values of an enumeration (`oneOf` of `const`s, or `enum`), with their descriptions.
    fn enum_values(self, node: &'a Json) -> Option<Vec<(&'a Json, Option<&'a str>)>> {
        let node = self.non_null(node);
        if let Some(alts) = node.get("oneOf").and_then(Json::as_array) {
            if !alts.is_empty() && alts.iter().all(|a| a.get("const").is_some()) {
                return Some(
                    alts.iter()
                        .map(|a| (&a["const"], a.get("description").and_then(Json::as_str)))
                        .collect(),
                );
            }
        }
        node.get("enum")
            .and_then(Json::as_array)
            .map(|v| v.iter().map(|c| (c, None)).collect())
    }

    /// The properties and required names of an object node (through `$ref`, an optional
    /// `null`, and the first object alternative of an `anyOf`, e.g. one record or a list).
    fn properties(
        self,
        node: &'a Json,
    ) -> Option<(&'a serde_json::Map<String, Json>, Vec<&'a str>)> {
        let node = self.non_null(node);
        let obj = if node.get("properties").is_some() {
            node
        } else {
            node.get("anyOf")
                .and_then(Json::as_array)?
                .iter()
                .map(|a| self.resolve(a))
                .find(|a| a.get("properties").is_some())?
        };
        let props = obj.get("properties")?.as_object()?;
        let required = obj
            .get("required")
            .and_then(Json::as_array)
            .map(|r| r.iter().filter_map(Json::as_str).collect())
            .unwrap_or_default();
        Some((props, required))
    }

    /// The type of a node in words.
    fn type_text(self, node: &'a Json) -> String {
        if let Some(u) = self.union_name(node) {
            return format!("a `type` of [{u}](#{}) with its fields", anchor(u));
        }
        if let Some(values) = self.enum_values(node) {
            let v: Vec<String> = values
                .iter()
                .map(|(c, _)| format!("`{}`", flow(&to_yaml(c))))
                .collect();
            return format!("one of {}", v.join(", "));
        }
        let node = self.non_null(node);
        if let Some(alts) = node.get("anyOf").and_then(Json::as_array) {
            let real: Vec<&Json> = alts.iter().filter(|a| !is_null(a)).collect();
            let mut words: Vec<String> = Vec::new();
            for (i, a) in real.iter().copied().enumerate() {
                // A list of what an earlier alternative is: "or a list of them".
                let items = self.resolve(a).get("items").map(|it| self.resolve(it));
                if items
                    .is_some_and(|it| real[..i].iter().any(|b| std::ptr::eq(self.resolve(*b), it)))
                {
                    words.push("a list of them".into());
                    continue;
                }
                let w = self.type_text(a);
                if !words.contains(&w) {
                    words.push(w);
                }
            }
            return words.join(", or ");
        }
        match type_name(node) {
            "integer" => {
                let lo = node.get("minimum").and_then(Json::as_i64);
                let hi = node.get("maximum").and_then(Json::as_i64);
                match (lo, hi) {
                    (Some(l), Some(h)) => format!("integer from {l} to {h}"),
                    (Some(l), None) => format!("integer >= {l}"),
                    (None, Some(h)) => format!("integer <= {h}"),
                    (None, None) => "integer".into(),
                }
            }
            "number" => "number".into(),
            "boolean" => "boolean".into(),
            "string" => "string".into(),
            "array" => {
                let items = node.get("items").unwrap_or(&Json::Null);
                let n_min = node.get("minItems").and_then(Json::as_u64);
                let n_max = node.get("maxItems").and_then(Json::as_u64);
                if let Some(u) = self.union_name(items) {
                    return format!(
                        "list of blocks, each a `type` of [{u}](#{}) with its fields",
                        anchor(u)
                    );
                }
                let item = self.type_text(items);
                match (n_min, n_max) {
                    (Some(a), Some(b)) if a == b => format!("list of {a} ({item} each)"),
                    _ => format!("list ({item} each)"),
                }
            }
            "object" => {
                if node.get("properties").is_some() {
                    "mapping (its fields below)".into()
                } else {
                    match node.get("additionalProperties") {
                        Some(Json::Bool(true)) | None => {
                            "mapping of names to values of any type".into()
                        }
                        Some(v) => {
                            format!("mapping of names to values ({} each)", self.type_text(v))
                        }
                    }
                }
            }
            _ => "any value".into(),
        }
    }

    /// A small valid value of a node's type (a string is the field's own name `key`, as a
    /// column header would be).
    fn made_up(self, node: &'a Json, key: &str, depth: usize) -> Yaml {
        if depth > 8 {
            return Yaml::Null;
        }
        if let Some(d) = node.get("default") {
            return to_yaml(d);
        }
        if let Some(values) = self.enum_values(node) {
            return values.first().map_or(Yaml::Null, |v| to_yaml(v.0));
        }
        if self.union_name(node).is_some() {
            if let Some(first) = self
                .non_null(node)
                .get("oneOf")
                .and_then(Json::as_array)
                .and_then(|a| a.first())
            {
                return self.made_up_object(first, depth);
            }
        }
        let node = self.non_null(node);
        if let Some(alts) = node.get("anyOf").and_then(Json::as_array) {
            if let Some(a) = alts.iter().find(|a| !is_null(a)) {
                return self.made_up(a, key, depth + 1);
            }
        }
        if node.get("properties").is_some() {
            return self.made_up_object(node, depth);
        }
        match type_name(node) {
            "integer" => {
                let lo = node.get("minimum").and_then(Json::as_i64).unwrap_or(1);
                Yaml::from(lo.max(1))
            }
            "number" => Yaml::from(0.5),
            "boolean" => Yaml::Bool(true),
            "string" => Yaml::from(key),
            "array" => {
                let item = node
                    .get("items")
                    .map_or(Yaml::Null, |i| self.made_up(i, key, depth + 1));
                let n = node.get("minItems").and_then(Json::as_u64).unwrap_or(1);
                if n == 2 && item.is_number() {
                    Yaml::Sequence(vec![Yaml::from(0.0), Yaml::from(1.0)])
                } else {
                    Yaml::Sequence(vec![item; n.max(1) as usize])
                }
            }
            "object" => {
                let v = match node.get("additionalProperties") {
                    Some(Json::Bool(true)) | None => Yaml::from(1),
                    Some(s) => self.made_up(s, key, depth + 1),
                };
                let mut m = serde_norway::Mapping::new();
                m.insert(Yaml::from("name"), v);
                Yaml::Mapping(m)
            }
            _ => Yaml::Null,
        }
    }

    /// An object with every field made up, the required ones (a `type` tag) first.
    fn made_up_object(self, node: &'a Json, depth: usize) -> Yaml {
        let mut m = serde_norway::Mapping::new();
        if let Some((props, req)) = self.properties(node) {
            for (k, p) in ordered(props, &req) {
                let v = match p.get("const") {
                    Some(c) => to_yaml(c),
                    None => self.made_up(p, k, depth + 1),
                };
                m.insert(Yaml::from(k.as_str()), v);
            }
        }
        Yaml::Mapping(m)
    }

    /// A value of a boolean or an enumeration other than its default `d`, if there is one.
    fn other_than(self, node: &'a Json, d: &Json) -> Option<Yaml> {
        if let Some(values) = self.enum_values(node) {
            return values.iter().find(|v| !same(v.0, d)).map(|v| to_yaml(v.0));
        }
        match d {
            Json::Bool(b) if type_name(self.non_null(node)) == "boolean" => Some(Yaml::Bool(!b)),
            _ => None,
        }
    }
}

/// The `$defs` name a node refers to, if any.
fn ref_name(node: &Json) -> Option<&str> {
    node.get("$ref")
        .and_then(Json::as_str)
        .and_then(|r| r.strip_prefix("#/$defs/"))
}

impl<'a> Renderer<'a> {
    fn header(&mut self, schema: &Json) {
        let title = schema.get("title").and_then(Json::as_str).unwrap_or("Spec");
        let _ = write!(
            self.out,
            "# Spec reference\n\n\
             A spec is the YAML file `smid run` reads: the plant, the noise bound, the \
             experiment, the model structure to identify and the method's options. This page \
             lists every field of a spec ({{FIELDS}} fields) by its path in the YAML: \
             `experiment.filter.pole` is the key `pole` inside `filter` inside `experiment`, \
             and `[]` marks the items of a list (`model.effects[]`). Each field gives its type, \
             its default, what it means and an example. A field without a default is either \
             required or left out when it is not needed (its description says what leaving it \
             out means). An example comes from a bundled spec under `examples/` where one sets \
             the field (the file is named); otherwise it is the default, or a value made up for \
             illustration. Within each mapping the required fields come first, then the others \
             in alphabetical order. The last sections list the plugin `type`s a block or an \
             effect can be, with their fields.\n\n\
             Unknown fields are an error, and an error names the file, the field and, where it \
             can, the line. An editor that reads JSON Schema checks a spec as it is typed \
             against the same schema, `schemas/smid-spec.schema.json`, when the spec's first \
             line names it (`# yaml-language-server: $schema=...`, as every bundled example \
             does).\n\n\
             This page is generated from that schema (`{title}`, from the doc comments of the \
             spec's Rust types and of the plugins), so do not edit it by hand: regenerate it \
             with `{REGENERATE}`.\n\n"
        );
    }

    /// One field: its heading, description, type, default and example, then its own fields.
    fn field(&mut self, path: &[Seg], prop: &'a Json, required: bool, level: usize) {
        let s = self.s;
        self.fields += 1;
        let target = s.non_null(prop);
        let p = path_text(path);
        let hashes = "#".repeat(level.min(6));
        let _ = write!(self.out, "{hashes} `{p}`\n\n");
        let description = prop
            .get("description")
            .or_else(|| s.resolve(prop).get("description"))
            .or_else(|| target.get("description"))
            .and_then(Json::as_str);
        if let Some(d) = description {
            let _ = write!(self.out, "{}\n\n", clean(d));
        }
        let _ = writeln!(self.out, "- **Type:** {}", s.type_text(prop));
        let children = s.properties(prop);
        let default = prop.get("default").or_else(|| target.get("default"));
        let default_text = match (default, &children) {
            _ if required => "none: required".to_string(),
            (Some(d), Some((props, _))) if children_default(d, props) => {
                "each field below at its default".into()
            }
            (Some(d), _) => format!("`{}`", flow(&to_yaml(d))),
            (None, _) => "not set".into(),
        };
        let _ = writeln!(self.out, "- **Default:** {default_text}");
        let (value, source) = self.example(path, prop, default);
        let label = match &source {
            Source::Schema => "- **Example:**".to_string(),
            Source::File(f) => format!("- **Example** (from `{f}`):"),
            Source::Default => "- **Example** (the default):".to_string(),
            Source::Made => "- **Example** (made up for illustration):".to_string(),
        };
        let _ = write!(
            self.out,
            "{label}\n\n  ```yaml\n{}  ```\n\n",
            indent(&nested(path, &value), 2)
        );
        if let Some(values) = s.enum_values(prop) {
            if values.iter().any(|(_, d)| d.is_some()) {
                self.out.push_str("Values:\n\n");
                for (c, d) in values {
                    let _ = writeln!(
                        self.out,
                        "- `{}`: {}",
                        flow(&to_yaml(c)),
                        d.map(|d| clean(d).replace('\n', " ")).unwrap_or_default()
                    );
                }
                self.out.push('\n');
            }
        }
        let union = match s.union_name(prop) {
            Some(u) => Some((u, path.to_vec())),
            None => target
                .get("items")
                .and_then(|items| s.union_name(items))
                .map(|u| {
                    let mut at = path.to_vec();
                    at.push(Seg::Items);
                    (u, at)
                }),
        };
        if let Some((u, at)) = union {
            match self.unions.iter_mut().find(|x| x.name == u) {
                Some(x) => x.used_at.push(at),
                None => self.unions.push(Union {
                    name: u.to_string(),
                    used_at: vec![at],
                }),
            }
        }
        if let Some((props, req)) = children {
            for (name, child) in ordered(props, &req) {
                let mut cp = path.to_vec();
                cp.push(Seg::Key(name.clone()));
                self.field(&cp, child, req.contains(&name.as_str()), 3);
            }
        }
    }

    /// The example of a field: the schema's, a bundled spec's (one other than the default
    /// first), the default, or one made up from the type.
    fn example(&self, path: &[Seg], prop: &'a Json, default: Option<&Json>) -> (Yaml, Source) {
        let target = self.s.non_null(prop);
        if let Some(e) = prop
            .get("examples")
            .or_else(|| target.get("examples"))
            .and_then(Json::as_array)
            .and_then(|v| v.first())
        {
            return (to_yaml(e), Source::Schema);
        }
        // The shortest bundled value other than the default (the first of equal length), else
        // the first bundled value.
        let mut shortest: Option<(usize, &Yaml, &str)> = None;
        let mut first: Option<(&Yaml, &str)> = None;
        for ex in self.examples {
            for v in values_at(&ex.doc, path) {
                first.get_or_insert((v, ex.file.as_str()));
                if default.is_some_and(|d| same(&to_json(v), d)) {
                    continue;
                }
                let n = flow(v).len();
                if shortest.is_none_or(|s| n < s.0) {
                    shortest = Some((n, v, ex.file.as_str()));
                }
            }
        }
        if let Some((v, f)) = shortest.map(|s| (s.1, s.2)).or(first) {
            return (v.clone(), Source::File(f.to_string()));
        }
        let key = match path.last() {
            Some(Seg::Key(k)) => k.as_str(),
            _ => "name",
        };
        match default {
            // The other value of a boolean or an enumeration says more than its default.
            Some(d) => match self.s.other_than(prop, d) {
                Some(v) => (v, Source::Made),
                None => (to_yaml(d), Source::Default),
            },
            None => (self.s.made_up(prop, key, 0), Source::Made),
        }
    }

    /// The section of a plugin union: where it is used and every `type` with its fields.
    fn union_section(&mut self, i: usize) {
        let s = self.s;
        let examples = self.examples;
        let name = self.unions[i].name.clone();
        let used_at = self.unions[i].used_at.clone();
        let Some(def) = s.defs.get(&name) else {
            return;
        };
        let _ = write!(self.out, "## {name}\n\n");
        if let Some(d) = def.get("description").and_then(Json::as_str) {
            let _ = write!(self.out, "{}\n\n", clean(d));
        }
        let places: Vec<String> = used_at
            .iter()
            .map(|p| {
                let t = path_text(p);
                format!("[`{t}`](#{})", anchor(t.trim_end_matches("[]")))
            })
            .collect();
        let _ = write!(
            self.out,
            "Used at {}. Each is a mapping: the key `type` names the plugin, the other keys \
             are that `type`'s fields.\n\n",
            places.join(", ")
        );
        let alts = def.get("oneOf").and_then(Json::as_array);
        for alt in alts.into_iter().flatten() {
            let Some(tag) = alt.pointer("/properties/type/const").and_then(Json::as_str) else {
                continue;
            };
            let _ = write!(self.out, "### {name} `{tag}`\n\n");
            if let Some(d) = alt.get("description").and_then(Json::as_str) {
                let _ = write!(self.out, "{}\n\n", clean(d));
            }
            // Every bundled block of this `type`, in order; the example shows the one that
            // sets the most fields.
            let blocks: Vec<(&Yaml, &[Seg], &str)> = examples
                .iter()
                .flat_map(|ex| {
                    used_at.iter().flat_map(move |at| {
                        values_at(&ex.doc, at)
                            .into_iter()
                            .map(move |v| (v, at.as_slice(), ex.file.as_str()))
                    })
                })
                .filter(|(v, _, _)| v.get("type").and_then(Yaml::as_str) == Some(tag))
                .collect();
            let len = |v: &Yaml| v.as_mapping().map_or(0, |m| m.len());
            let best = blocks
                .iter()
                .copied()
                .fold(None, |b: Option<(&Yaml, &[Seg], &str)>, x| match b {
                    Some(b) if len(b.0) >= len(x.0) => Some(b),
                    _ => Some(x),
                });
            let none = serde_json::Map::new();
            let (props, req) = s.properties(alt).unwrap_or((&none, Vec::new()));
            let fields: Vec<(&String, &Json)> = ordered(props, &req)
                .into_iter()
                .filter(|(k, _)| k.as_str() != "type")
                .collect();
            if fields.is_empty() {
                self.out.push_str("No fields besides `type`.\n\n");
            } else {
                self.out.push_str("Fields:\n\n");
            }
            for &(k, p) in &fields {
                self.fields += 1;
                let default = p.get("default");
                let mut line = format!("- `{k}`: {}", s.type_text(p));
                if req.contains(&k.as_str()) {
                    line.push_str(", required");
                } else if let Some(d) = default {
                    let _ = write!(line, ", default `{}`", flow(&to_yaml(d)));
                } else {
                    line.push_str(", optional");
                }
                line.push('.');
                if let Some(d) = p.get("description").and_then(Json::as_str) {
                    let _ = write!(line, " {}", clean(d).replace('\n', " "));
                }
                if let Some(values) = s.enum_values(p).filter(|v| v.iter().any(|x| x.1.is_some())) {
                    let v: Vec<String> = values
                        .iter()
                        .map(|(c, d)| {
                            format!(
                                "`{}`: {}",
                                flow(&to_yaml(c)),
                                d.map(|d| clean(d).replace('\n', " ")).unwrap_or_default()
                            )
                        })
                        .collect();
                    let _ = write!(line, " Values: {}", v.join("; "));
                    if !line.ends_with('.') {
                        line.push('.');
                    }
                }
                // The value in the example block, else in the first bundled block that sets
                // it, else the default, else made up.
                let found = best
                    .into_iter()
                    .chain(blocks.iter().copied())
                    .find_map(|(b, _, f)| b.get(k.as_str()).map(|v| (v, f)));
                let example = match found {
                    Some((v, f)) => format!("`{}` (`{f}`)", flow(v)),
                    None => match default {
                        Some(d) => format!("`{}`", flow(&to_yaml(d))),
                        None => format!("`{}` (made up)", flow(&s.made_up(p, k, 0))),
                    },
                };
                let _ = writeln!(line, " Example: {example}.");
                self.out.push_str(&line);
            }
            if !fields.is_empty() {
                self.out.push('\n');
            }
            let (block, at, src) = match best {
                Some((v, at, f)) => (v.clone(), at.to_vec(), format!(" (from `{f}`)")),
                None => (
                    s.made_up_object(alt, 0),
                    used_at.first().cloned().unwrap_or_default(),
                    " (made up for illustration)".into(),
                ),
            };
            let _ = write!(
                self.out,
                "Example{src}:\n\n```yaml\n{}```\n\n",
                nested(&at, &block)
            );
        }
    }
}

/// Where an example came from.
enum Source {
    Schema,
    File(String),
    Default,
    Made,
}

/// Whether an object default is just each property at its own default.
fn children_default(d: &Json, props: &serde_json::Map<String, Json>) -> bool {
    let Some(m) = d.as_object() else {
        return false;
    };
    m.iter().all(|(k, v)| {
        props
            .get(k)
            .and_then(|p| p.get("default"))
            .is_some_and(|pd| same(pd, v))
    })
}

/// Equal JSON values, numbers compared as numbers (`1` is `1.0`).
fn same(a: &Json, b: &Json) -> bool {
    match (a, b) {
        (Json::Number(x), Json::Number(y)) => x.as_f64() == y.as_f64(),
        (Json::Array(x), Json::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(p, q)| same(p, q))
        }
        (Json::Object(x), Json::Object(y)) => {
            x.len() == y.len() && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| same(v, w)))
        }
        _ => a == b,
    }
}

fn to_yaml(v: &Json) -> Yaml {
    serde_norway::to_value(v).unwrap_or(Yaml::Null)
}

fn to_json(v: &Yaml) -> Json {
    serde_json::to_value(v).unwrap_or(Json::Null)
}

/// The values at `path` in a spec: `[]` steps into a list's items, and a key applied to a list
/// applies to each item (one record or a list of them).
fn values_at<'y>(doc: &'y Yaml, path: &[Seg]) -> Vec<&'y Yaml> {
    let mut cur: Vec<&Yaml> = vec![doc];
    for seg in path {
        let mut next = Vec::new();
        for v in cur {
            match seg {
                Seg::Items => {
                    if let Some(s) = v.as_sequence() {
                        next.extend(s.iter());
                    }
                }
                Seg::Key(k) => match v {
                    Yaml::Sequence(s) => {
                        next.extend(s.iter().filter_map(|i| i.get(k.as_str())));
                    }
                    _ => next.extend(v.get(k.as_str())),
                },
            }
        }
        cur = next;
    }
    cur
}

/// Descriptions as Markdown: rustdoc links (``[`X`]``, ``[text](path)`` to Rust items) become
/// plain text.
fn clean(d: &str) -> String {
    let mut out = String::with_capacity(d.len());
    let mut rest = d;
    while let Some(i) = rest.find('[') {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        match after.find(']') {
            Some(j) if !after[..j].contains('[') => {
                let inner = &after[..j];
                let tail = &after[j + 1..];
                if let Some(t) = tail.strip_prefix('(') {
                    if let Some(k) = t.find(')') {
                        let target = &t[..k];
                        if !target.contains("://") && !target.contains(".md") {
                            // A link to a Rust item: keep its text.
                            out.push_str(inner);
                            rest = &t[k + 1..];
                            continue;
                        }
                    }
                    out.push('[');
                    rest = after;
                } else if inner.starts_with('`') && inner.ends_with('`') && inner.len() > 1 {
                    let name = inner.trim_matches('`');
                    let short = name.rsplit("::").next().unwrap_or(name);
                    let _ = write!(out, "`{short}`");
                    rest = tail;
                } else {
                    out.push('[');
                    rest = after;
                }
            }
            _ => {
                out.push('[');
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

/// `text` with every line indented by `n` spaces (an empty line stays empty).
fn indent(text: &str, n: usize) -> String {
    let pad = " ".repeat(n);
    text.lines()
        .map(|l| {
            if l.is_empty() {
                "\n".to_string()
            } else {
                format!("{pad}{l}\n")
            }
        })
        .collect()
}

/// `value` placed at `path` as YAML: one line per key of the path, the value in flow style
/// when it fits on a line, else in block style.
fn nested(path: &[Seg], value: &Yaml) -> String {
    let mut out = String::new();
    let mut depth = 0;
    let mut i = 0;
    while i < path.len() {
        let Seg::Key(k) = &path[i] else {
            i += 1;
            continue;
        };
        let pad = "  ".repeat(depth);
        let items = matches!(path.get(i + 1), Some(Seg::Items));
        let last = i + 1 == path.len() || (items && i + 2 == path.len());
        if last {
            if items {
                let _ = writeln!(out, "{pad}{}:", key(k));
                let item_pad = "  ".repeat(depth + 1);
                out.push_str(&block_item(value, &item_pad));
            } else {
                out.push_str(&block_entry(k, value, &pad));
            }
            return out;
        }
        let _ = writeln!(out, "{pad}{}:", key(k));
        depth += 1;
        if items {
            // A list item holding the rest of the path.
            let rest = nested(&path[i + 2..], value);
            let item_pad = "  ".repeat(depth);
            for (n, l) in rest.lines().enumerate() {
                let lead = if n == 0 { "- " } else { "  " };
                let _ = writeln!(out, "{item_pad}{lead}{l}");
            }
            return out;
        }
        i += 1;
    }
    out.push_str(&flow(value));
    out.push('\n');
    out
}

const WIDTH: usize = 88;

/// `k: value` at `pad`, flow style if it fits, else block style.
fn block_entry(k: &str, v: &Yaml, pad: &str) -> String {
    let f = flow(v);
    if pad.len() + k.len() + 2 + f.len() <= WIDTH {
        return format!("{pad}{}: {f}\n", key(k));
    }
    let mut out = format!("{pad}{}:\n", key(k));
    let inner = format!("{pad}  ");
    match v {
        Yaml::Mapping(m) => {
            for (mk, mv) in m {
                let name = match mk {
                    Yaml::String(s) => s.clone(),
                    other => flow(other),
                };
                out.push_str(&block_entry(&name, mv, &inner));
            }
        }
        Yaml::Sequence(s) => {
            for item in s {
                out.push_str(&block_item(item, &inner));
            }
        }
        _ => return format!("{pad}{}: {f}\n", key(k)),
    }
    out
}

/// `- item` at `pad`, flow style if it fits, else a block mapping.
fn block_item(v: &Yaml, pad: &str) -> String {
    let f = flow(v);
    if pad.len() + 2 + f.len() <= WIDTH {
        return format!("{pad}- {f}\n");
    }
    match v {
        Yaml::Mapping(m) => {
            let mut out = String::new();
            let inner = format!("{pad}  ");
            for (n, (mk, mv)) in m.iter().enumerate() {
                let name = match mk {
                    Yaml::String(s) => s.clone(),
                    other => flow(other),
                };
                let entry = block_entry(&name, mv, &inner);
                if n == 0 {
                    out.push_str(pad);
                    out.push_str("- ");
                    out.push_str(entry.trim_start());
                } else {
                    out.push_str(&entry);
                }
            }
            out
        }
        Yaml::Sequence(s) => {
            let mut out = format!("{pad}-\n");
            for item in s {
                out.push_str(&block_item(item, &format!("{pad}  ")));
            }
            out
        }
        _ => format!("{pad}- {f}\n"),
    }
}

/// A mapping key as YAML.
fn key(k: &str) -> String {
    scalar_str(k)
}

/// A string as a YAML scalar: plain when it reads back as the same string, else quoted.
fn scalar_str(s: &str) -> String {
    let lower = s.to_ascii_lowercase();
    let plain = !s.is_empty()
        && s.chars()
            .all(|c| c.is_alphanumeric() || "_-./+".contains(c))
        && !s.starts_with(['-', '+'])
        && !lower.starts_with(".inf")
        && !lower.starts_with(".nan")
        && !matches!(
            lower.as_str(),
            "true" | "false" | "null" | "yes" | "no" | "on" | "off" | "~"
        )
        && s.parse::<f64>().is_err()
        && !s.starts_with(|c: char| c.is_ascii_digit());
    if plain {
        s.to_string()
    } else {
        serde_json::to_string(s).unwrap_or_default()
    }
}

/// A value in YAML flow style (`{ type: offset }`, `[0.5, 0.7]`), keys in their order.
fn flow(v: &Yaml) -> String {
    match v {
        Yaml::Null => "null".into(),
        Yaml::Bool(b) => b.to_string(),
        Yaml::Number(n) => n.to_string(),
        Yaml::String(s) => scalar_str(s),
        Yaml::Sequence(s) => {
            let items: Vec<String> = s.iter().map(flow).collect();
            format!("[{}]", items.join(", "))
        }
        Yaml::Mapping(m) => {
            if m.is_empty() {
                return "{}".into();
            }
            let items: Vec<String> = m
                .iter()
                .map(|(k, v)| {
                    let k = match k {
                        Yaml::String(s) => scalar_str(s),
                        other => flow(other),
                    };
                    format!("{k}: {}", flow(v))
                })
                .collect();
            format!("{{ {} }}", items.join(", "))
        }
        Yaml::Tagged(t) => format!("{} {}", t.tag, flow(&t.value)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small schema in the shape schemars gives: a nested object behind a `$ref` with a
    /// default, an enumeration, a required field and a plugin union in a list.
    fn schema() -> Json {
        serde_json::json!({
            "title": "Spec",
            "type": "object",
            "required": ["plant"],
            "properties": {
                "plant": { "description": "The plant.", "type": "string" },
                "experiment": {
                    "$ref": "#/$defs/Experiment",
                    "default": { "filter": { "tol": 0.1 } }
                },
                "blocks": {
                    "description": "Blocks in signal order.",
                    "type": "array",
                    "items": { "$ref": "#/$defs/Block" }
                }
            },
            "$defs": {
                "Experiment": {
                    "description": "Experiment design.",
                    "type": "object",
                    "properties": {
                        "filter": { "$ref": "#/$defs/Filter", "default": { "tol": 0.1 } },
                        "shape": { "$ref": "#/$defs/Shape", "default": "square" }
                    }
                },
                "Filter": {
                    "type": "object",
                    "properties": {
                        "tol": {
                            "description": "Stop when the bracket is narrower than this.",
                            "type": "number",
                            "default": 0.1
                        },
                        "pole": { "description": "The pole, see [`Filter`].", "type": ["number", "null"] }
                    }
                },
                "Shape": {
                    "description": "The wave's shape.",
                    "oneOf": [
                        { "description": "A square wave.", "type": "string", "const": "square" },
                        { "description": "A ramp.", "type": "string", "const": "ramp" }
                    ]
                },
                "Block": {
                    "description": "A block: one of the registered plugin types (gain)",
                    "type": "object",
                    "oneOf": [{
                        "title": "gain",
                        "description": "A gain `k`.",
                        "type": "object",
                        "properties": {
                            "type": { "const": "gain" },
                            "k": { "description": "The gain.", "type": "number" }
                        },
                        "required": ["type", "k"]
                    }]
                }
            }
        })
    }

    #[test]
    fn lists_nested_paths_enums_defaults_and_unions() {
        let examples = vec![ExampleSpec {
            file: "examples/a.yaml".into(),
            doc: serde_norway::from_str(
                "plant: p\nexperiment:\n  filter: { tol: 0.25 }\nblocks: [ { type: gain, k: 2.0 } ]\n",
            )
            .unwrap(),
        }];
        let md = render(&schema(), &examples);
        // The required field first, then the others by name.
        let at = |s: &str| md.find(s).unwrap_or_else(|| panic!("no {s:?} in\n{md}"));
        assert!(at("## `plant`") < at("## `blocks`"));
        assert!(at("## `blocks`") < at("## `experiment`"));
        // A nested path, its description, default and the bundled example naming its file.
        at("### `experiment.filter.tol`");
        at("Stop when the bracket is narrower than this.");
        at("- **Default:** `0.1`");
        at("- **Example** (from `examples/a.yaml`):");
        at("  experiment:\n    filter:\n      tol: 0.25\n");
        // An optional field no example sets: a value made up from its type.
        at("### `experiment.filter.pole`");
        at("The pole, see `Filter`.");
        // The enumeration's values with their descriptions; no example sets it, so the
        // example is its other value.
        at("### `experiment.shape`");
        at("- **Type:** one of `square`, `ramp`");
        at("- `ramp`: A ramp.");
        at("- **Example** (made up for illustration):\n\n  ```yaml\n  experiment:\n    shape: ramp\n");
        // The required field and the parent whose default is its fields' defaults.
        at("- **Default:** none: required");
        at("- **Default:** each field below at its default");
        // The union, with where it is used, its `type` and the type's fields.
        at("## Block\n");
        at("Used at [`blocks[]`](#blocks)");
        at("### Block `gain`");
        at("- `k`: number, required. The gain. Example: `2.0` (`examples/a.yaml`).");
        at("  - { type: gain, k: 2.0 }\n");
        // Seven fields: plant, blocks, experiment, its filter, tol, pole, shape; and `k`.
        at("(8 fields)");
    }

    #[test]
    fn nested_values_read_back_as_yaml() {
        let v: Yaml = serde_norway::from_str("{ type: offset, value: 0.01 }").unwrap();
        let path = [
            Seg::Key("model".into()),
            Seg::Key("effects".into()),
            Seg::Items,
        ];
        let text = nested(&path, &v);
        assert_eq!(
            text,
            "model:\n  effects:\n    - { type: offset, value: 0.01 }\n"
        );
        let back: Yaml = serde_norway::from_str(&text).unwrap();
        assert_eq!(back["model"]["effects"][0], v);
        for s in [
            "yes",
            "1.5",
            "a b",
            "",
            "-x",
            "u",
            "y",
            ".inf",
            "../data/a.csv",
        ] {
            let y: Yaml = serde_norway::from_str(&format!("k: {}", scalar_str(s))).unwrap();
            assert_eq!(y["k"].as_str(), Some(s), "{s}");
        }
    }
}
