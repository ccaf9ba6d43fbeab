"""Identification, validation, diagnosis and simulation with smid's one model set.

Every function here calls the same Rust code as the CLI (``smid run``, ``smid validate``,
``smid diagnose``) through the native module ``smid._native``; results come back as the JSON
the CLI writes and are turned into numpy arrays and small objects here.
"""
from __future__ import annotations

import csv
import json
import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._native import DataError, InvalidError, SpecError

SpecLike = Union[str, "os.PathLike[str]", Mapping[str, Any]]
ArrayLike = Union[Sequence[float], np.ndarray]
RecordsLike = Union[
    Tuple[ArrayLike, ArrayLike],
    Sequence[Tuple[ArrayLike, ArrayLike]],
    Sequence[Tuple[str, ArrayLike, ArrayLike]],
    Mapping[str, Tuple[ArrayLike, ArrayLike]],
]


def _json_default(v: Any) -> Any:
    """numpy scalars and arrays, paths: what a spec dict may hold besides plain values."""
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, os.PathLike):
        return os.fspath(v)
    raise InvalidError(f"invalid spec value {v!r}: expected numbers, strings, lists or dicts")


def _spec_source(spec: SpecLike, base: Optional[Union[str, "os.PathLike[str]"]]) -> Tuple[str, str, str]:
    """(text, label, base directory) of a spec given as a path, a YAML string or a dict."""
    if isinstance(spec, Mapping):
        # JSON is YAML: the dict goes through the same parser (and errors) as a file.
        text = json.dumps(spec, default=_json_default)
        return text, "<dict>", str(base if base is not None else os.getcwd())
    # A one-line string is a path; YAML text has lines (or is JSON).
    if isinstance(spec, os.PathLike) or (isinstance(spec, str) and "\n" not in spec and not spec.lstrip().startswith("{")):
        path = Path(spec)
        if not path.is_file():
            if isinstance(spec, str) and ": " in spec:
                return spec, "<string>", str(base if base is not None else os.getcwd())
            raise SpecError(f"{path}: no such spec file (give a path, a YAML string or a dict)")
        return path.read_text(encoding="utf-8"), str(path), str(base if base is not None else path.parent)
    if isinstance(spec, str):
        return spec, "<string>", str(base if base is not None else os.getcwd())
    raise TypeError(f"spec: expected a path, a YAML string or a dict, got {type(spec).__name__}")


def _vector(a: ArrayLike, what: str) -> List[float]:
    try:
        v = np.asarray(a, dtype=float)
    except (TypeError, ValueError) as e:
        raise DataError(f"array `{what}`: expected numbers ({e})") from None
    if v.ndim != 1:
        raise InvalidError(f"invalid `{what}`: expected a 1-D array, got shape {v.shape}")
    return v.tolist()


def _is_1d(a: Any) -> bool:
    try:
        return np.ndim(a) == 1
    except ValueError:  # ragged
        return False


def _records(records: RecordsLike, what: str) -> List[Tuple[str, List[float], List[float]]]:
    """Normalise records: ``(u, y)``, a list of ``(u, y)`` or ``(name, u, y)``, or a dict
    ``name -> (u, y)``."""
    if isinstance(records, Mapping):
        items: Iterable[Any] = [(str(k), v[0], v[1]) for k, v in records.items()]
    elif isinstance(records, tuple) and len(records) == 2 and not isinstance(records[0], (str, tuple)) and _is_1d(records[0]):
        items = [records]
    else:
        items = list(records)
    out = []
    for i, r in enumerate(items):
        if not isinstance(r, (tuple, list)):
            raise InvalidError(f"invalid `{what}[{i}]`: expected (u, y) or (name, u, y)")
        if len(r) == 3:
            name, u, y = r
        elif len(r) == 2:
            name, (u, y) = f"{what} {i + 1}", r
        else:
            raise InvalidError(f"invalid `{what}[{i}]`: expected (u, y) or (name, u, y)")
        uu, yy = _vector(u, f"{what} `{name}`: u"), _vector(y, f"{what} `{name}`: y")
        for col, v in (("u", uu), ("y", yy)):
            bad = np.flatnonzero(~np.isfinite(np.asarray(v)))
            if bad.size:
                raise DataError(f"{what} `{name}`, array `{col}`, sample {bad[0]}: expected a finite number, got {v[bad[0]]}")
        out.append((str(name), uu, yy))
    if not out:
        raise InvalidError(f"invalid `{what}`: no record given")
    return out


@dataclass(frozen=True)
class Parameter:
    """Guaranteed bounds of one parameter: the truth lies in ``[lower, upper]`` whenever the
    noise stays within its declared bound. ``truth`` and ``contains`` are known for plants whose
    truth smid knows (simulators, FMUs with declared values)."""

    name: str
    lower: float
    upper: float
    center: float
    radius: float
    truth: Optional[float] = None
    contains: Optional[bool] = None


@dataclass(frozen=True)
class Verdict:
    """Consistent, or falsified: the data contradict the model and noise bound, at ``stage``
    and first offending ``sample`` of ``record`` (the training record in an identification, the
    fresh record in a validation). ``located`` is False when ``sample`` is only one by which
    the data are inconsistent (the first offending one was not looked for).

    A validation's verdict also has ``kind``: ``proven`` (a member of the set satisfies the
    training and the fresh equations), ``consistent`` (no contradiction found), ``undecided``
    (neither proven nor falsified; ``message`` says why, and ``consistent`` is False) or
    ``falsified``."""

    consistent: bool
    stage: Optional[str] = None
    sample: Optional[int] = None
    detail: Optional[str] = None
    message: Optional[str] = None
    record: Optional[int] = None
    located: Optional[bool] = None
    kind: Optional[str] = None


@dataclass(frozen=True)
class InnerBounds:
    """Bounds of the unmeasured inner signal (stage 2): ``lower[t] <= x_t <= upper[t]``;
    ``kind[t]`` is ``inverted``, ``band`` or ``unknown`` (infinite bounds)."""

    lower: np.ndarray
    upper: np.ndarray
    kind: List[str]


@dataclass(frozen=True)
class Simulation:
    """Free run from rest of a model set: the simulation member's output ``y`` (the central
    member's when none was certified; inner signal
    ``x``, nonlinearity output ``w``) and the envelope ``[lower, upper]``: over members
    certified consistent when the identification found them (an inner approximation of the
    set's output range), else over the axis members (indicative, not a guarantee);
    ``envelope`` says which."""

    y: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    x: np.ndarray
    w: np.ndarray
    stable_members: int
    members: int
    envelope: str = ""


def _pandas():
    try:
        import pandas  # noqa: F401
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("pandas is not installed: use the dicts and arrays instead") from e
    return pandas


class ModelSet:
    """The identified model set (what ``smid run`` writes into ``result.json``): validate it,
    diagnose it, simulate it, save it. Built by :func:`identify` or :meth:`load`."""

    def __init__(self, result: Mapping[str, Any]):
        _check_format(result, "result", "<result>")
        if "model" not in result or "spec" not in result:
            raise InvalidError("invalid `result`: not a result.json of smid run (no `model` or `spec`)")
        self._result = dict(result)

    @classmethod
    def load(cls, path: Union[str, "os.PathLike[str]"]) -> "ModelSet":
        """Read a ``result.json`` written by ``smid run`` or :meth:`save`."""
        p = Path(path)
        try:
            text = p.read_text(encoding="utf-8")
        except OSError as e:
            raise DataError(f"{p}: {e.strerror or e}") from None
        try:
            result = json.loads(text)
        except json.JSONDecodeError as e:
            raise DataError(f"{p}: not a result.json ({e})") from None
        _check_format(result, "result", str(p))
        return cls(result)

    def save(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Write the model set as a ``result.json`` (readable by ``smid validate``)."""
        Path(path).write_text(json.dumps(self._result, indent=2), encoding="utf-8")

    @property
    def name(self) -> str:
        return str(self._result.get("name", ""))

    @property
    def spec(self) -> Dict[str, Any]:
        """The spec the set was identified with."""
        return self._result["spec"]

    @property
    def model(self) -> Dict[str, Any]:
        """The model set itself (structure, method, bound, cells, hull, training data)."""
        return self._result["model"]

    @property
    def parameters(self) -> List[Parameter]:
        return [_parameter(p) for p in self._result.get("parameters", [])]

    @property
    def simulation_member(self) -> Optional[Dict[str, Any]]:
        """The member certified consistent whose free run fits the training records best:
        ``values`` (name -> value), ``training_fit`` and the centre's ``centre_training_fit``
        (%), ``cell``, ``consistency``, ``certified``, and ``within`` (when the records have no
        steady-state points): the largest distance of its free run from any training sample,
        a bound at which the model is consistent, so the model's exact smallest consistent bound
        is at most it. When no point was certified within the
        search budget it is the best free run within the outer bounds with ``certified`` False
        (a stand-in for simulation, not a member of the set); ``None`` when not searched (the
        centre stands in)."""
        m = self.model.get("simulation_member")
        if m is None:
            return None
        out = dict(m)
        out["values"] = {n: float(v) for n, v in m["values"]}
        return out

    @property
    def unbounded_cells(self) -> List[Dict[str, Any]]:
        """Cells of the bisected parameters left without a finite θ bound when the
        branch and bound's refinement budget was spent (``cell``, ``cause``: ``unbounded`` or
        ``solver``, ``detail``); when any, every θ bound is infinite and the bisected
        parameters' bounds still hold. Empty for a fully bounded set."""
        return [dict(c) for c in self.model.get("search", {}).get("unbounded", [])]

    def validate(self, records: RecordsLike, *, k: int = 5) -> "Validation":
        """See :func:`validate`."""
        return validate(self, records, k=k)

    def diagnose(self, holdout: RecordsLike, *, max_effects: int = 2, only: Sequence[str] = (), k: int = 5) -> "Diagnosis":
        """See :func:`diagnose`."""
        return diagnose(self, holdout, max_effects=max_effects, only=only, k=k)

    def simulate(self, u: ArrayLike, *, dt: Optional[float] = None) -> Simulation:
        """See :func:`simulate`."""
        return simulate(self, u, dt=dt)

    def to_json(self) -> str:
        """The model set as the text of a ``result.json``."""
        return json.dumps(self._result)

    def __repr__(self) -> str:
        return f"ModelSet({self.name!r}, {len(self.parameters)} parameters, {len(self.model.get('cells', []))} cells)"


def _check_format(content: Any, kind: str, label: str) -> int:
    """The ``format_version`` of a ``kind`` file of smid (``result``, ``validation``,
    ``diagnosis``); :class:`smid.FormatError` naming ``label``, the field and the versions this
    smid reads when it is another kind of file, of a version this smid does not read, or
    unstamped. The check is the CLI's (the native module's)."""
    if not isinstance(content, Mapping):
        raise InvalidError(f"invalid `{label}`: expected a JSON object, got {type(content).__name__}")
    stamp = {k: content[k] for k in ("format", "format_version", "smid_version") if k in content}
    return int(_native.check_format(json.dumps(stamp), kind, label))


def _num(v: Any, null: float) -> float:
    """A JSON number; ``null`` is what serde_json writes for a non-finite value."""
    return null if v is None else float(v)


def _parameter(p: Mapping[str, Any]) -> Parameter:
    return Parameter(
        name=p["name"],
        lower=_num(p["lower"], -math.inf),
        upper=_num(p["upper"], math.inf),
        center=_num(p["center"], math.nan),
        radius=_num(p["radius"], math.inf),
        truth=p.get("truth"),
        contains=p.get("contains"),
    )


class Identification:
    """The outcome of :func:`identify`: bounds, or the finding that the data falsify the model.

    ``consistent`` is False when the feasible set is empty; then ``verdict`` says where
    (stage and first offending sample) and there are no bounds. Otherwise ``parameters``
    (and the arrays ``names``, ``lower``, ``upper``, ``center``), the nonlinearity
    ``regions``, the ``inner`` signal bounds and the ``model`` set are there, and ``result``
    is the very content of the CLI's ``result.json``."""

    def __init__(self, raw: Mapping[str, Any]):
        self._raw = dict(raw)
        if raw["status"] == "identified":
            self.result: Optional[Dict[str, Any]] = raw["result"]
            self.verdict = Verdict(consistent=True)
            self.table: str = raw["table"]
            self.files: List[str] = list(raw.get("files", []))
        else:
            self.result = None
            self.verdict = Verdict(
                consistent=False,
                stage=raw["stage"],
                sample=raw["sample"],
                detail=raw["detail"],
                message=raw["message"],
                record=raw.get("record"),
                located=raw.get("located"),
            )
            self.table = raw["message"] + "\n"
            self.files = []

    @property
    def consistent(self) -> bool:
        return self.verdict.consistent

    def _need(self) -> Dict[str, Any]:
        if self.result is None:
            raise InvalidError(f"invalid `identification`: the data falsify the model, there are no bounds ({self.verdict.message})")
        return self.result

    @property
    def parameters(self) -> List[Parameter]:
        return [_parameter(p) for p in self._need()["parameters"]]

    @property
    def names(self) -> List[str]:
        return [p.name for p in self.parameters]

    def _column(self, field: str) -> np.ndarray:
        return np.array([getattr(p, field) for p in self.parameters])

    lower = property(lambda self: self._column("lower"), doc="Guaranteed lower bounds (numpy array).")
    upper = property(lambda self: self._column("upper"), doc="Guaranteed upper bounds (numpy array).")
    center = property(lambda self: self._column("center"), doc="Centres of the bounds (numpy array).")
    radius = property(lambda self: self._column("radius"), doc="Radii of the bounds (numpy array).")

    def bounds(self) -> Dict[str, Tuple[float, float]]:
        """``{name: (lower, upper)}``."""
        return {p.name: (p.lower, p.upper) for p in self.parameters}

    @property
    def truth_inside(self) -> Optional[bool]:
        """Every bound contains the truth (None when no truth is known)."""
        c = [p.contains for p in self.parameters]
        return None if any(v is None for v in c) else all(c)

    @property
    def regions(self) -> List[Dict[str, Any]]:
        """The nonlinearity's feasible regions (polygons of the plugin's parameters)."""
        return self._need()["regions"]

    @property
    def inner(self) -> InnerBounds:
        b = self._need()["inner_signal"]["bounds"]
        num = lambda v, d: d if v is None else float(v)  # noqa: E731
        return InnerBounds(
            lower=np.array([num(x["interval"]["lo"], -np.inf) for x in b]),
            upper=np.array([num(x["interval"]["hi"], np.inf) for x in b]),
            kind=[x["kind"] for x in b],
        )

    @property
    def model(self) -> ModelSet:
        return ModelSet(self._need())

    def dataframe(self):
        """The parameter table as a pandas DataFrame (needs pandas)."""
        pd = _pandas()
        return pd.DataFrame([p.__dict__ for p in self.parameters]).set_index("name")

    def __repr__(self) -> str:
        if not self.consistent:
            return f"Identification(falsified: {self.verdict.message})"
        return f"Identification({len(self.parameters)} parameters, truth inside: {self.truth_inside})"


def identify(spec: SpecLike, *, base: Optional[Union[str, "os.PathLike[str]"]] = None, out: Optional[Union[str, "os.PathLike[str]"]] = None) -> Identification:
    """Identify from a spec, as ``smid run SPEC`` does.

    ``spec`` is a path to a YAML spec, a YAML string or a dict of the same content. Relative
    paths inside it resolve against ``base`` (default: the spec file's directory, else the
    current directory). With ``out``, the CLI's files (``result.json``, ``data.csv``, SVG
    plots) are written there. A falsified model is a result (``consistent`` False), not an
    exception; bad input raises :class:`smid.SmidError` subclasses with located messages.
    """
    text, label, b = _spec_source(spec, base)
    raw = _native.identify(text, label, b, None if out is None else str(out))
    return Identification(json.loads(raw))


def identify_arrays(
    u: ArrayLike,
    y: ArrayLike,
    *,
    model: Mapping[str, Any],
    noise: Mapping[str, Any],
    method: Optional[Mapping[str, Any]] = None,
    dt: float = 1.0,
    name: str = "arrays",
    truth: Optional[Mapping[str, float]] = None,
) -> Identification:
    """Identify from measured arrays ``u``, ``y`` (one dynamic record, no steady-state
    experiment), with ``model``, ``noise`` and ``method`` as the spec sections of the same
    name, e.g. ``model={"structure": "wiener", "nonlinearity": {"type": "linear"}, "na": 2,
    "nb": 2, "nk": 1}, noise={"delta": 1e-3}``. The arrays go through the same reader as a
    CSV record of ``smid run`` (a temporary file), so the result is the CLI's."""
    uu, yy = _vector(u, "u"), _vector(y, "y")
    if len(uu) != len(yy):
        raise InvalidError(f"invalid `u, y`: {len(uu)} inputs and {len(yy)} outputs, expected equal lengths")
    for what, v in (("u", uu), ("y", yy)):
        bad = np.flatnonzero(~np.isfinite(np.asarray(v)))
        if bad.size:
            raise DataError(f"array `{what}`, sample {bad[0]}: expected a finite number, got {v[bad[0]]}")
    if not uu:
        raise InvalidError("invalid `u, y`: empty arrays, expected one sample per row of the record")
    with tempfile.TemporaryDirectory(prefix="smid-") as d:
        path = Path(d) / "record.csv"
        with path.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["u", "y"])
            for a, b in zip(uu, yy):
                w.writerow([repr(a), repr(b)])
        spec: Dict[str, Any] = {
            "name": name,
            "plant": {"data": {"dynamic": {"file": str(path), "u": "u", "y": "y"}, "dt": dt}},
            "noise": dict(noise),
            "model": dict(model),
        }
        if truth:
            spec["plant"]["truth"] = dict(truth)
        if method:
            spec["method"] = dict(method)
        try:
            return identify(spec, base=d)
        except (DataError, InvalidError, SpecError) as e:
            # The temporary file is the caller's arrays: say so, not where it was written.
            raise type(e)(str(e).replace(str(path), "arrays `u`, `y`")) from None


def _model_text(model: Union[ModelSet, Identification, Mapping[str, Any], str, "os.PathLike[str]"]) -> str:
    """The ``result.json`` text of a model set given in any of the accepted forms."""
    if isinstance(model, Identification):
        model = model.model
    if isinstance(model, ModelSet):
        return model.to_json()
    if isinstance(model, Mapping):
        return ModelSet(model).to_json()
    if isinstance(model, (str, os.PathLike)) and not str(model).endswith(".json"):
        # A run spec, identified now (as `smid validate SPEC` does).
        r = identify(model)
        if not r.consistent:
            raise InvalidError(f"invalid `model`: the spec's training data falsify it ({r.verdict.message})")
        return _model_text(r)
    return ModelSet.load(model).to_json()


def _ends(values: Sequence[Any], fill: float) -> "np.ndarray":
    """A band end as floats, JSON's null (an infinite end) as ``fill``."""
    return np.asarray([fill if v is None else float(v) for v in values], dtype=float)


class Validation:
    """What ``smid validate`` reports on fresh records: the set-membership verdict, the
    smallest consistent noise bound (PASS when within the declared one; 0 when a cell admits
    the records down to 1e-9 of it), free-run / one-step /
    k-step fits next to the least-squares ARX baseline, residual correlations, warnings, and
    per record the series (numpy arrays) for plots. ``data`` is the whole report as a dict."""

    def __init__(self, raw: Mapping[str, Any]):
        self.data: Dict[str, Any] = raw["validation"]
        self.text: str = raw["text"]
        self.series: List[Dict[str, Any]] = [
            {
                "name": s["name"],
                "y": np.asarray(s["y"], dtype=float),
                "free_run": np.asarray(s["free_run"], dtype=float),
                "lower": np.asarray(s["envelope"][0], dtype=float),
                "upper": np.asarray(s["envelope"][1], dtype=float),
                "one_step": np.asarray(s["one_step"], dtype=float),
                "k_step": np.asarray(s["k_step"], dtype=float),
                "baseline": None if s["baseline"] is None else np.asarray(s["baseline"], dtype=float),
                # The guaranteed one-step band of the whole set (infinite where nothing is
                # guaranteed; JSON carries those ends as null).
                "band_lower": None if s.get("band") is None else _ends(s["band"][0], -math.inf),
                "band_upper": None if s.get("band") is None else _ends(s["band"][1], math.inf),
            }
            for s in raw["series"]
        ]

    @property
    def band(self) -> Optional[Dict[str, Any]]:
        """The guaranteed one-step band's summary: cells, samples, finite samples, mean width,
        measurements outside the band widened by the noise bound (each a contradiction of the
        set) and the first of them. ``None`` when not computed."""
        b = self.data.get("band")
        return None if b is None else dict(b)

    @property
    def verdict(self) -> Verdict:
        c = self.data["consistency"]
        f = c.get("falsified_at")
        kind = c.get("verdict")
        if c["consistent"] or not f:
            u = c.get("undecided")
            return Verdict(consistent=bool(c["consistent"]), kind=kind,
                           message=None if u is None else str(u.get("cause")))
        return Verdict(consistent=False, stage=f.get("stage"), sample=f.get("sample"), detail=f.get("detail"),
                       record=f.get("record"), located=f.get("located"), kind=kind,
                       message=f"record {f.get('record')}, sample {f.get('sample')}: {f.get('detail')}")

    @property
    def passed(self) -> bool:
        return bool(self.data["pass"])

    @property
    def fit(self) -> float:
        """Free-run fit % (MATLAB ``compare``) over the records of the member named by
        :attr:`member` (the simulation member when certified, else the centre)."""
        return _num(self.data["free_run"]["fit_percent"], -math.inf)

    @property
    def member(self) -> str:
        """Which member the free run and the predictions use."""
        return str(self.data.get("member", ""))

    @property
    def centre_fit(self) -> Optional[float]:
        """The central member's free-run fit %, reported beside the simulation member's."""
        c = self.data.get("centre_free_run")
        return None if c is None else _num(c["fit_percent"], -math.inf)

    @property
    def baseline_fit(self) -> Optional[float]:
        b = self.data.get("baseline")
        return None if b is None else _num(b["fit_percent"], -math.inf)

    @property
    def smallest_bound(self) -> Optional[Tuple[float, float]]:
        s = self.data.get("smallest_bound")
        return None if s is None else (float(s[0]), float(s[1]))

    @property
    def warnings(self) -> List[str]:
        return list(self.data["warnings"])

    def dataframe(self):
        """Per-record free-run fits as a pandas DataFrame (needs pandas)."""
        pd = _pandas()
        return pd.DataFrame([{"record": n, **f} for n, f in self.data["per_record"]]).set_index("record")

    def __repr__(self) -> str:
        return f"Validation(consistent={self.verdict.consistent}, pass={self.passed}, fit={self.fit:.2f} %)"


def validate(model: Union[ModelSet, Identification, Mapping[str, Any], str, "os.PathLike[str]"], records: RecordsLike, *, k: int = 5) -> Validation:
    """Validate a model set on fresh records, as ``smid validate``: ``records`` is ``(u, y)``,
    a list of ``(u, y)`` or ``(name, u, y)``, or a dict ``name -> (u, y)``; the records get the
    model's noise bound and sample time. ``model`` is a :class:`ModelSet`, an
    :class:`Identification`, a result dict or a ``result.json`` path."""
    text = _model_text(model)
    return Validation(json.loads(_native.validate(text, _records(records, "record"), int(k))))


class Diagnosis:
    """What ``smid diagnose`` reports: the choice made on training data alone (``added``:
    the effects or plugin added; ``summary`` in words) and the before/after columns on the
    held-out records (fit, verdict, bounds of each model). ``data`` is the whole report."""

    def __init__(self, raw: Mapping[str, Any]):
        self.data: Dict[str, Any] = dict(raw)
        self.text: str = raw["text"]
        self.summary: str = raw["summary"]
        self.added: List[str] = list(raw["choice"]["added"])
        self.before: Dict[str, Any] = raw["before"]
        self.after: Dict[str, Any] = raw["after"]

    def __repr__(self) -> str:
        return f"Diagnosis({self.summary!r})"


def diagnose(
    model: Union[SpecLike, ModelSet, Identification],
    holdout: RecordsLike,
    *,
    max_effects: int = 2,
    only: Sequence[str] = (),
    k: int = 5,
    base: Optional[Union[str, "os.PathLike[str]"]] = None,
) -> Diagnosis:
    """Diagnose a model, as ``smid diagnose``: the missing effect is chosen on the training
    data only (a model set's stored training data, or a spec's experiments), then the held-out
    records (read only for the final table) give the before/after columns. ``model`` is a
    :class:`ModelSet` / :class:`Identification` / ``result.json`` path, or a spec (path, YAML
    string or dict); ``only`` restricts the candidates to these ``type`` tags."""
    held = _records(holdout, "holdout")
    is_set = isinstance(model, (ModelSet, Identification)) or (
        isinstance(model, (str, os.PathLike)) and str(model).endswith(".json")
    ) or (isinstance(model, Mapping) and "model" in model and "spec" in model)
    if is_set:
        raw = _native.diagnose(_model_text(model), "result", "<result>", os.getcwd(), held, int(max_effects), list(only), int(k))
    else:
        text, label, b = _spec_source(model, base)
        raw = _native.diagnose(text, "spec", label, b, held, int(max_effects), list(only), int(k))
    return Diagnosis(json.loads(raw))


def simulate(model: Union[ModelSet, Identification, Mapping[str, Any], str, "os.PathLike[str]"], u: ArrayLike, *, dt: Optional[float] = None) -> Simulation:
    """Free run of a model set from rest on the input ``u``: the simulation member (the centre
    when none was certified) and the envelope."""
    text = _model_text(model)
    s = json.loads(_native.simulate(text, _vector(u, "u"), dt))
    arr = lambda k: np.asarray([np.nan if v is None else v for v in s[k]], dtype=float)  # noqa: E731
    return Simulation(y=arr("y"), lower=arr("lower"), upper=arr("upper"), x=arr("x"), w=arr("w"),
                      stable_members=int(s["stable_members"]), members=int(s["members"]),
                      envelope=str(s.get("envelope", "")))


@dataclass(frozen=True)
class PlantRecord:
    """A record of a spec's plant (``smid simulate``): input ``u``, measured output ``y =
    w + η`` with ``|η| <= added``, noise-free output ``w``, times ``t``, declared bound
    ``delta``."""

    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    w: np.ndarray
    delta: float
    added: float


def simulate_plant(spec: SpecLike, *, seed: Optional[int] = None, length: Optional[int] = None,
                   base: Optional[Union[str, "os.PathLike[str]"]] = None) -> PlantRecord:
    """Run the plant a spec names (built-in simulator or FMU) on the spec's PRBS experiment
    with another ``seed`` and/or ``length``, with its bounded noise: fresh data for
    :func:`validate` and :func:`diagnose`, as ``smid simulate SPEC --seed S`` writes them."""
    text, label, b = _spec_source(spec, base)
    r = json.loads(_native.simulate_plant(text, label, b, length, seed))
    return PlantRecord(t=np.asarray(r["t"], dtype=float), u=np.asarray(r["u"], dtype=float),
                       y=np.asarray(r["y"], dtype=float), w=np.asarray(r["w"], dtype=float),
                       delta=float(r["delta"]), added=float(r["added"]))


def schema() -> Dict[str, Any]:
    """The JSON Schema of specs (every registered plugin and effect)."""
    return json.loads(_native.schema())


def methods(available_only: bool = True) -> List[str]:
    """The registered stage-3 methods (``method=``), in documentation order; by default only
    those this build runs (``sdp`` needs the cargo feature ``sdp``)."""
    return [name for name, ok in _native.methods() if ok or not available_only]


def check_cases() -> List[str]:
    """The containment check's cases (``check(plugin=...)``), derived from the plugin registry."""
    return list(_native.check_cases())
