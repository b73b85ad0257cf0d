#!/usr/bin/env python3
"""UM-Bridge protocol 1.0 server of the UM-Bridge analytic benchmarks and test model, written for
sigmaheart's tests (python3 standard library only; no code of the UM-Bridge project).

The densities are those the UM-Bridge benchmark documentation defines (Seelinger et al. 2023,
JOSS 8:4748; um-bridge-benchmarks.readthedocs.io, "Analytic Banana", "Analytic Donut", "Analytic
Funnel", "Analytic Gaussian Mixture"); each is served as model "posterior": input [2] (x), output
[1] (log pi(x)), config as documented. The test model is "forward": input [1], output [1] = 2 x.
"split" (model "forward") has two input and two output vectors: [[x], [y]] -> [[x + y], [x y, x - y]].

  banana   Z ~ N((0, 4), scale [[1, 0.5], [0.5, 1]]), T(x) = (x1/a, a x2 + a b (x1^2 + a^2)),
           log pi(x) = log f_Z(T(x)); config a = 2, b = 0.2, scale = 1
  donut    log pi(x) = -(|x| - 2.6)^2 / 0.033
  funnel   log pi(x) = log N(x1; 0, 3^2) + log N(x2; 0, exp(x1))      (Neal 2003)
  gaussian-mixture  log of N(x; (-1.5, -1.5), 0.8 I) + N(x; (1.5, 1.5), 0.8 I) + N(x; (-2, 2), 0.5 I)

The unit model ("units", model "forward") is sigmaheart's test beat with a period, in clinical
units on purpose: input [4] = V_ed [mL], EF [1], P_peak [kPa], period [ms]; outputs [63, 21] =
V_lv [mL], P_lv [mmHg], P_kpa [kPa] at 21 frames, then the frames' times [ms]. With
`--params PARAMS.json --out CURVES.csv` it is the same model as an external program (a CSV with
`time [ms], V_lv [mL], P_lv [mmHg], P_kpa [kPa]`).

Usage: umbridge_models.py --model banana [--port 0] [--protocol-version 1.0] [--delay-ms 0]
Prints "listening on http://127.0.0.1:PORT" once it accepts connections.
"""
import json
import math
import sys
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer


def normal2_logpdf(y, mean, cov):
    d0, d1 = y[0] - mean[0], y[1] - mean[1]
    det = cov[0][0] * cov[1][1] - cov[0][1] * cov[1][0]
    q = (cov[1][1] * d0 * d0 - 2.0 * cov[0][1] * d0 * d1 + cov[0][0] * d1 * d1) / det
    return -math.log(2.0 * math.pi) - 0.5 * math.log(det) - 0.5 * q


def banana(x, config):
    a, b, s = config.get("a", 2.0), config.get("b", 0.2), config.get("scale", 1.0)
    y = (x[0] / a, a * x[1] + a * b * (x[0] ** 2 + a ** 2))
    return normal2_logpdf(y, (0.0, 4.0), ((s, 0.5 * s), (0.5 * s, s)))


def donut(x, config):
    return -(math.hypot(x[0], x[1]) - 2.6) ** 2 / 0.033


def funnel(x, config):
    def f(v, m, s):
        return -0.5 * math.log(2.0 * math.pi) - math.log(s) - 0.5 * ((v - m) / s) ** 2
    return f(x[0], 0.0, 3.0) + f(x[1], 0.0, math.exp(x[0] / 2.0))


def gaussian_mixture(x, config):
    total = 0.0
    for mean, var in (((-1.5, -1.5), 0.8), ((1.5, 1.5), 0.8), ((-2.0, 2.0), 0.5)):
        total += math.exp(normal2_logpdf(x, mean, ((var, 0.0), (0.0, var))))
    return math.log(total) if total > 0.0 else sys.float_info.min


MMHG = 133.322  # Pa


def unit_beat(v_ed_ml, ef, p_peak_kpa, period_ms, frames=21):
    """(times [ms], V_lv [mL], P_lv [mmHg], P [kPa]): the test beat computed in SI."""
    v_ed, p_peak, period = v_ed_ml * 1e-6, p_peak_kpa * 1e3, period_ms * 1e-3
    t, v, p = [], [], []
    for k in range(frames):
        tk = period if k == frames - 1 else period * k / (frames - 1)
        phi = 2.0 * math.pi * tk / period
        s = 0.5 * (1.0 - math.cos(phi))
        t.append(tk)
        v.append(v_ed * (1.0 - ef * s))
        p.append(1000.0 + (p_peak - 1000.0) * math.sin(phi / 2.0) ** 4)
    return ([x * 1e3 for x in t], [x * 1e6 for x in v], [x / MMHG for x in p], [x / 1e3 for x in p])


DENSITIES = {"banana": banana, "donut": donut, "funnel": funnel, "gaussian-mixture": gaussian_mixture}


def main(argv):
    args = dict(zip(argv[1::2], argv[2::2]))
    kind = args.get("--model", "banana")
    port = int(args.get("--port", "0"))
    version = float(args.get("--protocol-version", "1.0"))
    delay = float(args.get("--delay-ms", "0")) / 1000.0
    if "--params" in args:  # the unit model as an external program
        with open(args["--params"]) as f:
            params = json.load(f)
        units = dict(zip(params["names"], params["units"]))
        assert units == {"V_ed": "mL", "EF": "1", "P_peak": "kPa", "period": "ms"}, units
        q = params["parameters"]
        t, v, p, pk = unit_beat(q["V_ed"], q["EF"], q["P_peak"], q["period"])
        with open(args["--out"], "w") as f:
            f.write("time [ms], V_lv [mL], P_lv [mmHg], P_kpa [kPa]\n")
            for row in zip(t, v, p, pk):
                f.write(", ".join(repr(x) for x in row) + "\n")
        return
    if kind == "units":
        name, sizes = "forward", ([4], [63, 21])

        def evaluate(inputs, config):
            t, v, p, pk = unit_beat(*inputs[0])
            return [v + p + pk, t]
    elif kind == "split":  # several input and output vectors: [[x], [y]] -> [[x + y], [x y, x - y]]
        name, sizes = "forward", ([1, 1], [1, 2])
        evaluate = lambda inputs, config: [[inputs[0][0] + inputs[1][0]],
                                           [inputs[0][0] * inputs[1][0], inputs[0][0] - inputs[1][0]]]
    elif kind == "testmodel":
        name, sizes = "forward", ([1], [1])
        evaluate = lambda inputs, config: [[2.0 * inputs[0][0]]]
    elif kind in DENSITIES:
        name, sizes = "posterior", ([2], [1])
        density = DENSITIES[kind]
        evaluate = lambda inputs, config: [[density(inputs[0], config)]]
    else:
        sys.exit("unknown --model " + kind)

    class Handler(BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.1"  # keep-alive, as UM-Bridge clients use it
        disable_nagle_algorithm = True  # headers and body leave at once (no 40 ms delayed-ACK wait)

        def log_message(self, *a):
            pass

        def reply(self, status, body):
            data = json.dumps(body).encode()
            self.send_response(status)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

        def error(self, status, kind_, message):
            self.reply(status, {"error": {"type": kind_, "message": message}})

        def do_GET(self):
            if self.path == "/Info":
                self.reply(200, {"protocolVersion": version, "models": [name]})
            else:
                self.error(404, "NotFound", self.path)

        def do_POST(self):
            body = json.loads(self.rfile.read(int(self.headers.get("Content-Length", "0"))) or b"{}")
            if body.get("name") != name:
                return self.error(400, "ModelNotFound", "no model %r" % body.get("name"))
            config = body.get("config", {}) or {}
            if self.path == "/InputSizes":
                return self.reply(200, {"inputSizes": sizes[0]})
            if self.path == "/OutputSizes":
                return self.reply(200, {"outputSizes": sizes[1]})
            if self.path == "/ModelInfo":
                return self.reply(200, {"support": {"Evaluate": True, "Gradient": False,
                                                    "ApplyJacobian": False, "ApplyHessian": False}})
            if self.path != "/Evaluate":
                return self.error(400, "UnsupportedFeature", self.path[1:] + " is not supported")
            inputs = body.get("input")
            if (not isinstance(inputs, list) or len(inputs) != len(sizes[0]) or
                    any(len(v) != n for v, n in zip(inputs, sizes[0]))):
                return self.error(400, "InvalidInput", "expected input vectors of sizes %s" % sizes[0])
            if delay:
                time.sleep(delay)
            self.reply(200, {"output": evaluate(inputs, config)})

    server = ThreadingHTTPServer(("127.0.0.1", port), Handler)
    server.daemon_threads = True
    print("listening on http://127.0.0.1:%d" % server.server_address[1], flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main(sys.argv)
