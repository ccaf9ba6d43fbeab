#!/usr/bin/env python3
"""Cross-check smid's FMU host against fmpy, the reference FMI tooling.

Usage: crosscheck.py CASES.json

CASES.json is a list of cases written by the Rust test crates/smid-fmu/tests/crosscheck.rs:
{"fmu": path, "input": name, "output": name, "step": h, "parameters": {name: value},
 "u": [...], "host": [...]} where "host" is the output smid's FmuPlant produced for "u".
For each distinct FMU, fmpy.validation.validate_fmu must find no problem; for each case,
fmpy.simulate_fmu on the same input (held over each step) must give the same output, sample by
sample, to 1e-12. Exit codes: 0 all agree, 1 a mismatch or a validation problem, 3 fmpy or numpy
is not installed (the caller decides whether that is acceptable).
"""
import json
import sys

TOL = 1e-12


def main():
    try:
        import numpy as np
        import fmpy
        from fmpy.validation import validate_fmu
    except ImportError as e:  # pragma: no cover - depends on the machine
        print(f"crosscheck: fmpy/numpy not available ({e}); install with `pip install fmpy`")
        return 3
    with open(sys.argv[1]) as f:
        cases = json.load(f)
    failures = 0
    validated = set()
    for case in cases:
        fmu = case["fmu"]
        if fmu not in validated:
            problems = validate_fmu(fmu)
            validated.add(fmu)
            if problems:
                print(f"FAIL validate_fmu({fmu}): {problems}")
                failures += 1
            else:
                print(f"ok   validate_fmu({fmu}) = []")
        h = float(case["step"])
        u = np.asarray(case["u"], dtype=float)
        n = len(u)
        t = np.arange(n) * h
        signals = np.array(list(zip(t, u)), dtype=[("time", float), (case["input"], float)])
        res = fmpy.simulate_fmu(
            fmu,
            start_time=0.0,
            stop_time=n * h,
            step_size=h,
            output_interval=h,
            start_values=case["parameters"],
            input=signals,
            output=[case["output"]],
        )
        # Row 0 is the state after initialization; row k + 1 follows the step that consumed u_k.
        ref = np.asarray(res[case["output"]][1 : n + 1], dtype=float)
        host = np.asarray(case["host"], dtype=float)
        label = f"{fmu.rsplit('/', 1)[-1]} {case['parameters']} ({n} samples)"
        if len(ref) != n:
            print(f"FAIL {label}: fmpy returned {len(ref)} samples, expected {n}")
            failures += 1
            continue
        diff = np.abs(ref - host)
        worst = float(diff.max()) if n else 0.0
        if not np.all(np.isfinite(ref)) or worst > TOL:
            k = int(diff.argmax())
            print(f"FAIL {label}: max |fmpy - smid| = {worst:.3e} at sample {k}")
            failures += 1
        else:
            print(f"ok   {label}: max |fmpy - smid| = {worst:.3e}")
    print(f"{len(cases) - failures if failures <= len(cases) else 0} passed, {failures} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
