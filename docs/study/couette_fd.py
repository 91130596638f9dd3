#!/usr/bin/env python3
"""What the Couette start-up's profile check asks of any discretisation (docs/hard-cases.md).

The scene `cases/hard/couette.toml`: plates 1 mm apart, nu = 1e-6, the top plate started
impulsively at U0 = 2.5e-5 m/s, 25 particles across, the step the automatic time step takes
(2 959 steps to t = 1). Here the same 25 cells (centres where the particles sit) are solved by
second-order central differences, the plates as antisymmetric ghosts (u_ghost = 2 u_plate - u),
explicit (forward Euler) and implicit (backward Euler) in time, with the same step, against
Morris, Fox & Zhu's (1997) series solution. It prints the largest error over the profile at
the first step, over the run, and from when it stays under the check's 2 % of U0.

numpy only; seconds.  python3 docs/study/couette_fd.py
"""
import numpy as np

H, NU, U0, N = 1e-3, 1e-6, 2.5e-5, 25
DX = H / N
Y = (np.arange(N) + 0.5) * DX
DT = 1.0 / 2959
STEPS = 2959


def exact(y, t, terms=2000):
    k = np.arange(1, terms + 1)[:, None]
    s = ((-1.0) ** k / k * np.sin(k * np.pi * y / H) * np.exp(-NU * k * k * np.pi ** 2 * t / H ** 2)).sum(0)
    return U0 * y / H + 2 * U0 / np.pi * s


def main():
    lap = -2 * np.eye(N) + np.eye(N, k=1) + np.eye(N, k=-1)
    lap[0, 0] = lap[-1, -1] = -3  # the ghosts: 2 u_plate - u
    src = np.zeros(N)
    src[-1] = 2 * U0
    c = NU / DX ** 2
    implicit = np.linalg.inv(np.eye(N) - DT * c * lap)
    print("| time stepping | error after the first step | largest | under 2 % of U0 from t |")
    print("|---|---|---|---|")
    for name in ("explicit", "implicit"):
        u = np.zeros(N)
        err = np.empty(STEPS)
        for k in range(STEPS):
            if name == "explicit":
                u = u + DT * c * (lap @ u + src)
            else:
                u = implicit @ (u + DT * c * src)
            err[k] = np.abs(u - exact(Y, (k + 1) * DT)).max() / U0
        over = np.nonzero(err >= 0.02)[0]
        since = (over.max() + 2) * DT if len(over) else DT
        print(f"| {name} | {err[0]:.3f} | {err.max():.3f} | {since * 1e3:.2f} ms |")


if __name__ == "__main__":
    main()
