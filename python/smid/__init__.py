"""smid: guaranteed (set-membership) bounds for block-oriented nonlinear systems.

A linear block followed (Wiener) or preceded (Hammerstein) by a hard nonlinearity (backlash,
dead zone, saturation, ...), output errors known only to be bounded: smid returns bounds that
hold whenever the noise stays within its bound, or the finding that the data falsify the model.
The same engine and spec format as the ``smid`` CLI::

    import smid
    r = smid.identify("examples/paper.yaml")      # a path, a YAML string or a dict
    r.parameters, r.lower, r.upper                # guaranteed bounds
    v = smid.validate(r.model, (u_new, y_new))    # verdict, fits, ARX baseline
    s = smid.simulate(r.model, u_new)             # centre and envelope

Errors are :class:`SmidError` subclasses whose messages name the file, field or sample.
"""
from ._native import (
    DataError,
    FormatError,
    InconsistentError,
    InvalidError,
    PlantError,
    SmidError,
    SolverError,
    SpecError,
    UnboundedError,
    UnsupportedError,
    __version__,
)
from ._api import (
    Diagnosis,
    Identification,
    InnerBounds,
    ModelSet,
    Parameter,
    PlantRecord,
    Simulation,
    Validation,
    Verdict,
    diagnose,
    identify,
    check_cases,
    identify_arrays,
    methods,
    schema,
    simulate,
    simulate_plant,
    validate,
)
from .sweeps import CheckResult, check, check_merge, check_shard, reproduce_merge, reproduce_shard

__all__ = [
    "CheckResult", "DataError", "Diagnosis", "FormatError", "Identification", "InconsistentError", "InnerBounds",
    "InvalidError", "ModelSet", "Parameter", "PlantRecord", "PlantError", "Simulation", "SmidError", "SolverError",
    "SpecError", "UnboundedError", "UnsupportedError", "Validation", "Verdict", "__version__",
    "check", "check_cases", "check_merge", "check_shard", "diagnose", "identify", "identify_arrays", "methods",
    "reproduce_merge", "reproduce_shard", "schema", "simulate", "simulate_plant", "validate",
]
