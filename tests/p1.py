"""Linear P1 elasticity on tetrahedra in numpy and SciPy, assembled from SPEC section 1's stress:
the independent solver the outside simulators' tests compare Drake, MuJoCo, Kratos and Newton
against (nothing of tissuebench or of the simulator is used)."""

import numpy as np
import scipy.sparse as sp


def p1_matrices(nodes, tets, mu, lam, rho, gravity):
    """P1 stiffness K (Lame mu, lam in Pa), consistent mass, the one-point (centroid) mass
    rho V/16 for every corner pair, row-sum lumped mass (kg), and gravity's nodal force (N)."""
    n = 3 * len(nodes)
    rows, cols, k_vals, mc_vals, m1_vals = [], [], [], [], []
    f = np.zeros(n)
    D = np.zeros((6, 6))
    D[:3, :3] = lam
    D[np.arange(3), np.arange(3)] += 2 * mu
    D[3:, 3:] = mu * np.eye(3)
    eye = np.eye(3)
    for t in tets:
        A = np.c_[np.ones(4), nodes[t]]
        volume = abs(np.linalg.det(A)) / 6
        grad = np.linalg.inv(A)[1:]
        B = np.zeros((6, 12))
        for a in range(4):
            gx, gy, gz = grad[:, a]
            B[:, 3 * a : 3 * a + 3] = [
                [gx, 0, 0],
                [0, gy, 0],
                [0, 0, gz],
                [0, gz, gy],
                [gz, 0, gx],
                [gy, gx, 0],
            ]
        dofs = (3 * t[:, None] + np.arange(3)).ravel()
        rows.append(np.repeat(dofs, 12))
        cols.append(np.tile(dofs, 12))
        k_vals.append((volume * B.T @ D @ B).ravel())
        mc_vals.append(np.kron(rho * volume / 20 * (np.ones((4, 4)) + np.eye(4)), eye).ravel())
        m1_vals.append(np.kron(rho * volume / 16 * np.ones((4, 4)), eye).ravel())
        f[dofs] += np.tile(rho * volume / 4 * gravity, 4)
    rows, cols = np.concatenate(rows), np.concatenate(cols)

    def assemble(values):
        return sp.csr_matrix((np.concatenate(values), (rows, cols)), shape=(n, n))

    M = assemble(mc_vals)
    lumped = sp.diags(np.asarray(M.sum(axis=1)).ravel()).tocsr()
    return assemble(k_vals), {"consistent": M, "one-point": assemble(m1_vals), "lumped": lumped}, f
