"""The polar decomposition F = R U of many small matrices at once (the corotational model's
rotations, SPEC 8): Newton's scaled iteration where every det F > 0, the SVD otherwise."""

from __future__ import annotations

import numpy as np

POLAR_STOP = 1e-8  # Newton's polar iteration stops when no entry changes by more than this
POLAR_MAX_ITERATIONS = 50


def _cofactor(X: np.ndarray, C: np.ndarray, det: np.ndarray, work: np.ndarray) -> None:
    """C = cof(X) = det(X) X^-T and det = det(X) for the matrices X[:, :, k] (d = 2 or 3),
    stored entry by entry (shape (d, d, n)) so that every operation runs over all n."""
    d = X.shape[0]
    if d == 2:
        C[0, 0], C[1, 1] = X[1, 1], X[0, 0]
        np.negative(X[1, 0], out=C[0, 1])
        np.negative(X[0, 1], out=C[1, 0])
    else:
        for i in range(3):
            i1, i2 = (i + 1) % 3, (i + 2) % 3
            for j in range(3):
                j1, j2 = (j + 1) % 3, (j + 2) % 3
                np.multiply(X[i1, j1], X[i2, j2], out=C[i, j])
                np.multiply(X[i1, j2], X[i2, j1], out=work)
                C[i, j] -= work
    np.multiply(X[0, 0], C[0, 0], out=det)
    for j in range(1, d):
        np.multiply(X[0, j], C[0, j], out=work)
        det += work


def _polar_newton(F: np.ndarray) -> np.ndarray | None:
    """The rotations R of F = R U (shape (n, d, d)) by the scaled Newton iteration
    X <- (g X + X^-T / g) / 2, g = det(X)^(-1/d), from X = F (quadratic convergence; every
    iterate is R times a symmetric positive definite matrix), or None if some det F <= 0 (or
    is not finite) or the iteration has not converged."""
    n, d = F.shape[:2]
    if n == 0:
        return F.copy()
    X = np.ascontiguousarray(F.transpose(1, 2, 0))
    C, Y = np.empty_like(X), np.empty_like(X)
    det, scale, work = (np.empty(X.shape[2]) for _ in range(3))
    _cofactor(X, C, det, work)
    if not (det > 0).all():
        return None
    for _ in range(POLAR_MAX_ITERATIONS):
        np.power(det, -1.0 / d, out=scale)
        np.multiply(scale, det, out=work)
        np.divide(0.5, work, out=work)  # 1 / (2 g det X)
        scale *= 0.5
        np.multiply(X, scale, out=Y)
        C *= work
        Y += C  # (g X + X^-T / g) / 2
        X -= Y
        np.abs(X, out=X)
        change = X.max()
        X, Y = Y, X
        if change <= POLAR_STOP:  # the next change, about change^2 / 2, is round-off
            return np.ascontiguousarray(X.transpose(2, 0, 1))
        if not np.isfinite(change):
            return None
        _cofactor(X, C, det, work)
    return None


def rotations(F: np.ndarray) -> np.ndarray:
    """R of the polar decomposition F = R U of each matrix of F (shape (n, d, d)): the
    rotation (det R = +1) closest to F, R = U V^T from the SVD F = U S V^T with the sign of
    U's last column chosen so that det R = +1. Where every det F > 0 this is the polar factor,
    computed by Newton's iteration (about 10x faster than a LAPACK SVD per matrix; the same R
    up to round-off); otherwise by the SVD."""
    R = _polar_newton(F)
    if R is not None:
        return R
    U, _, Vt = np.linalg.svd(F)
    sign = np.sign(np.linalg.det(U @ Vt))
    sign[sign == 0] = 1.0
    U[:, :, -1] *= sign[:, None]
    return U @ Vt
