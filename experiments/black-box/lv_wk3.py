#!/usr/bin/env python3
"""A time-varying-elastance left ventricle ejecting into a three-element Windkessel: a stand-in
for "anyone's simulator", driven by sigmaheart as `model: external` (README.md).

    P_lv = E(t) (V - V0),  E(t) = E_min + (E_max - E_min) e(t),
    e(t) = sin^2(pi tau / T_s) for tau = t mod T < T_s, else 0
        (Suga-Sagawa time-varying elastance, Suga et al. 1973, Circ Res 32:314)
    q_in  = max(P_la - P_lv, 0) / R_mv         (mitral valve, ideal diode)
    q_out = max(P_lv - P_c, 0) / Z_c           (aortic valve, diode, in series with Z_c)
    dV/dt = q_in - q_out,  C dP_c/dt = q_out - P_c / R_p
    P_ar  = P_c + Z_c q_out                    (three-element Windkessel,
        Westerhof et al. 2009, Med Biol Eng Comput 47:131)

Classical RK4 with a 1 ms step, beats repeated until V and P_c at the start of a beat change by
less than 1e-6 (relative), at most 40 beats. Writes the last beat, 81 frames, as CSV with
`name [unit]` headers in clinical units (mL, mmHg), which sigmaheart converts to SI.

Usage: lv_wk3.py --params PARAMS.json --out CURVES.csv   (PARAMS: sigmaheart's parameter file,
{"parameters": {name: value in SI}}; parameters not in the file keep the defaults below).
Standard library only.
"""
import json
import math
import sys

MMHG = 133.322   # Pa
ML = 1e-6        # m^3

DEFAULTS = {     # SI
    "E_max": 2.0 * MMHG / ML,     # Pa/m^3, end-systolic elastance
    "E_min": 0.1 * MMHG / ML,     # Pa/m^3, diastolic elastance
    "V0": 15 * ML,                # m^3, unloaded volume
    "R_p": 1.3 * MMHG / ML,       # Pa s/m^3, peripheral resistance
    "C": 1.2 * ML / MMHG,         # m^3/Pa, arterial compliance
    "Z_c": 0.05 * MMHG / ML,      # Pa s/m^3, characteristic impedance
    "R_mv": 0.01 * MMHG / ML,     # Pa s/m^3, mitral resistance
    "P_la": 10 * MMHG,            # Pa, left atrial pressure
    "period": 0.8,                # s
    "T_s": 0.3,                   # s, duration of the active elastance
}


def simulate(p, dt=1e-3, frames=81, max_beats=40, tol=1e-6):
    T, Ts = p["period"], p["T_s"]
    steps = int(round(T / dt))
    dt = T / steps
    every = steps // (frames - 1) if steps % (frames - 1) == 0 else None

    def elastance(t):
        tau = math.fmod(t, T)
        e = math.sin(math.pi * tau / Ts) ** 2 if tau < Ts else 0.0
        return p["E_min"] + (p["E_max"] - p["E_min"]) * e

    def flows(t, V, Pc):
        Plv = elastance(t) * (V - p["V0"])
        q_in = max(p["P_la"] - Plv, 0.0) / p["R_mv"]
        q_out = max(Plv - Pc, 0.0) / p["Z_c"]
        return Plv, q_in, q_out

    def rhs(t, V, Pc):
        _, q_in, q_out = flows(t, V, Pc)
        return q_in - q_out, (q_out - Pc / p["R_p"]) / p["C"]

    V, Pc = 120 * ML, 90 * MMHG
    for beat in range(max_beats):
        V_start, Pc_start = V, Pc
        rows = []
        for k in range(steps + 1):
            t = k * dt
            if every and k % every == 0:
                Plv, _, q_out = flows(t, V, Pc)
                rows.append((t, V, Plv, Pc + p["Z_c"] * q_out))
            if k == steps:
                break
            a1, b1 = rhs(t, V, Pc)
            a2, b2 = rhs(t + dt / 2, V + dt / 2 * a1, Pc + dt / 2 * b1)
            a3, b3 = rhs(t + dt / 2, V + dt / 2 * a2, Pc + dt / 2 * b2)
            a4, b4 = rhs(t + dt, V + dt * a3, Pc + dt * b3)
            V += dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
            Pc += dt / 6 * (b1 + 2 * b2 + 2 * b3 + b4)
            if not (math.isfinite(V) and math.isfinite(Pc)):
                raise FloatingPointError("state not finite at t = %g s of beat %d" % (t, beat + 1))
        change = max(abs(V - V_start) / abs(V_start), abs(Pc - Pc_start) / abs(Pc_start))
        if change < tol:
            return rows, beat + 1
    raise RuntimeError("no periodic beat after %d beats (last change %.3g)" % (max_beats, change))


def main(argv):
    args = dict(zip(argv[1::2], argv[2::2]))
    if "--params" not in args or "--out" not in args:
        sys.stderr.write(__doc__)
        return 2
    p = dict(DEFAULTS)
    with open(args["--params"]) as f:
        p.update(json.load(f)["parameters"])
    rows, beats = simulate(p)
    with open(args["--out"], "w") as f:
        f.write("# lv_wk3.py: periodic after %d beats\n" % beats)
        f.write("time [s], V_lv [mL], P_lv [mmHg], P_ar [mmHg]\n")
        for t, V, Plv, Par in rows:
            f.write("%r, %r, %r, %r\n" % (t, V / ML, Plv / MMHG, Par / MMHG))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
