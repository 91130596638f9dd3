#!/usr/bin/env python3
"""Spectral radius of the SPH projection's step map on disordered particles (docs/hard-cases.md).

A projection step maps the intermediate velocity to u' = P u*, P = I - G L^-1 D (pressure
scaled by dt/rho, so P does not depend on dt). An exact projection has eigenvalues 0 and 1;
an SPH projection (L is not D G) may have eigenvalues outside the unit circle, and then a
perturbation grows by that factor every step, whatever dt. This builds G, D and L as dense
matrices for a small 2D particle set (Wendland C2, h = 1.3 dx, V = dx^2) and prints max |eig P|:

  * a periodic box (no boundaries), and a slab periodic in x with free surfaces at top and
    bottom (Dirichlet p = 0 on particles with div r < 1.5, eliminated);
  * lattice, 10 % and 20 % jitter (uniform, seeded), and the 20 % jitter after packing
    iterations dr = -beta h^2 grad C (the free surface band: tangential part only), as
    `[start] relax_iterations` does;
  * pairs: difference (D, G both sum V_j (f_j - f_i) grad W_ij), renormalised difference
    (kernel-gradient corrected), symmetric gradient with the difference divergence (its
    negative adjoint), the renormalised gradient with the negative adjoint of it as divergence,
    and Laplacians: Morris, and Morris with the renormalised kernel gradient.

numpy only; about a minute.  python3 docs/study/projection_spectrum.py
"""
import numpy as np

def wc2(q):
    return np.where(q < 2, (1 - q / 2) ** 4 * (2 * q + 1), 0.0)

def dwc2(q):
    return np.where(q < 2, -5 * q * (1 - q / 2) ** 3, 0.0)

def build(x, dx, periodic_y, L=1.0, hdx=1.3):
    h = hdx * dx
    N = len(x)
    d = x[:, None, :] - x[None, :, :]              # x_i - x_j
    d[..., 0] -= L * np.round(d[..., 0] / L)
    if periodic_y:
        d[..., 1] -= L * np.round(d[..., 1] / L)
    r = np.sqrt((d ** 2).sum(-1))
    q = r / h
    sig = 7 / (4 * np.pi) / h ** 2
    dW = np.zeros_like(d)
    nz = r > 0
    dW[nz] = (sig * dwc2(q[nz]) / h / r[nz])[:, None] * d[nz]   # grad_i W_ij
    V = np.full(N, dx * dx)
    divr = -(V[None, :] * (d * dW).sum(-1)).sum(1)
    surf = np.zeros(N, bool) if periodic_y else divr < 1.5
    return dict(N=N, d=d, r=r, dW=dW, V=V, h=h, surf=surf)

def corrected(s):
    M = np.einsum('j,ija,ijb->iab', s['V'], -s['d'], s['dW'])
    return np.einsum('iba,ijb->ija', np.linalg.inv(M), s['dW'])

def difference_pair(s, grad_kernel):
    N = s['N']
    A = s['V'][None, :, None] * grad_kernel
    G = np.zeros((N, 2, N))
    for a in range(2):
        G[:, a, :] = A[:, :, a]
        G[np.arange(N), a, np.arange(N)] -= A[:, :, a].sum(1)
    G = G.reshape(2 * N, N)
    D = np.zeros((N, N, 2))
    for a in range(2):
        D[:, :, a] = A[:, :, a]
        D[np.arange(N), np.arange(N), a] -= A[:, :, a].sum(1)
    return G, D.reshape(N, 2 * N)

def symmetric_gradient(s):
    N = s['N']
    A = s['V'][None, :, None] * s['dW']
    G = np.zeros((N, 2, N))
    for a in range(2):
        G[:, a, :] = A[:, :, a]
        G[np.arange(N), a, np.arange(N)] += A[:, :, a].sum(1)
    return G.reshape(2 * N, N)

def morris(s, grad_kernel):
    N = s['N']
    F = 2 * s['V'][None, :] * (s['d'] * grad_kernel).sum(-1) / (s['r'] ** 2 + (0.01 * s['h']) ** 2)
    np.fill_diagonal(F, 0.0)
    L = -F.copy()
    L[np.arange(N), np.arange(N)] = F.sum(1)
    return L        # L p_i = sum_j F_ij (p_i - p_j)

def radius(G, D, L, surf):
    N = len(surf)
    I = ~surf
    GI, DI, LII = G[:, I], D[I, :], L[np.ix_(I, I)]
    Linv = np.linalg.pinv(LII) if not surf.any() else np.linalg.inv(LII)
    P = np.eye(2 * N) - GI @ Linv @ DI
    return np.abs(np.linalg.eigvals(P)).max()

def particles(n, jitter, periodic_y, seed=1, ny=12):
    dx = 1.0 / n
    gy = (np.arange(n if periodic_y else ny) + 0.5) * dx
    gx = (np.arange(n) + 0.5) * dx
    X, Y = np.meshgrid(gx, gy, indexing='ij')
    x = np.c_[X.ravel(), Y.ravel()]
    x += np.random.default_rng(seed).uniform(-jitter, jitter, x.shape) * dx
    return x, dx

def relax(x, dx, periodic_y, iterations, beta=0.1):
    for _ in range(iterations):
        s = build(x, dx, periodic_y)
        gc = (s['V'][None, :, None] * s['dW']).sum(1)    # grad C (no anti-clumping term)
        dr = -beta * s['h'] ** 2 * gc
        band = s['surf'] | ((s['r'] < 2 * s['h']) & s['surf'][None, :]).any(1)
        n = gc / np.maximum(np.linalg.norm(gc, axis=1, keepdims=True), 1e-300)
        dr[band] -= (dr[band] * n[band]).sum(1, keepdims=True) * n[band]
        dr *= np.minimum(1.0, 0.2 * dx / np.maximum(np.linalg.norm(dr, axis=1, keepdims=True), 1e-300))
        x = x + dr
        x[:, 0] %= 1.0
        if periodic_y:
            x[:, 1] %= 1.0
    return x

def row(label, x, dx, periodic_y):
    s = build(x, dx, periodic_y)
    ck = corrected(s)
    G0, D0 = difference_pair(s, s['dW'])
    Gc, Dc = difference_pair(s, ck)
    Lm, Lc = morris(s, s['dW']), morris(s, ck)
    Gs = symmetric_gradient(s)
    vals = [radius(G0, D0, Lm, s['surf']), radius(Gc, Dc, Lm, s['surf']),
            radius(Gc, Dc, Lc, s['surf']), radius(Gs, D0, Lm, s['surf']),
            radius(Gc, -Gc.T, Lm, s['surf'])]
    print('| %s | %s |' % (label, ' | '.join('%.4f' % v for v in vals)))

if __name__ == '__main__':
    print('| particles | difference, Morris | renormalised, Morris | renormalised, corrected Morris '
          '| symmetric G / difference D | renormalised G / its adjoint D |')
    print('|---|---|---|---|---|---|')
    for periodic_y, name in [(True, 'periodic 20x20'), (False, 'slab 20x12, free surfaces')]:
        for jit in [0.0, 0.1, 0.2]:
            x, dx = particles(20, jit, periodic_y)
            row('%s, jitter %d %%' % (name, round(100 * jit)), x, dx, periodic_y)
        x, dx = particles(20, 0.2, periodic_y)
        for it in [5, 20]:
            row('%s, jitter 20 %%, %d packing iterations' % (name, it), relax(x, dx, periodic_y, it), dx, periodic_y)
