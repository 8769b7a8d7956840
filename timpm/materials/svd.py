"""The singular value decomposition F = U diag(S) V^T of a 2x2 or 3x3 deformation gradient,
accurate to round-off, for the Hencky laws' principal log strains.

Taichi's own ``ti.svd`` is not fit for soil's small elastic strains: in 2D it drops a
symmetric shear below 1e-5 (``_svd2d``: ``if abs(S[0, 1]) < 1e-5``), so an elastic shear
strain under 1e-5 (a shear stress under about 770 Pa in Griffiths & Lane's soil) is erased
at every step, and in 3D its fixed iterations reconstruct F to a relative 1e-5 at strains of
1e-5.  A soil then creeps at a rate that grows with the number of steps (docs/results.md,
"A time step that changed the factor of safety").  Here:

- 2D in closed form: the rotation of the polar decomposition and the symmetric stretch's
  principal axes without a threshold or trigonometry (square roots and divisions), its
  principal values exactly;
- 3D by cyclic Jacobi rotations on C = F^T F (each angle from atan2, so a tiny off-diagonal
  entry is rotated away, not dropped), a fixed number of sweeps, U's columns F v_k made
  orthonormal (Gram-Schmidt, the third a cross product) and S_k = u_k . F v_k.
"""
import taichi as ti

__all__ = ["svd", "principal_log_stretch", "spectral"]

#: Jacobi sweeps in 3D: quadratic convergence takes an off-diagonal of 1 to below 1e-16 of
#: the diagonal within five sweeps for a 3x3 matrix; six for margin
SWEEPS = 6


@ti.func
def svd(F):
    """F = U diag(S) V^T (S a diagonal matrix, U and V orthogonal), F 2x2 or 3x3."""
    U, S, V = F, F, F
    if ti.static(F.n == 2):
        U, S, V = _svd2(F)
    else:
        U, S, V = _svd3(F)
    return U, S, V


@ti.func
def principal_log_stretch(F):
    """The principal logarithmic strains of F's left stretch (F F^T = U diag(e^(2 eps))
    U^T) and its principal frame, for :func:`spectral`: in 2D the frame is N = U diag(1,
    -1) U^T, in closed form without U (b = F F^T = m I + r N: one square root, one
    division); in 3D it is U, from :func:`svd`."""
    eps = ti.Vector.zero(float, F.n)
    frame = F
    if ti.static(F.n == 2):
        b = F @ F.transpose()
        mean, half, shear = 0.5 * (b[0, 0] + b[1, 1]), 0.5 * (b[0, 0] - b[1, 1]), b[0, 1]
        radius = ti.sqrt(half * half + shear * shear)
        frame = ti.Matrix([[1.0, 0.0], [0.0, -1.0]])  # b isotropic: any frame
        if radius > 0.0:
            frame = ti.Matrix([[half, shear], [shear, -half]]) / radius
        # the larger eigenvalue mean + radius, the smaller from the product det(F)^2 (no
        # cancellation)
        eps[0] = 0.5 * ti.log(mean + radius)
        eps[1] = ti.log(ti.max(ti.abs(F.determinant()), 1e-300)) - eps[0]
    else:
        U, S, V = _svd3(F)
        for k in ti.static(range(3)):
            eps[k] = ti.log(ti.max(ti.abs(S[k, k]), 1e-12))
        frame = U
    return eps, frame


@ti.func
def spectral(frame, a):
    """U diag(a) U^T in the principal frame of :func:`principal_log_stretch` (the first
    F.n entries of ``a``): in 2D (a_0 + a_1) / 2 I + (a_0 - a_1) / 2 N."""
    out = frame
    if ti.static(frame.n == 2):
        out = 0.5 * (a[0] + a[1]) * ti.Matrix.identity(float, 2) + 0.5 * (a[0] - a[1]) * frame
    else:
        D = ti.Matrix.zero(float, 3, 3)
        for k in ti.static(range(3)):
            D[k, k] = a[k]
        out = frame @ D @ frame.transpose()
    return out


@ti.func
def _svd2(F):
    # the polar rotation R: (cos, sin) the normalised (F00 + F11, F10 - F01); P = R^T F
    # symmetric; its principal axes at half the angle of (p00 - p11, 2 p01), the half angle
    # by a square root and a division (no trigonometry, no cancellation); its principal
    # values mean +- radius
    r = ti.sqrt((F[0, 0] + F[1, 1]) ** 2 + (F[1, 0] - F[0, 1]) ** 2)
    c, s = 1.0, 0.0
    if r > 0.0:
        c, s = (F[0, 0] + F[1, 1]) / r, (F[1, 0] - F[0, 1]) / r
    R = ti.Matrix([[c, -s], [s, c]])
    P = R.transpose() @ F
    a, b, d = P[0, 0], 0.5 * (P[0, 1] + P[1, 0]), P[1, 1]
    half, radius = 0.5 * (a - d), ti.sqrt(0.25 * (a - d) ** 2 + b * b)
    cp, sp = 1.0, 0.0
    if radius > 0.0:
        c2, s2 = half / radius, b / radius  # cos and sin of twice the axes' angle
        if c2 >= 0.0:
            cp = ti.sqrt(0.5 * (1.0 + c2))
            sp = s2 / (2.0 * cp)
        else:
            sp = ti.sqrt(0.5 * (1.0 - c2))
            cp = s2 / (2.0 * sp)
    V = ti.Matrix([[cp, -sp], [sp, cp]])
    mean = 0.5 * (a + d)
    S = ti.Matrix([[mean + radius, 0.0], [0.0, mean - radius]])
    return R @ V, S, V


@ti.func
def _svd3(F):
    # cyclic Jacobi on C = F^T F: V^T C V diagonal, S = sqrt(diag), U = F V S^-1
    C = F.transpose() @ F
    V = ti.Matrix.identity(float, 3)
    for _ in ti.static(range(SWEEPS)):
        for p, q in ti.static(((0, 1), (0, 2), (1, 2))):
            # the rotation in the (p, q) plane that zeroes C[p, q]
            angle = 0.5 * ti.atan2(2.0 * C[p, q], C[q, q] - C[p, p])
            c, s = ti.cos(angle), ti.sin(angle)
            J = ti.Matrix.identity(float, 3)
            J[p, p], J[q, q], J[p, q], J[q, p] = c, c, s, -s
            C = J.transpose() @ C @ J
            V = V @ J
    # U's columns F v_k / s_k made orthonormal (Gram-Schmidt, the third u_1 x u_2: U a
    # rotation), the singular values then u_k . F v_k (the last negative where det F < 0)
    v0 = ti.Vector([V[0, 0], V[1, 0], V[2, 0]])
    v1 = ti.Vector([V[0, 1], V[1, 1], V[2, 1]])
    v2 = ti.Vector([V[0, 2], V[1, 2], V[2, 2]])
    u0 = _unit(F @ v0, ti.Vector([1.0, 0.0, 0.0]))
    u1 = F @ v1
    u1 = _unit(u1 - u1.dot(u0) * u0, _perpendicular(u0))
    u2 = u0.cross(u1)
    U = ti.Matrix.cols([u0, u1, u2])
    S = ti.Matrix.zero(float, 3, 3)
    S[0, 0], S[1, 1], S[2, 2] = u0.dot(F @ v0), u1.dot(F @ v1), u2.dot(F @ v2)
    return U, S, V


@ti.func
def _unit(u, fallback):
    """u / |u|, or ``fallback`` where u vanishes (a zero singular value)."""
    n = u.norm()
    out = fallback
    if n > 1e-300:
        out = u / n
    return out


@ti.func
def _perpendicular(u):
    """A unit vector perpendicular to the unit vector u."""
    a = ti.Vector([1.0, 0.0, 0.0])
    if ti.abs(u[0]) > 0.9:
        a = ti.Vector([0.0, 1.0, 0.0])
    w = a - a.dot(u) * u
    return w / w.norm()
