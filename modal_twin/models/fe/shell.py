"""Flat 4-node shell: QM6 membrane + MITC4 plate + drilling penalty, 6 DOF per node.

Each element is flat (its four nodes within a tolerance of one plane). In its local axes
(``x`` along edge 1-2, ``z`` the normal, ``y = z x x``) the node DOFs are
``u, v, w, theta_x, theta_y, theta_z`` and the element matrix is the sum of

* **membrane** (``u, v``): the bilinear quadrilateral with Wilson's incompatible modes
  ``1 - xi^2``, ``1 - eta^2``, their derivatives taken with the centre Jacobian ``J0`` and
  scaled by ``det J0 / det J`` (Taylor, Beresford & Wilson's QM6), so it passes the patch
  test on any convex quadrilateral; the internal modes are condensed statically::

      K_m = K_cc - K_ci K_ii^-1 K_ic,   K = int B' D_m B dA,  D_m = E t / (1 - nu^2) [..]

* **plate** (``w, theta_x, theta_y``, Mindlin-Reissner, ``u = z theta_y``, ``v = -z theta_x``):
  curvatures ``kappa = (theta_y,x, -theta_x,y, theta_y,y - theta_x,x)`` with
  ``D_b = E t_b^3 / (12 (1 - nu^2)) [..]``; transverse shear ``gamma = (w,x + theta_y,
  w,y - theta_x)`` by the MITC4 assumed covariant strains (Bathe & Dvorkin): ``e_xi`` tied
  at ``(0, +-1)``, ``e_eta`` at ``(+-1, 0)``, interpolated linearly and mapped with
  ``gamma = J^-1 e``; shear modulus ``k G t_b`` with ``k = 5/6``. No shear locking.
* **drilling** (``theta_z``): the penalty ``(alpha G t / 2) int (theta_z - omega)^2 dA`` with
  the in-plane rotation ``omega = (v,x - u,y) / 2`` (Hughes & Brezzi), at the 2x2 Gauss
  points. It vanishes for rigid motions and only ties ``theta_z`` to ``omega``.

Every stiffness term is proportional to ``E`` (``G = E / (2 (1 + nu))``), every mass term to
``rho``: the element returns ``k / E`` and ``m / rho`` so that a zone's modulus and density are
exact linear parameters of the model (Sec. 4 of [004]; the twelve parameters of [002]
Table 1 without the Poisson ratios). ``t`` is the membrane (mass) thickness and ``t_b`` the
bending-equivalent thickness (``t_b^3 / 12`` = second moment per unit width): a hollow
aluminium extrusion of two skins ``s`` at a depth ``d`` has ``t = 2 s`` (plus webs) and
``t_b = (6 s d^2)^(1/3)``; a solid plate has ``t_b = t``. Mass: consistent, ``rho t`` on
``u, v, w`` and ``rho t_b^3 / 12`` on ``theta_x, theta_y``, none on ``theta_z``.

References
----------
R. L. Taylor, P. J. Beresford, E. L. Wilson, "A non-conforming element for stress
analysis", IJNME 10 (1976) 1211-1219 (QM6). K. J. Bathe, E. N. Dvorkin, "A four-node plate
bending element based on Mindlin/Reissner plate theory and a mixed interpolation", IJNME 21
(1985) 367-383 (MITC4). T. J. R. Hughes, F. Brezzi, "On drilling degrees of freedom",
CMAME 72 (1989) 105-121.
"""

from __future__ import annotations

import math

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError
from modal_twin.models.fe.model import FEModel, NodeId

__all__ = [
    "ShellModel",
    "shell_global_units",
    "shell_local_matrices",
    "shell_rotation",
]

_XI = np.array([-1.0, 1.0, 1.0, -1.0])
_ETA = np.array([-1.0, -1.0, 1.0, 1.0])
_G = 1.0 / math.sqrt(3.0)
_GAUSS = [(-_G, -_G), (_G, -_G), (_G, _G), (-_G, _G)]  # 2x2, unit weights
_SHEAR_FACTOR = 5.0 / 6.0

# local DOF indices within the 24 of an element
_U = 6 * np.arange(4)
_V = _U + 1
_W = _U + 2
_TX = _U + 3
_TY = _U + 4
_TZ = _U + 5


def _shape(xi: float, eta: float) -> tuple[FloatArray, FloatArray]:
    """Bilinear shape functions ``N`` (4,) and their natural derivatives (2, 4)."""
    N = 0.25 * (1.0 + _XI * xi) * (1.0 + _ETA * eta)
    dN = np.array([0.25 * _XI * (1.0 + _ETA * eta), 0.25 * _ETA * (1.0 + _XI * xi)])
    return N, dN


def _jacobian(dN: FloatArray, xy: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Return ``J`` (ne, 2, 2) = [[x_xi, y_xi], [x_eta, y_eta]], ``det J`` and ``J^-1``."""
    J = np.einsum("ak,ekb->eab", dN, xy)
    det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
    inv = np.empty_like(J)
    inv[:, 0, 0] = J[:, 1, 1] / det
    inv[:, 1, 1] = J[:, 0, 0] / det
    inv[:, 0, 1] = -J[:, 0, 1] / det
    inv[:, 1, 0] = -J[:, 1, 0] / det
    return J, det, inv


def _check_quads(xy: FloatArray) -> None:
    for xi, eta in [(-1, -1), (1, -1), (1, 1), (-1, 1), (0, 0)]:
        _, dN = _shape(xi, eta)
        _, det, _ = _jacobian(dN, xy)
        bad = np.flatnonzero(~(det > 0.0))
        if bad.size:
            msg = (f"shell element {int(bad[0])}: expected a convex quadrilateral numbered "
                   f"counter-clockwise about its normal, got det J = {det[bad[0]]:.3g} at "
                   f"corner ({xi}, {eta})")
            raise ModelError(msg)


def _membrane(xy: FloatArray, nu: float, dm: FloatArray) -> FloatArray:
    """QM6 membrane ``k / E`` (ne, 8, 8) in the order (u1, v1, ..., u4, v4)."""
    ne = xy.shape[0]
    _, dN0 = _shape(0.0, 0.0)
    _, det0, inv0 = _jacobian(dN0, xy)
    D = np.array([[1.0, nu, 0.0], [nu, 1.0, 0.0], [0.0, 0.0, 0.5 * (1.0 - nu)]]) / (1 - nu**2)
    Kcc = np.zeros((ne, 8, 8))
    Kci = np.zeros((ne, 8, 4))
    Kii = np.zeros((ne, 4, 4))
    for xi, eta in _GAUSS:
        _, dN = _shape(xi, eta)
        _, det, inv = _jacobian(dN, xy)
        d = np.einsum("eab,bk->eak", inv, dN)  # (ne, 2, 4): d/dx, d/dy
        B = np.zeros((ne, 3, 8))
        B[:, 0, 0::2] = d[:, 0]
        B[:, 1, 1::2] = d[:, 1]
        B[:, 2, 0::2] = d[:, 1]
        B[:, 2, 1::2] = d[:, 0]
        dP = np.array([[-2.0 * xi, 0.0], [0.0, -2.0 * eta]])  # rows d/dxi, d/deta of P1, P2
        dPi = np.einsum("eab,bk->eak", inv0, dP) * (det0 / det)[:, None, None]
        Bi = np.zeros((ne, 3, 4))
        Bi[:, 0, 0:2] = dPi[:, 0]
        Bi[:, 1, 2:4] = dPi[:, 1]
        Bi[:, 2, 0:2] = dPi[:, 1]
        Bi[:, 2, 2:4] = dPi[:, 0]
        w = (det * dm)[:, None, None]
        Kcc += w * np.einsum("eia,ij,ejb->eab", B, D, B)
        Kci += w * np.einsum("eia,ij,ejb->eab", B, D, Bi)
        Kii += w * np.einsum("eia,ij,ejb->eab", Bi, D, Bi)
    return np.asarray(Kcc - Kci @ np.linalg.solve(Kii, np.swapaxes(Kci, 1, 2)))


def _plate(xy: FloatArray, nu: float, tb: FloatArray) -> FloatArray:
    """MITC4 plate ``k / E`` (ne, 12, 12) in the order (w1, tx1, ty1, ..., w4, tx4, ty4)."""
    ne = xy.shape[0]
    Db = np.array([[1.0, nu, 0.0], [nu, 1.0, 0.0], [0.0, 0.0, 0.5 * (1.0 - nu)]])
    Db = Db / (12.0 * (1.0 - nu**2))
    ks = _SHEAR_FACTOR / (2.0 * (1.0 + nu))
    # covariant shear rows at the tying points: e_xi at A (0, 1), C (0, -1); e_eta at
    # B (1, 0), D (-1, 0). e_xi = w,xi + x_xi theta_y - y_xi theta_x.
    tie: dict[str, FloatArray] = {}
    for name, (xi, eta), row in (("A", (0.0, 1.0), 0), ("C", (0.0, -1.0), 0),
                                 ("B", (1.0, 0.0), 1), ("D", (-1.0, 0.0), 1)):
        N, dN = _shape(xi, eta)
        J, _, _ = _jacobian(dN, xy)
        e = np.zeros((ne, 12))
        e[:, 0::3] = dN[row]
        e[:, 1::3] = -J[:, row, 1, None] * N
        e[:, 2::3] = J[:, row, 0, None] * N
        tie[name] = e
    K = np.zeros((ne, 12, 12))
    for xi, eta in _GAUSS:
        _, dN = _shape(xi, eta)
        _, det, inv = _jacobian(dN, xy)
        d = np.einsum("eab,bk->eak", inv, dN)
        Bb = np.zeros((ne, 3, 12))
        Bb[:, 0, 2::3] = d[:, 0]
        Bb[:, 1, 1::3] = -d[:, 1]
        Bb[:, 2, 2::3] = d[:, 1]
        Bb[:, 2, 1::3] = -d[:, 0]
        e_nat = np.stack([0.5 * (1 + eta) * tie["A"] + 0.5 * (1 - eta) * tie["C"],
                          0.5 * (1 + xi) * tie["B"] + 0.5 * (1 - xi) * tie["D"]], axis=1)
        Bs = np.einsum("eab,ebk->eak", inv, e_nat)  # gamma = J^-1 e
        K += (det * tb**3)[:, None, None] * np.einsum("eia,ij,ejb->eab", Bb, Db, Bb)
        K += (det * ks * tb)[:, None, None] * np.einsum("eia,eib->eab", Bs, Bs)
    return K


def _drilling(xy: FloatArray, nu: float, t: FloatArray, alpha: float) -> FloatArray:
    """Drilling penalty ``k / E`` (ne, 12, 12) in the order (u1, v1, tz1, ..., tz4)."""
    ne = xy.shape[0]
    g = alpha / (2.0 * (1.0 + nu))
    K = np.zeros((ne, 12, 12))
    for xi, eta in _GAUSS:
        N, dN = _shape(xi, eta)
        _, det, inv = _jacobian(dN, xy)
        d = np.einsum("eab,bk->eak", inv, dN)
        r = np.zeros((ne, 12))
        r[:, 0::3] = 0.5 * d[:, 1]   # - omega: + u,y / 2
        r[:, 1::3] = -0.5 * d[:, 0]  # - v,x / 2
        r[:, 2::3] = N
        K += (g * t * det)[:, None, None] * np.einsum("ea,eb->eab", r, r)
    return K


def _mass(xy: FloatArray, t: FloatArray, tb: FloatArray) -> FloatArray:
    """Consistent ``m / rho`` (ne, 24, 24) in local DOFs."""
    ne = xy.shape[0]
    NN = np.zeros((ne, 4, 4))
    for xi, eta in _GAUSS:
        N, dN = _shape(xi, eta)
        _, det, _ = _jacobian(dN, xy)
        NN += det[:, None, None] * np.outer(N, N)
    M = np.zeros((ne, 24, 24))
    for idx, scale in ((_U, t), (_V, t), (_W, t), (_TX, tb**3 / 12.0), (_TY, tb**3 / 12.0)):
        M[:, idx[:, None], idx[None, :]] = scale[:, None, None] * NN
    return M


def shell_local_matrices(
    xy: FloatArray, *, nu: float, t: FloatArray | float, t_b: FloatArray | float | None = None,
    drilling: float = 1e-2,
) -> tuple[FloatArray, FloatArray]:
    """Return ``k / E`` and ``m / rho`` (ne, 24, 24) of flat shells in their local axes.

    Parameters
    ----------
    xy : (ne, 4, 2) or (4, 2) float array
        Local in-plane node coordinates (m), counter-clockwise about the normal.
    nu : float
        Poisson ratio, in [0, 0.5).
    t : float or (ne,) float array
        Membrane (mass) thickness, m (> 0).
    t_b : float or (ne,) float array, optional
        Bending-equivalent thickness, m (default ``t``).
    drilling : float
        Drilling penalty factor ``alpha`` (module docstring), > 0.

    Returns
    -------
    k_unit, m_unit : (ne, 24, 24) float arrays
        Stiffness per unit modulus (``K = E k_unit``) and mass per unit density
        (``M = rho m_unit``), local DOFs ``u, v, w, theta_x, theta_y, theta_z`` per node.

    Raises
    ------
    ModelError
        Bad thickness, Poisson ratio or a distorted / clockwise quadrilateral.
    """
    xy = np.asarray(xy, dtype=float)
    if xy.ndim == 2:
        xy = xy[None]
    if xy.ndim != 3 or xy.shape[1:] != (4, 2) or not np.all(np.isfinite(xy)):
        msg = f"xy: expected (ne, 4, 2) finite coordinates, got shape {xy.shape}"
        raise ModelError(msg)
    ne = xy.shape[0]
    if not (math.isfinite(nu) and 0.0 <= nu < 0.5):
        msg = f"nu: expected a value in [0, 0.5), got {nu!r}"
        raise ModelError(msg)
    if not (math.isfinite(drilling) and drilling > 0.0):
        msg = f"drilling: expected a finite value > 0, got {drilling!r}"
        raise ModelError(msg)
    tt = np.broadcast_to(np.asarray(t, dtype=float), (ne,)).copy()
    tb = tt.copy() if t_b is None else np.broadcast_to(np.asarray(t_b, dtype=float), (ne,)).copy()
    for name, arr in (("t", tt), ("t_b", tb)):
        if not np.all(np.isfinite(arr) & (arr > 0.0)):
            msg = f"{name}: expected finite thicknesses > 0, got min {arr.min()!r}"
            raise ModelError(msg)
    _check_quads(xy)
    K = np.zeros((ne, 24, 24))
    mem = np.ravel(np.column_stack([_U, _V]))
    K[:, mem[:, None], mem[None, :]] += _membrane(xy, nu, tt)
    pl = np.ravel(np.column_stack([_W, _TX, _TY]))
    K[:, pl[:, None], pl[None, :]] += _plate(xy, nu, tb)
    dr = np.ravel(np.column_stack([_U, _V, _TZ]))
    K[:, dr[:, None], dr[None, :]] += _drilling(xy, nu, tt, drilling)
    return K, _mass(xy, tt, tb)


def shell_rotation(xyz: FloatArray, *, flat_tol: float = 1e-3) -> tuple[FloatArray, FloatArray]:
    """Return the local axes ``r`` (ne, 3, 3) (rows x, y, z) and local ``xy`` (ne, 4, 2).

    ``x`` runs along edge 1-2, ``z`` is the normal from the diagonals' cross product.

    Raises
    ------
    ModelError
        Degenerate elements, or nodes off the mean plane by more than ``flat_tol`` times
        the element's size (a warped element is not a flat shell).
    """
    X = np.asarray(xyz, dtype=float)
    if X.ndim == 2:
        X = X[None]
    if X.ndim != 3 or X.shape[1:] != (4, 3) or not np.all(np.isfinite(X)):
        msg = f"xyz: expected (ne, 4, 3) finite coordinates, got shape {X.shape}"
        raise ModelError(msg)
    n = np.cross(X[:, 2] - X[:, 0], X[:, 3] - X[:, 1])
    ex = X[:, 1] - X[:, 0]
    size = np.linalg.norm(X[:, 2] - X[:, 0], axis=1)
    nn = np.linalg.norm(n, axis=1)
    bad = np.flatnonzero(~((nn > 1e-12 * size**2) & (np.linalg.norm(ex, axis=1) > 1e-9 * size)))
    if bad.size:
        msg = f"shell element {int(bad[0])}: expected a non-degenerate quadrilateral"
        raise ModelError(msg)
    ez = n / nn[:, None]
    ex = ex - np.einsum("ei,ei->e", ex, ez)[:, None] * ez
    ex /= np.linalg.norm(ex, axis=1)[:, None]
    ey = np.cross(ez, ex)
    r = np.stack([ex, ey, ez], axis=1)
    c = X.mean(axis=1, keepdims=True)
    loc = np.einsum("eab,ekb->eka", r, X - c)
    warp = np.abs(loc[:, :, 2]).max(axis=1) / size
    bad = np.flatnonzero(warp > flat_tol)
    if bad.size:
        msg = (f"shell element {int(bad[0])}: expected a flat quadrilateral, got a warp of "
               f"{warp[bad[0]]:.3g} of its size")
        raise ModelError(msg)
    return r, loc[:, :, :2]


def shell_global_units(
    xyz: FloatArray, *, nu: float, t: FloatArray | float, t_b: FloatArray | float | None = None,
    drilling: float = 1e-2,
) -> tuple[FloatArray, FloatArray]:
    """Return ``k / E`` and ``m / rho`` (ne, 24, 24) of flat shells in global axes.

    ``xyz`` (ne, 4, 3): node coordinates (m), counter-clockwise about the wanted normal.
    ``k_g = T' k_l T`` with ``T = blockdiag(r, ..., r)`` (8 blocks). Other parameters as in
    :func:`shell_local_matrices`.
    """
    r, xy = shell_rotation(xyz)
    k, m = shell_local_matrices(xy, nu=nu, t=t, t_b=t_b, drilling=drilling)
    ne = r.shape[0]
    T = np.zeros((ne, 24, 24))
    for j in range(8):
        T[:, 3 * j:3 * j + 3, 3 * j:3 * j + 3] = r
    Tt = np.swapaxes(T, 1, 2)
    return Tt @ k @ T, Tt @ m @ T


class ShellModel(FEModel):
    """:class:`~modal_twin.models.fe.model.FEModel` with flat 4-node shells.

    A shell's stiffness is recorded as ``E * (k / E)`` and its mass as ``rho * (m / rho)``
    (module docstring), so ``E_param`` / ``rho_param`` make a zone's modulus and density
    exact linear parameters; a non-structural mass per area is a separate mass term.

    Examples
    --------
    >>> fem = ShellModel()
    >>> for i, p in enumerate([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]):
    ...     _ = fem.add_node(i, p)
    >>> fem.add_shells([(0, 1, 2, 3)], E=70e9, nu=0.3, rho=2700.0, t=0.01)
    [0]
    >>> round(fem.assemble().total_mass(), 9)
    27.0
    """

    def __init__(self) -> None:
        super().__init__()
        self.n_shells = 0

    def add_shells(
        self, quads: list[tuple[NodeId, NodeId, NodeId, NodeId]], *, E: float, nu: float,
        rho: float, t: float, t_b: float | None = None, nsm: float = 0.0,
        E_param: str | None = None, rho_param: str | None = None, drilling: float = 1e-2,
    ) -> list[int]:
        """Add flat shells of one property; return their shell numbers.

        Parameters
        ----------
        quads : list of 4 node ids
            Corner nodes, counter-clockwise about the outward normal.
        E, nu, rho : float
            Modulus (Pa, > 0), Poisson ratio, density (kg/m^3, >= 0).
        t, t_b : float
            Membrane and bending-equivalent thickness, m (``t_b`` default ``t``).
        nsm : float
            Non-structural mass per area, kg/m^2 (>= 0), on ``u, v, w`` (consistent).
        E_param, rho_param : str, optional
            Parameter names of ``E`` and ``rho``.
        drilling : float
            Drilling penalty factor (:func:`shell_local_matrices`).

        Raises
        ------
        ModelError
            Unknown nodes, bad properties, a warped or degenerate quadrilateral.
        """
        for name, val, low in (("E", E, 0.0), ("rho", rho, None), ("nsm", nsm, None)):
            ok = math.isfinite(val) and (val > low if low is not None else val >= 0.0)
            if not ok:
                want = "> 0" if low is not None else ">= 0"
                msg = f"shell {name}: expected a finite value {want}, got {val!r}"
                raise ModelError(msg)
        if not quads:
            return []
        for q in quads:
            if len(q) != 4 or len(set(q)) != 4:
                msg = f"shell nodes: expected 4 distinct node ids, got {q!r}"
                raise ModelError(msg)
        dofs = [np.concatenate([self._node_dofs(n) for n in q]) for q in quads]
        xyz = np.array([[self._xyz[n] for n in q] for q in quads])
        k_unit, m_unit = shell_global_units(xyz, nu=nu, t=t, t_b=t_b, drilling=drilling)
        if nsm > 0.0:
            _, m_nsm = shell_global_units(xyz, nu=nu, t=1.0, t_b=1e-6, drilling=drilling)
        out = []
        for e, d in enumerate(dofs):
            self._add("K", d, k_unit[e], E, E_param)
            if rho > 0.0:
                self._add("M", d, m_unit[e], rho, rho_param)
            if nsm > 0.0:
                self._add("M", d, _translational(m_nsm[e]), nsm, None)
            out.append(self.n_shells)
            self.n_shells += 1
        return out


def _translational(m: FloatArray) -> FloatArray:
    """Keep the translational rows / columns of a 24 x 24 mass (drop rotary inertia)."""
    keep = np.zeros(24, dtype=bool)
    for j in range(4):
        keep[6 * j:6 * j + 3] = True
    out = m.copy()
    out[~keep, :] = 0.0
    out[:, ~keep] = 0.0
    return out
