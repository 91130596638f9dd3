#!/usr/bin/env python3
"""Why the Taylor-Green vortex without shifting blows up: the exact flow map (docs/hard-cases.md).

Moves the quick preset's initial lattice (25 x 25 on the periodic unit square) with the exact
Taylor-Green velocity u = (-cos 2πx sin 2πy, sin 2πx cos 2πy) exp(-8π²νt), ν = 0.01 (RK4,
step 1e-3): the positions a Lagrangian method without particle regularisation would reach if
it moved every particle exactly with the flow. At each time it prints the nearest pair's
distance over dx, the largest anisotropy of a particle's neighbourhood (eigenvalue ratio of
Σ_j x_ij ⊗ x_ij within the support), how many renormalisation matrices fall back to the
identity under the code's rules (det < 1e-3 or an inverse entry > 5), and the spectral radius
of the projection's step map P = I - G L^-1 D (docs/study/projection_spectrum.py) for three
pairs: the Taylor-Green scenes' renormalised difference pair with Morris' Laplacian, the plain
difference pair, and the symmetric gradient with the difference divergence (the flow default).

numpy only; about 20 s.  python3 docs/study/tg_flow_map.py
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import projection_spectrum as ps  # noqa: E402

NU = 0.01


def velocity(x, t):
    a = np.exp(-8 * np.pi ** 2 * NU * t)
    s, c = np.sin(2 * np.pi * x), np.cos(2 * np.pi * x)
    return np.c_[-c[:, 0] * s[:, 1], s[:, 0] * c[:, 1]] * a


def corrected_with_fallback(s):
    m = np.einsum('j,ija,ijb->iab', s['V'], -s['d'], s['dW'])
    inv = np.linalg.inv(m)
    bad = (np.abs(np.linalg.det(m)) < 1e-3) | (np.abs(inv).max((1, 2)) > 5)
    inv[bad] = np.eye(2)
    return np.einsum('iba,ijb->ija', inv, s['dW']), int(bad.sum())


def row(t, x, dx):
    s = ps.build(x, dx, True)
    r = s['r'] + np.eye(len(x)) * 9
    inside = (s['r'] < 2 * s['h']) * 1.0
    m2 = np.einsum('ij,ija,ijb->iab', inside, s['d'], s['d'])
    ev = np.linalg.eigvalsh(m2)
    ck, fallbacks = corrected_with_fallback(s)
    gc, dc = ps.difference_pair(s, ck)
    g0, d0 = ps.difference_pair(s, s['dW'])
    lm = ps.morris(s, s['dW'])
    gs = ps.symmetric_gradient(s)
    radii = [ps.radius(gc, dc, lm, s['surf']), ps.radius(g0, d0, lm, s['surf']),
             ps.radius(gs, d0, lm, s['surf'])]
    print('| %.2f | %.3f | %.1f | %d | %s |' % (
        t, r.min() / dx, (ev[:, 1] / ev[:, 0]).max(), fallbacks,
        ' | '.join('%.4f' % v for v in radii)))


if __name__ == '__main__':
    n = 25
    dx = 1.0 / n
    g = (np.arange(n) + 0.5) * dx
    gx, gy = np.meshgrid(g, g, indexing='ij')
    x = np.c_[gx.ravel(), gy.ravel()]
    print('| t | nearest pair / dx | anisotropy | fallbacks | renormalised difference, Morris '
          '| difference, Morris | symmetric G / difference D |')
    print('|---|---|---|---|---|---|---|')
    t, h = 0.0, 1e-3
    for end in [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]:
        while t < end - 1e-12:
            k1 = velocity(x, t)
            k2 = velocity(x + h / 2 * k1, t + h / 2)
            k3 = velocity(x + h / 2 * k2, t + h / 2)
            k4 = velocity(x + h * k3, t + h)
            x = (x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)) % 1.0
            t += h
        row(end, x, dx)
