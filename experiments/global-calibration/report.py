"""Tables of experiments/global-calibration from the JSON summaries in results/ (see run)."""
import json
import os
import sys

import yaml

out = sys.argv[1]
root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
cohort = yaml.safe_load(open(os.path.join(root, "configs", "data", "cohort.yaml")))
truths = {c["name"]: {k: float(v) for k, v in c["truth"].items()} for c in cohort["cases"]}
truths["twin-clean"] = truths["twin-noisy"] = {
    "sigma0": 6.0e4, "k_ATP": 7.2, "P_at0": 1060.0, "APD": 0.28, "R_d": 1.1e8}
params = ["sigma0", "k_ATP", "P_at0", "APD", "R_d"]

print("| case | " + " | ".join(f"{p} error (z)" for p in params) +
      " | mean abs error | RMS residual [noise std] | iterations | runs |")
print("|---" * (len(params) + 5) + "|")
rows = []
for name in ["twin-clean", "twin-noisy"] + sorted(n for n in truths if not n.startswith("twin")):
    path = os.path.join(out, name + ".json")
    if not os.path.exists(path):
        continue
    s = json.load(open(path))
    cells, errs = [], []
    for p in params:
        est, sd, tr = s["parameters"][p]["value"], s["parameters"][p]["std"], truths[name][p]
        e = 100.0 * (est - tr) / tr
        errs.append(abs(e))
        cells.append(f"{e:+.1f} % ({(est - tr) / sd:+.1f})")
    rows.append((name, sum(errs) / len(errs)))
    print(f"| {name} | " + " | ".join(cells) +
          f" | {sum(errs) / len(errs):.1f} % | {s['rms_normalised_residual']:.2f} |"
          f" {s['iterations']} | {s['simulations']} |")
vol = [e for n, e in rows if n.startswith("volunteer")]
if vol:
    print(f"\nmean absolute parameter error over the {len(vol)} volunteers: "
          f"{sum(vol) / len(vol):.1f} %")
