#!/usr/bin/python3
"""The firmware against the plain baseline on frames from the outside renderer (issue 50):
`../shared/conformance/run_case.py` on its three shipped cases and on seeded random mixes of the
renderer's environment (ghost offset, step and amplitude, speckle contrast and grain, frame count,
scene, seed). The mixes' seeds were fixed before any tuning on them; the renderer and the runner
are not the project's. Each case passes when run_case.py exits 0 (the firmware at least as good
as the baseline: no more points beyond 50 um, RMS no larger +0.5 um, >= 90 % of its points).

usage: conformance_mixes.py BIN_DIR CONFORMANCE_DIR [MIXES] [SEED]
exit: 0 when every case passes, 1 when one loses, 2 when a case could not run."""
import os, subprocess, sys
import numpy as np

bindir, kit = sys.argv[1], sys.argv[2]
mixes = int(sys.argv[3]) if len(sys.argv) > 3 else 20
seed = int(sys.argv[4]) if len(sys.argv) > 4 else 5000
cases = [({"GHOST_PX": "25", "GHOST_STEP": "7"}, "plane", 3),
         ({"SPECKLE": "0.3", "GRAIN_PX": "1.5"}, "cylinder", 4),
         ({"SPECKLE": "0.3", "GRAIN_PX": "1.5"}, "plane", 3),
         ({}, "sphere", 8),
         # a reflection's piece where the stripe curves along the epipolar lines and meets it on
         # two lines only (seed 6003's miss, 3.6 mm off: the unpaired test of epipolar.cc)
         ({"FRAMES": "17", "GHOST_AMP": "0.52", "GHOST_PX": "25", "GHOST_STEP": "13",
           "GRAIN_PX": "2.87", "SPECKLE": "0.12"}, "sphere", 61475)]
rng = np.random.default_rng(seed)
for _ in range(mixes):
    env = {}
    if rng.random() < 0.7:   # a reflection ghost: 3-80 px beside the stripe, 0-15 px a frame
        env.update(GHOST_PX=str(int(rng.integers(3, 81))), GHOST_STEP=str(int(rng.integers(0, 16))),
                   GHOST_AMP="%.2f" % rng.uniform(0.2, 0.8))
    if rng.random() < 0.6:   # speckle
        env.update(SPECKLE="%.2f" % rng.uniform(0.05, 0.5), GRAIN_PX="%.2f" % rng.uniform(1.0, 3.0))
    env["FRAMES"] = str(int(rng.integers(6, 25)))
    cases.append((env, str(rng.choice(["plane", "sphere", "cylinder"])), int(rng.integers(1, 10000))))
failed = broken = 0
for env, scene, case_seed in cases:
    run = subprocess.run([sys.executable, os.path.join(kit, "run_case.py"), bindir, scene, str(case_seed)],
                         env=dict(os.environ, **env), capture_output=True, text=True)
    said = " ".join("%s=%s" % kv for kv in sorted(env.items()))
    lines = [l for l in run.stdout.splitlines() if l.startswith(("firmware", "baseline"))]
    verdict = {0: "ok", 1: "LOSES"}.get(run.returncode, "FAILED TO RUN")
    print("%-13s %-8s %5d  %s" % (verdict, scene, case_seed, said))
    for l in lines:
        print("    " + l)
    if run.returncode == 1:
        failed += 1
    elif run.returncode != 0:
        broken += 1
        print(run.stdout[-1500:], run.stderr[-1500:])
print("%d cases: %d hold against the baseline, %d lose, %d could not run" %
      (len(cases), len(cases) - failed - broken, failed, broken))
sys.exit(2 if broken else (1 if failed else 0))
