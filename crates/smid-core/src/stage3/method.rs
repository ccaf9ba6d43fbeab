//! The stage-3 method trait, the method names of specs and the link-time registry of methods.
use super::{classical, exact_grid, shared, EivProblem, EivResult};
use crate::error::{Result, SmidError};
use serde::{Deserialize, Serialize};

/// A stage-3 method by its registered name (`method.eiv` in a spec, `--method` on the command
/// line, `method` in `result.json`): one of the methods in the registry ([`all`]). The name is
/// the method's own [`Stage3Method::name`]; a value is made only from a registered name
/// ([`EivMethod::parse`], deserialisation) or one of the built-in constants below.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct EivMethod(&'static str);

#[allow(non_upper_case_globals)]
impl EivMethod {
    /// [`classical`]: the orthant-wise LP outer set of Section 5.
    pub const Classical: EivMethod = EivMethod(classical::NAME);
    /// [`shared`]: the shared-error relaxation (the default).
    pub const Shared: EivMethod = EivMethod(shared::NAME);
    /// `sdp`: the moment relaxation, registered by the crate `smid-sdp` (which the facade
    /// links; its feature `openblas` makes it available).
    pub const Sdp: EivMethod = EivMethod("sdp");
    /// [`exact_grid`]: the exact-set reference on a grid.
    pub const ExactGrid: EivMethod = EivMethod(exact_grid::NAME);

    /// Whether this build can run the method: it is registered (`sdp` is registered by the
    /// crate `smid-sdp`) and available (`sdp` needs that crate's feature `openblas`).
    pub fn available(self) -> bool {
        by_name(self.0).is_some_and(|m| m.available())
    }

    /// The name used in specs and on the command line (the method's own name).
    pub fn name(self) -> &'static str {
        self.0
    }

    /// Every registered method, in documentation order (see [`all`]).
    pub fn registered() -> Vec<EivMethod> {
        all().map(|(m, _)| m).collect()
    }

    /// The registered method called `s` (`_` accepted for `-`).
    pub fn from_name(s: &str) -> Option<Self> {
        all()
            .map(|(m, _)| m)
            .find(|m| m.name() == s || m.name().replace('-', "_") == s)
    }

    /// Parse a name given by a user (surrounding blanks ignored): an error naming the valid
    /// ones (specs, the CLI's `--method` and the Python package's `method=` all use it).
    pub fn parse(s: &str) -> Result<Self> {
        Self::from_name(s.trim()).ok_or_else(|| {
            SmidError::invalid(
                "method",
                format!(
                    "unknown stage-3 method `{s}`; expected one of: {}",
                    names().join(", ")
                ),
            )
        })
    }
}

impl Default for EivMethod {
    /// `shared`.
    fn default() -> Self {
        EivMethod::Shared
    }
}

impl std::fmt::Display for EivMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.0)
    }
}

impl Serialize for EivMethod {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(self.0)
    }
}

impl<'de> Deserialize<'de> for EivMethod {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        EivMethod::parse(&s).map_err(|e| match e {
            SmidError::Invalid { message, .. } => serde::de::Error::custom(message),
            e => serde::de::Error::custom(e),
        })
    }
}

impl schemars::JsonSchema for EivMethod {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "EivMethod".into()
    }
    /// One `const` per registered method, described by the method itself.
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        let one_of: Vec<serde_json::Value> = all()
            .map(|(m, imp)| {
                serde_json::json!({ "description": imp.description(), "type": "string", "const": m.name() })
            })
            .collect();
        schemars::json_schema!({ "description": "Stage-3 method: one of the registered methods.", "oneOf": one_of })
    }
}

/// A stage-3 method: maps an [`EivProblem`] to guaranteed θ intervals.
///
/// One required method, [`solve_from`](Self::solve_from), refines a guaranteed start box; the
/// rest have defaults. [`solve`](Self::solve) checks the problem ([`check`](Self::check)), gets
/// the start from the method named by [`start`](Self::start) through the registry (or the
/// problem's own box when `None`) and refines it. A method is never wider than its start.
///
/// ```
/// use smid_core::stage3::{EivProblem, EivResult, Stage3Method};
/// use smid_core::Result;
///
/// /// Reports its start unchanged: guaranteed (the start is), if not informative.
/// struct Keep;
/// impl Stage3Method for Keep {
///     fn solve_from(&self, _prob: &EivProblem, start: EivResult) -> Result<EivResult> {
///         Ok(start)
///     }
/// }
///
/// let (output, input) = (Vec::new(), Vec::new());
/// let prob = EivProblem {
///     na: 0,
///     nb: 0,
///     fixed: vec![Some(1.0)],
///     unit_gain: false,
///     output: &output,
///     input: &input,
///     use_band_samples: false,
///     lagged: None,
///     locate: true,
///     extra: &[],
///     prior: None,
/// };
/// let start = EivResult {
///     bounds: vec![smid_core::interval::Interval::new(1.0, 1.0)],
///     equations: vec![],
///     feasible_orthants: 0,
///     unsettled: None,
/// };
/// assert_eq!(Keep.solve_from(&prob, start).unwrap().bounds[0].lo, 1.0);
/// ```
pub trait Stage3Method: Send + Sync {
    /// Guaranteed θ bounds of `prob`, starting from the guaranteed result `start` (never wider
    /// than it). Required.
    fn solve_from(&self, prob: &EivProblem, start: EivResult) -> Result<EivResult>;

    /// The method's name in specs, on the command line and in messages: its one name. A
    /// registered method must give its own (the default, the type's path, is for unregistered
    /// helpers such as doc examples).
    fn name(&self) -> &'static str {
        std::any::type_name::<Self>()
    }

    /// One line for the spec's JSON Schema and `--help`. Default: empty.
    fn description(&self) -> &'static str {
        ""
    }

    /// This method with the options of a spec's `method.options` (see [`parse_options`]).
    /// `Ok(None)`: the registered instance as it is. Default: no options; any given is an
    /// error naming the method.
    fn with_options(
        &self,
        options: &serde_json::Map<String, serde_json::Value>,
    ) -> Result<Option<Box<dyn Stage3Method>>> {
        match options.keys().next() {
            None => Ok(None),
            Some(k) => Err(SmidError::invalid(
                format!("method.options.{k}"),
                format!("the stage-3 method `{}` takes no options", self.name()),
            )),
        }
    }

    /// Whether this build can run the method (e.g. a cargo feature it needs is on).
    fn available(&self) -> bool {
        true
    }

    /// The method whose result this one starts from; `None`: from the problem alone.
    fn start(&self) -> Option<EivMethod> {
        None
    }

    /// The method the pipeline retries with when this one reports solver trouble
    /// ([`SmidError::Solver`]); its outer bound is as guaranteed. Default: `shared`.
    fn fallback(&self) -> EivMethod {
        EivMethod::Shared
    }

    /// Refuse a problem this method cannot handle (before any start is computed), with an
    /// error saying why; `Ok` by default.
    fn check(&self, _prob: &EivProblem) -> Result<()> {
        Ok(())
    }

    /// Guaranteed θ bounds of `prob`: a problem with [`lagged`](EivProblem::lagged) past
    /// outputs is solved as its [`flattened`](EivProblem::flattened) problem (the bounds in
    /// its own θ order, errors in its own names); then [`EivProblem::validate`],
    /// [`check`](Self::check), the start (the result of [`start`](Self::start) through the
    /// registry, or [`prior_start`]), then [`solve_from`](Self::solve_from).
    fn solve(&self, prob: &EivProblem) -> Result<EivResult> {
        if let Some(f) = prob.flattened()? {
            return self.solve(&f.problem(prob)).map_err(|e| f.error(e, prob));
        }
        prob.validate()?;
        self.check(prob)?;
        let start = match self.start() {
            Some(m) => solve(m, prob)?,
            None => prior_start(prob)?,
        };
        self.solve_from(prob, start)
    }
}

/// The start of a method that starts from the problem alone: its [`EivProblem::start_box`]
/// (prior box, fixed entries at their values) over every usable equation.
pub fn prior_start(prob: &EivProblem) -> Result<EivResult> {
    Ok(EivResult {
        bounds: prob.start_box()?,
        equations: prob.equation_times(),
        feasible_orthants: 0,
        unsettled: None,
    })
}

/// A registered stage-3 method ([`register_stage3!`](crate::register_stage3)): the method
/// (with its default options) and its place in documentation order.
pub struct MethodEntry {
    /// Documentation order (the built-in methods: 0, 10, 20, 30).
    pub order: u32,
    /// The method with its default options; its [`Stage3Method::name`] is its name everywhere.
    pub method: &'static dyn Stage3Method,
}

inventory::collect!(MethodEntry);

/// Register a stage-3 method: `register_stage3!(order, VALUE)` with `VALUE` a constant
/// expression of a type implementing [`Stage3Method`] (its default options). The method file
/// calls it once; the spec, the schema, the CLI and the Python package then offer the method.
#[macro_export]
macro_rules! register_stage3 {
    ($order:expr, $method:expr) => {
        $crate::inventory::submit! {
            $crate::stage3::MethodEntry { order: $order, method: &$method }
        }
    };
}

/// The registered implementation of `m` (default options).
pub fn method(m: EivMethod) -> &'static dyn Stage3Method {
    entries()
        .iter()
        .find(|e| e.method.name() == m.name())
        .map(|e| e.method)
        .expect("an EivMethod is made only from a registered name")
}

/// The registered methods in documentation order, collected once (the pipeline looks a
/// method up per cell).
fn entries() -> &'static [&'static MethodEntry] {
    static ENTRIES: std::sync::OnceLock<Vec<&'static MethodEntry>> = std::sync::OnceLock::new();
    ENTRIES.get_or_init(|| {
        let mut v: Vec<_> = inventory::iter::<MethodEntry>.into_iter().collect();
        v.sort_by_key(|e| (e.order, e.method.name()));
        v
    })
}

/// The method of a spec name (`_` for `-` too).
pub fn by_name(name: &str) -> Option<&'static dyn Stage3Method> {
    EivMethod::from_name(name).map(method)
}

/// Every registered method with its implementation, in documentation order (including those
/// this build cannot run: see [`Stage3Method::available`]).
pub fn all() -> impl Iterator<Item = (EivMethod, &'static dyn Stage3Method)> {
    entries()
        .iter()
        .map(|e| (EivMethod(e.method.name()), e.method))
}

/// The names of every registered method, in documentation order (the CLI's and the Python
/// package's lists).
pub fn names() -> Vec<&'static str> {
    all().map(|(m, _)| m.name()).collect()
}

/// The method `m` with a spec's options (`method.options`, checked by the method: an unknown
/// or mistyped option is an error naming it); the registered default when none are given.
/// The options are the chosen method's only: the method it starts from
/// ([`Stage3Method::start`]) and its fallback run with their defaults.
pub fn configured(
    m: EivMethod,
    options: &serde_json::Map<String, serde_json::Value>,
) -> Result<ConfiguredMethod> {
    let imp = method(m);
    match imp.with_options(options)? {
        Some(b) => Ok(ConfiguredMethod::Owned(b)),
        None => Ok(ConfiguredMethod::Registered(imp)),
    }
}

/// A method as the pipeline runs it: the registered one or one built with spec options.
pub enum ConfiguredMethod {
    /// The registered instance with its default options (no `method.options` given).
    Registered(&'static dyn Stage3Method),
    /// An instance built from the spec's `method.options`.
    Owned(Box<dyn Stage3Method>),
}

impl std::ops::Deref for ConfiguredMethod {
    type Target = dyn Stage3Method;
    fn deref(&self) -> &Self::Target {
        match self {
            ConfiguredMethod::Registered(m) => *m,
            ConfiguredMethod::Owned(b) => b.as_ref(),
        }
    }
}

/// [`Stage3Method::with_options`] for a method whose options are the fields of `T`: `None`
/// when none are given, else the method `build` makes from the parsed options
/// ([`parse_options`]).
pub fn with_parsed_options<T: serde::de::DeserializeOwned>(
    name: &str,
    options: &serde_json::Map<String, serde_json::Value>,
    build: impl FnOnce(T) -> Box<dyn Stage3Method>,
) -> Result<Option<Box<dyn Stage3Method>>> {
    if options.is_empty() {
        return Ok(None);
    }
    Ok(Some(build(parse_options(name, options)?)))
}

/// Options of a method from `method.options`: the fields of `T` (unknown ones refused), the
/// rest at `T`'s defaults. For [`Stage3Method::with_options`] implementations.
pub fn parse_options<T: serde::de::DeserializeOwned>(
    name: &str,
    options: &serde_json::Map<String, serde_json::Value>,
) -> Result<T> {
    serde_json::from_value(serde_json::Value::Object(options.clone())).map_err(|e| {
        SmidError::invalid(
            "method.options",
            format!("options of the stage-3 method `{name}`: {e}"),
        )
    })
}

/// A cheap necessary test of consistency: whether the classical outer set is non-empty
/// (`false` proves that no θ fits; `true` proves nothing). See [`classical::feasible`].
pub fn feasible(prob: &EivProblem) -> Result<bool> {
    match prob.flattened()? {
        Some(f) => classical::feasible(&f.problem(prob)).map_err(|e| f.error(e, prob)),
        None => classical::feasible(prob),
    }
}

/// Stage 3 by the chosen method (the pipeline's entry point).
pub fn solve(m: EivMethod, prob: &EivProblem) -> Result<EivResult> {
    method(m).solve(prob)
}
