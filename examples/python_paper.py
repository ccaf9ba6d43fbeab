"""smid from Python, notebook style: identify the paper's plant (Section 6), validate the
model set on a fresh record it never saw, simulate it, and plot with matplotlib.

    pip install .            # from the repository root (builds the native module)
    pip install matplotlib
    python examples/python_paper.py [--out DIR]
"""
import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files, no window
import matplotlib.pyplot as plt
import numpy as np

import smid

ap = argparse.ArgumentParser()
ap.add_argument("--out", default="out/python_paper")
out = Path(ap.parse_args().out)
out.mkdir(parents=True, exist_ok=True)
spec = Path(__file__).resolve().parent / "paper.yaml"

# %% Identify: guaranteed bounds (the same numbers as `smid run examples/paper.yaml`).
r = smid.identify(spec)
print(r.table, end="")
for p in r.parameters:
    print(f"{p.name:>4}: [{p.lower:.6f}, {p.upper:.6f}]  truth {p.truth}")

# %% Fresh data from the same plant (another PRBS seed, 400 samples), read once.
fresh = smid.simulate_plant(spec, seed=1001, length=400)

# %% Validate: verdict, free-run fit next to the least-squares ARX baseline.
v = smid.validate(r.model, (fresh.u, fresh.y))
arx = "n/a" if v.baseline_fit is None else f"{v.baseline_fit:.2f} %"
print(f"verdict: {'consistent' if v.verdict.consistent else 'FALSIFIED'}; "
      f"free-run fit {v.fit:.2f} % (ARX baseline {arx})")

# %% Simulate the model set from rest: the representative member and the envelope of the set.
s = smid.simulate(r.model, fresh.u)

t = np.arange(len(fresh.u))
fig, ax = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
ax[0].plot(t, fresh.y, "k", lw=1, label="measured y (fresh record)")
ax[0].plot(t, s.y, "b", lw=1, label="model set, centre (free run)")
ax[0].fill_between(t, s.lower, s.upper, color="b", alpha=0.2, label="envelope (s.envelope names its members)")
base = v.series[0]["baseline"]
if base is not None:
    ax[0].plot(t, base, "g--", lw=1, label="ARX baseline (free run)")
ax[0].legend(loc="upper right", fontsize=8)
ax[0].set_ylabel("y")
ax[1].plot(t, fresh.y - s.y, "r", lw=1)
ax[1].axhline(fresh.delta, color="grey", ls=":")
ax[1].axhline(-fresh.delta, color="grey", ls=":")
ax[1].set_ylabel("y - centre")
ax[1].set_xlabel("sample")
fig.suptitle(f"paper plant: free-run fit {v.fit:.1f} %")
fig.tight_layout()
fig.savefig(out / "validation.svg")
print(f"wrote {out / 'validation.svg'}")
