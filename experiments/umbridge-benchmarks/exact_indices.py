#!/usr/bin/env python3
"""Exact Sobol' indices of the UM-Bridge banana's log density on a box (x1, x2 uniform), and its
posterior moments: the known answers of README.md.

  /usr/bin/python3 exact_indices.py [--a 1.5 --b 0.5 --scale 2 --box -2.5,2.5,-1.5,1.5]

log pi is a polynomial of degree 4 in x, so an 8-point Gauss-Legendre rule per axis integrates the
variance decomposition exactly (degree <= 8). The posterior moments follow from x = T^-1(z),
z ~ N((0, 4), scale [[1, .5], [.5, 1]]): x1 = a z1, x2 = z2 / a - b (a^2 z1^2 + a^2).
"""
import argparse
import math

import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("--a", type=float, default=1.5)
ap.add_argument("--b", type=float, default=0.5)
ap.add_argument("--scale", type=float, default=2.0)
ap.add_argument("--box", default="-2.5,2.5,-1.5,1.5")
o = ap.parse_args()
l1, u1, l2, u2 = (float(v) for v in o.box.split(","))
a, b, s = o.a, o.b, o.scale


def logpi(x1, x2):
    y1, y2 = x1 / a, a * x2 + a * b * (x1 ** 2 + a ** 2) - 4.0
    det = 0.75 * s * s
    return -math.log(2 * math.pi) - 0.5 * math.log(det) - 0.5 * s * (y1 * y1 - y1 * y2 + y2 * y2) / det


g, w = np.polynomial.legendre.leggauss(8)
x1 = l1 + (u1 - l1) * (g + 1) / 2
x2 = l2 + (u2 - l2) * (g + 1) / 2
w = w / 2
f = np.array([[logpi(p, q) for q in x2] for p in x1])
mean = w @ f @ w
var = w @ (f - mean) ** 2 @ w
v1 = w @ (f @ w - mean) ** 2
v2 = w @ (w @ f - mean) ** 2
print("a=%g b=%g scale=%g box=%s: variance %.6f" % (a, b, s, o.box, var))
print("  S1 = (%.4f, %.4f), ST = (%.4f, %.4f)" % (v1 / var, v2 / var, 1 - v2 / var, 1 - v1 / var))
m2 = 4.0 / a - b * (a * a * s + a * a)
v2x = s / a ** 2 + b * b * a ** 4 * 2 * s * s
print("  posterior: mean (0, %.4f), variances (%.4f, %.4f), covariance %.4f" % (m2, a * a * s, v2x, 0.5 * s))
