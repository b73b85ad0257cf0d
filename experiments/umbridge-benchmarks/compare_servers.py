#!/usr/bin/env python3
"""Evaluates two UM-Bridge servers of the same model at the same random inputs and prints the
largest absolute and relative difference (python3 standard library).

  compare_servers.py URL_A URL_B MODEL --points 1000 [--box -3,3,-3,3] [--config '{"a": 1.5}']

Used to check tests/app/blackbox/umbridge_models.py against the official UM-Bridge benchmark
servers run beside it (README.md of this folder).
"""
import argparse
import json
import random
import urllib.request


def evaluate(url, model, x, config):
    body = json.dumps({"name": model, "input": [x], "config": config}).encode()
    req = urllib.request.Request(url + "/Evaluate", body, {"Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=30) as r:
        return json.loads(r.read())["output"][0][0]


ap = argparse.ArgumentParser()
ap.add_argument("a")
ap.add_argument("b")
ap.add_argument("model")
ap.add_argument("--points", type=int, default=1000)
ap.add_argument("--box", default="-3,3,-3,3")
ap.add_argument("--config", default="{}")
ap.add_argument("--seed", type=int, default=1)
o = ap.parse_args()
box = [float(v) for v in o.box.split(",")]
config = json.loads(o.config)
rng = random.Random(o.seed)
worst_abs = worst_rel = 0.0
for _ in range(o.points):
    x = [rng.uniform(box[0], box[1]), rng.uniform(box[2], box[3])]
    va, vb = evaluate(o.a, o.model, x, config), evaluate(o.b, o.model, x, config)
    worst_abs = max(worst_abs, abs(va - vb))
    worst_rel = max(worst_rel, abs(va - vb) / max(abs(va), 1e-300))
print("%d points: max |difference| %.3g, max relative %.3g" % (o.points, worst_abs, worst_rel))
