#!/usr/bin/env python3
"""Static passive inflation of an incompressible thick-walled sphere against the lumped sphere.

docs/models.md s.4.8, "Consistency with the lumped sphere". Both use the passive law of the lumped
sphere (docs/models.md s.2.1) as a function of the equibiaxial stretch l (radial stretch l^-2):
  W(l) = c1 (J1 - 3) + c2 (J2 - 3) + c_exp (exp(b_exp (J1 - 3)^2) - 1),  J1 = 2 l^2 + l^-4,
  J2 = l^4 + 2 l^-2.
Lumped (thin shell, Laplace law):  P = (d0/R0) W'(l) / l^2.
Thick sphere: the radial balance d sigma_r/dr = 2 (sigma_t - sigma_r)/r with
sigma_t - sigma_r = l W'(l)/2 gives P = int_{r_i}^{r_o} l W'(l) / r dr, where incompressibility maps
a reference radius rho to r = (rho^3 + r_i^3 - R_i^3)^(1/3) (the classical inflation of an incompressible spherical shell; Ogden 1984, Non-linear Elastic
Deformations, ch. 5). The thick sphere has inner radius R0 and the wall volume 4 pi R0^2 d0.
The stress-like constants are scaled by kappa = (14.5/24) / (d0/R0), as in the study.

Usage: python3 experiments/thin-shell/thick_sphere.py    (no dependencies)
"""
import math

P_MMHG = 133.322
R0 = 24.939e-3  # [m] the study's equivalent radius (tests/model/fem/thin_shell_comparison.h)
C1, C2, CEXP, BEXP = 100.0, 150.0, 30.0, 1.0  # [Pa] the lumped sphere's healthy values


def bisect(f, a, b):
    fa = f(a)
    for _ in range(200):
        m = 0.5 * (a + b)
        fm = f(m)
        if (fm > 0) == (fa > 0):
            a, fa = m, fm
        else:
            b = m
    return 0.5 * (a + b)


def simpson(f, a, b, n=200):
    h = (b - a) / n
    s = f(a) + f(b)
    for i in range(1, n):
        s += (4 if i % 2 else 2) * f(a + i * h)
    return s * h / 3


def volumes(d0, pressure):
    kappa = (14.5 / 24) / (d0 / R0)
    c1, c2, ce = C1 * kappa, C2 * kappa, CEXP * kappa

    def dW(l):  # dW/dl
        J1 = 2 * l * l + l ** -4
        dJ1, dJ2 = 4 * l - 4 * l ** -5, 4 * l ** 3 - 4 * l ** -3
        return c1 * dJ1 + c2 * dJ2 + ce * math.exp(BEXP * (J1 - 3) ** 2) * 2 * BEXP * (J1 - 3) * dJ1

    l_lumped = bisect(lambda l: (d0 / R0) * dW(l) / l ** 2 - pressure, 1.0, 2.5)
    Ro = (R0 ** 3 + 3 * R0 ** 2 * d0) ** (1 / 3)

    def p_thick(li):
        k = (li * R0) ** 3 - R0 ** 3
        ro = (Ro ** 3 + k) ** (1 / 3)
        stretch = lambda r: r / (r ** 3 - k) ** (1 / 3)
        return simpson(lambda r: stretch(r) * dW(stretch(r)) / r, li * R0, ro)

    l_thick = bisect(lambda l: p_thick(l) - pressure, 1.0, 2.5)
    v = lambda l: 4 / 3 * math.pi * (R0 * l) ** 3 * 1e6
    return v(l_lumped), v(l_thick)


if __name__ == "__main__":
    P = 7.126 * P_MMHG  # P_at0 of the healthy set
    print("d/R   d0 [mm]  V lumped [mL]  V thick sphere [mL]")
    # d0 of the study's meshes (0.4, 0.2, 0.1); thinner walls: d0 halved.
    for ratio, d0 in [(0.4, 12.7275e-3), (0.2, 5.5349e-3), (0.1, 2.5728e-3), (0.05, 1.2864e-3),
                      (0.025, 0.6432e-3)]:
        vl, vt = volumes(d0, P)
        print(f"{ratio:<5} {d0 * 1e3:7.3f}  {vl:13.1f}  {vt:19.1f}")
