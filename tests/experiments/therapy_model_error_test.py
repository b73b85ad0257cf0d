#!/usr/bin/env python3
"""`experiments/therapy/run model-error` against hand-computed leave-one-out values.

Three hearts, two sites each, every true AHR 10 %. Errors (predicted - true) and posterior stds:
a: +4, +2 (std 0); b: -3, -1 (std 1, given as std_posterior beside a wider std); c: 0, +2 (std 0).
Leaving a out (b and c): d^2 = ((9 - 1) + (1 - 1) + 0 + 4) / 4 = 3, d = 1.7321; mean squared error
(9 + 1 + 0 + 4) / 4 = 3.5, squared heart biases (b: -2, c: +1) 4 and 1, shared = 2.5 / 3.5 = 0.7143.
Leaving b out (a and c): d^2 = (16 + 4 + 0 + 4) / 4 = 6; shared = ((3^2 + 1^2) / 2) / 6 = 5 / 6.
Leaving c out (a and b): d^2 = (16 + 4 + 8 + 0) / 4 = 7; mean squared error 30 / 4 = 7.5, biases
3 and -2: shared = 6.5 / 7.5. Exit 0; fewer than 3 hearts is exit 2."""
import csv
import json
import pathlib
import subprocess
import sys
import tempfile

run = pathlib.Path(sys.argv[1])
with tempfile.TemporaryDirectory() as tmp:
    d = pathlib.Path(tmp)
    rows = ["heart,variant,site,status,AHR"] + [f"{h},lbbb,{s},ok,10" for h in "abc" for s in (1, 2)]
    (d / "truth.csv").write_text("\n".join(rows) + "\n")
    preds = d / "pred"
    preds.mkdir()
    given = {"a": [(14, 0, None), (12, 0, None)], "b": [(7, 5, 1), (9, 5, 1)], "c": [(10, 0, None), (12, 0, None)]}
    for h, sites in given.items():
        rows = []
        for site, (mean, std, post) in enumerate(sites, start=1):
            ahr = {"mean": mean, "std": std, "lower": None, "upper": None}
            if post is not None:
                ahr["std_posterior"] = post
            rows.append({"lv_segment": site, "AHR": ahr})
        (preds / f"{h}-therapy.json").write_text(json.dumps({"map": rows}))
    out = subprocess.run([sys.executable, run, "model-error", "--truth", d / "truth.csv", "--predictions", preds,
                          "--out", d / "out"], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
    got = {r["heart"]: (float(r["ahr_sd_points"]), float(r["shared"])) for r in csv.DictReader(open(d / "out" / "model-error.csv"))}
    want = {"a": (3 ** 0.5, 2.5 / 3.5), "b": (6 ** 0.5, 5 / 6), "c": (7 ** 0.5, 6.5 / 7.5)}
    for h, (sd, shared) in want.items():
        assert abs(got[h][0] - sd) < 1e-5 and abs(got[h][1] - shared) < 1e-5, (h, got[h], (sd, shared))
    (preds / "c-therapy.json").unlink()
    few = subprocess.run([sys.executable, run, "model-error", "--truth", d / "truth.csv", "--predictions", preds,
                          "--out", d / "out"], capture_output=True, text=True)
    assert few.returncode == 2 and "at least 3" in few.stderr, few.stdout + few.stderr
print("model-error: leave-one-out values as computed by hand")
