"""The symmetric pressure gradient of the exact hydrostatic pressure on the rows of a lattice
cut by a flat face (docs/hard-cases.md, "Still water: the surface row's missing push").

Row k stands (k + 1/2) dx below the face, where p = 0 (the Robin rows' level); p = rho g
times the depth. Prints -(sum_j V (p_i + p_j) grad_i W_ij . n) / (rho g) per row: 1 would
balance gravity. Wendland C2 at h = 1.3 dx, 2D and 3D. Run: python3 docs/study/surface_row_factor.py
"""
import itertools

import numpy as np


def wendland_c2_dwdr(dim, h):
    a = 7 / (4 * np.pi * h * h) if dim == 2 else 21 / (16 * np.pi * h**3)

    def dw(r):
        q = r / h
        return np.where(q < 2, a * (-5 * q) * (1 - q / 2) ** 3, 0.0) / h

    return dw


for dim in (2, 3):
    dx, h = 1.0, 1.3
    volume = dx**dim
    dw = wendland_c2_dwdr(dim, h)
    points = np.array(list(itertools.product(range(-4, 5), repeat=dim)), float)
    for k in range(4):
        level = k + 0.5
        x = points[points[:, 0] < level]
        r = np.linalg.norm(x, axis=1)
        x, r = x[r > 0], r[r > 0]
        p_i, p_j = level, level - x[:, 0]
        # grad_i W_ij = W'(r) (x_i - x_j)/r = -W'(r) x/r, x = x_j - x_i.
        g = (volume * (p_i + p_j) * (-dw(r)) * x[:, 0] / r).sum()
        print(f"{dim}D row {k}: {-g:.4f}")
