"""Does an identified damper model hold a stuck force when large motion gives way to small?

Runs the simulation member of each identified model (a `result.json` of `smid run`) on
displacements that decay like a building's response after an earthquake (1 in at 0.5 Hz,
time constants 1, 2 and 4 s, 40 s at the models' 64 Hz), and reports the mean absolute force
over the last 10 s, when the motion has all but stopped. The records show no force inside the
play (below about 0.3 kip while x travels 0.12-0.14 in after a reversal); a model that keeps a
force there holds a stuck force. (When motion stops while the band slides, dry friction does
hold a force: the fastest decay shows that part.)

    smid run examples/damper-play.yaml --out out/damper-play      # the play model
    smid run examples/damper.yaml --out out/damper                 # the play + dead zone model
    python examples/damper_stuck_force.py out/damper-play/result.json out/damper/result.json

Writes `stuck_force.svg` beside the first result (needs matplotlib for the plot only).
"""
import sys
from pathlib import Path

import numpy as np

import smid

if len(sys.argv) < 2:
    sys.exit(__doc__)
dt = 16 / 1024
t = np.arange(0.0, 40.0, dt)
tail = t >= 30.0
runs = []
for tau in (1.0, 2.0, 4.0):
    x = np.exp(-t / tau) * np.sin(2 * np.pi * 0.5 * t)
    for path in sys.argv[1:]:
        force = np.asarray(smid.simulate(path, x).y)
        if tau == 2.0:
            runs.append((path, force, x))
        print(f"decay {tau:.0f} s, {path}: mean |force| over the last 10 s "
              f"{np.abs(force[tail]).mean():.3f} kip (largest {np.abs(force[tail]).max():.3f} kip)")
try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    sys.exit(0)
fig, ax = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
ax[0].plot(t, runs[0][2], color="k", lw=0.8)
ax[0].set_ylabel("displacement [in] (decay 2 s)")
for path, force, _ in runs:
    ax[1].plot(t, force, lw=0.8, label=Path(path).parent.name)
ax[1].set_ylabel("force [kip]")
ax[1].set_xlabel("t [s]")
ax[1].legend()
out = Path(sys.argv[1]).parent / "stuck_force.svg"
fig.savefig(out)
print(f"wrote {out}")
