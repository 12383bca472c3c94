"""The space of stereo pairs of a camera graph (S2 §4): stereo points, regions and their parameters.

A stereo pair of camera centres ``a`` (first eye) and ``b`` (second eye) is the 4-vector
``s(a, b) = ((a + b) / 2, |a - b|)``: the view position and the interocular distance (S2 §4, Eq. 1).
With the cameras moving on the segments of the camera graph, ``c(i, λ) = s_i0 (1 - λ) + s_i1 λ``,
the pairs with the first eye on segment ``i`` and the second on segment ``j`` fill a *region*
``s(c(i, λi), c(j, λj))``, (λi, λj) in [0, 1]²: a rhomboid for i < j, a triangle for i = j
(S2 §4, Fig. 6). Everything is in the units of the camera centres (metres for a metric collection).

Conventions (decisions; S2 leaves them open)
--------------------------------------------
- Regions are ordered pairs ``(i, j)`` with ``i <= j``: region ``(j, i)`` is region ``(i, j)`` with
  the eyes swapped, the same set of stereo points, so it is not a separate region.
- The *first* eye is ``c(i, λi)``, the *second* ``c(j, λj)``; the baseline is ``c(j, λj) - c(i, λi)``.
  Which one is the left eye is the renderer's decision (it knows where the cameras look): it
  rectifies with the x axis from left to right centre (Fusiello et al. 2000; S2 §3.2).
- A triangle ``(i, i)`` is the half ``λi <= λj`` of the square: ``(λj, λi)`` is the same stereo point
  with the eyes swapped. On it the baseline points along the segment (``λj - λi >= 0``).
- Where two parameter pairs give one stereo point (parallel segments, S2 §4.2), :meth:`parameters`
  keeps the one whose baseline points the same way as a reference: the baseline at ``near`` when it is
  given (the current view, so that the rectified orientation does not flip while browsing), else the
  direction of segment ``i`` as on the triangles.
- Regions may intersect: :meth:`StereoSpace.locate` maps a point to the first region that holds it
  (S2 §4.2).
- Zero-length segments are allowed (S2 includes the original cameras as segments ``aa``); their
  parameter does not move the eye and :meth:`parameters` returns 0 for it. Coincident eyes
  (interocular distance 0) are points of the space, e.g. the diagonal of every triangle.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Integral

import numpy as np

from vergence._validate import as_float_array, check_finite, check_in_range, readonly_copy

__all__ = ["JUMP_CONE_DEG", "PARALLEL_SINE", "RELATIVE_TOLERANCE", "StereoSpace", "StereoState", "stereo_point"]

RELATIVE_TOLERANCE = 1e-9
"""Tolerance of :meth:`StereoSpace.parameters`, relative to the size of the camera graph (its largest
absolute coordinate, at least 1): a point this far off a region still belongs to it, and parameters
this far outside [0, 1] are clipped. About 1e7 machine epsilons: far above the round-off of the 2x2
solve, far below any distance a viewer can see (1 nm on a 1 m graph)."""

PARALLEL_SINE = 1e-6
"""Segments whose directions make an angle with a sine below this are parallel for
:meth:`StereoSpace.parameters` (S2 §4.2): the mid-point system is then too ill-conditioned
(its error grows as 1/sine) and the Pythagoras construction is used; a Gauss-Newton polish on the
full 4-vector removes the error of either construction."""

JUMP_CONE_DEG = 40.0
"""Half-angle of the cone in which :meth:`StereoSpace.zoom` and :meth:`StereoSpace.pan` look for a region
to jump to, degrees (S2 §4.1: "the cone ... oriented as d and with angle 40"; S2 does not say whether
40 is the half-angle or the aperture: the half-angle finds a neighbour more often)."""

_POLISH_STEPS = 3  # Gauss-Newton steps on s(λ) = p after the closed form: quadratic convergence.


def stereo_point(a: object, b: object) -> np.ndarray:
    """The stereo point ``s(a, b) = ((a + b) / 2, |a - b|)`` of two camera centres (S2 §4, Eq. 1).

    Parameters
    ----------
    a, b : array_like, shape (3,)
        Centres of the first and second eye.

    Returns
    -------
    numpy.ndarray, shape (4,)
        Mid-point (view position) and interocular distance.

    Examples
    --------
    >>> stereo_point([0, 0, 0], [0.06, 0, 0]).round(3).tolist()
    [0.03, 0.0, 0.0, 0.06]
    """
    a = as_float_array("a", a, shape=(3,))
    b = as_float_array("b", b, shape=(3,))
    return np.append((a + b) / 2.0, np.linalg.norm(a - b))


@dataclass(frozen=True, slots=True)
class StereoState:
    """A position in the stereospace: a region ``(i, j)`` and its parameters ``(li, lj)``.

    The state only checks its own form; :class:`StereoSpace` checks that the region exists and that the
    parameters lie in it.
    """

    region: tuple[int, int]
    li: float
    lj: float

    def __post_init__(self) -> None:
        region = self.region
        if not isinstance(region, tuple | list) or len(region) != 2:
            raise TypeError(f"region must be a pair (i, j) of segment indices; got {region!r}")
        if not all(isinstance(k, Integral) and not isinstance(k, bool) for k in region):
            raise TypeError(f"region must hold integers; got {region!r}")
        object.__setattr__(self, "region", (int(region[0]), int(region[1])))
        object.__setattr__(self, "li", check_finite("li", self.li))
        object.__setattr__(self, "lj", check_finite("lj", self.lj))


@dataclass(frozen=True, slots=True, eq=False)
class StereoSpace:
    """The stereospace of a set of camera-centre segments (S2 §4).

    Parameters
    ----------
    segments : array_like, shape (m, 2, 3)
        Segment ``k`` joins camera centres ``segments[k, 0]`` and ``segments[k, 1]`` (an edge of the
        camera graph; a zero-length segment is a single camera). ``m >= 1``.

    Notes
    -----
    Region ``(i, j)``, ``i <= j``, is ``{s(c(i, λi), c(j, λj))}`` with ``c(k, λ) = s_k0 (1 - λ) + s_k1 λ``
    (S2 §4.1); see the module docstring for the conventions (first eye on segment ``i``, triangles
    ``λi <= λj``). The navigation (:func:`~vergence.stereospace.zoom`, :func:`~vergence.stereospace.pan`) is in :mod:`vergence.stereospace.navigation`.

    Examples
    --------
    >>> space = StereoSpace([[[0, 0, 0], [1, 0, 0]], [[0, 1, 0], [1, 1, 0]]])
    >>> space.regions
    ((0, 0), (0, 1), (1, 1))
    >>> space.point(0, 0.0, 1, 1.0).round(4).tolist()
    [0.5, 0.5, 0.0, 1.4142]
    >>> space.parameters([0.5, 0.5, 0.0, 2**0.5], region=(0, 1))
    (0.0, 1.0)
    """

    segments: np.ndarray

    def __post_init__(self) -> None:
        seg = as_float_array("segments", self.segments)
        if seg.ndim != 3 or seg.shape[1:] != (2, 3):
            raise ValueError(f"segments must have shape (m, 2, 3); got {seg.shape}")
        if seg.shape[0] < 1:
            raise ValueError("segments must hold at least one segment; got 0")
        object.__setattr__(self, "segments", readonly_copy(seg))

    @property
    def regions(self) -> tuple[tuple[int, int], ...]:
        """Every region ``(i, j)``, ``i <= j``, in lexicographic order: m (m + 1) / 2 of them."""
        m = len(self.segments)
        return tuple((i, j) for i in range(m) for j in range(i, m))

    @property
    def tolerance(self) -> float:
        """Absolute tolerance of :meth:`parameters`: :data:`RELATIVE_TOLERANCE` times the graph size."""
        return RELATIVE_TOLERANCE * max(1.0, float(np.abs(self.segments).max()))

    # -- checks -----------------------------------------------------------------------------------
    def check_region(self, region: object) -> tuple[int, int]:
        """Return ``region`` as ``(i, j)``, or raise if it is not a region of this space."""
        if not isinstance(region, tuple | list) or len(region) != 2:
            raise TypeError(f"region must be a pair (i, j) of segment indices; got {region!r}")
        if not all(isinstance(k, Integral) and not isinstance(k, bool) for k in region):
            raise TypeError(f"region must hold integers; got {region!r}")
        i, j = int(region[0]), int(region[1])
        m = len(self.segments)
        if not (0 <= i < m and 0 <= j < m):
            raise ValueError(f"region {(i, j)} does not exist: segment indices must lie in [0, {m - 1}]")
        if i > j:
            raise ValueError(f"region must have i <= j; {(i, j)} is region {(j, i)} with the eyes swapped")
        return i, j

    def check_state(self, state: object) -> StereoState:
        """Return ``state`` if it is a :class:`StereoState` lying in this space, else raise."""
        if not isinstance(state, StereoState):
            raise TypeError(f"state must be a StereoState; got {type(state).__name__}")
        self._check_parameters(self.check_region(state.region), state.li, state.lj)
        return state

    def _check_parameters(self, region: tuple[int, int], li: object, lj: object) -> tuple[float, float]:
        li = check_in_range("li", li, 0.0, 1.0)
        lj = check_in_range("lj", lj, 0.0, 1.0)
        if region[0] == region[1] and li > lj:
            raise ValueError(
                f"li must be <= lj on the triangle {region}; got li={li:g} > lj={lj:g} "
                f"(swap them: the same stereo point with the eyes swapped)"
            )
        return li, lj

    # -- parameters -> space ----------------------------------------------------------------------
    def eyes(self, state: StereoState) -> np.ndarray:
        """The two camera centres of a state, shape (2, 3): first eye ``c(i, li)``, second ``c(j, lj)``."""
        state = self.check_state(state)
        return self._eyes(state.region, state.li, state.lj)

    def _eyes(self, region: tuple[int, int], li: float, lj: float) -> np.ndarray:
        si, sj = self.segments[region[0]], self.segments[region[1]]
        return np.stack([si[0] * (1.0 - li) + si[1] * li, sj[0] * (1.0 - lj) + sj[1] * lj])

    def point(self, i: int, li: float, j: int, lj: float) -> np.ndarray:
        """The stereo point of the first eye at ``c(i, li)`` and the second at ``c(j, lj)`` (S2 §4.1).

        ``s(λi, λj) = ((c(λi) + c(λj)) / 2, |c(λi) - c(λj)|)``; shape (4,).
        """
        region = self.check_region((i, j))
        li, lj = self._check_parameters(region, li, lj)
        a, b = self._eyes(region, li, lj)
        return np.append((a + b) / 2.0, np.linalg.norm(a - b))

    def points(self, params: object, *, region: tuple[int, int]) -> np.ndarray:
        """:meth:`point` for many parameter pairs of one region: ``params`` (N, 2) -> (N, 4)."""
        i, j = self.check_region(region)
        lam = as_float_array("params", params, shape=(None, 2))
        if ((lam < 0.0) | (lam > 1.0)).any():
            raise ValueError(f"params must lie in [0, 1]; got [{lam.min():g}, {lam.max():g}]")
        if i == j and (lam[:, 0] > lam[:, 1]).any():
            raise ValueError(f"params must have li <= lj on the triangle {(i, j)}")
        return self._points((i, j), lam)

    def _points(self, region: tuple[int, int], lam: np.ndarray) -> np.ndarray:
        """Unchecked :meth:`points`; also valid outside [0, 1] (on the lines through the segments)."""
        si, sj = self.segments[region[0]], self.segments[region[1]]
        a = si[0] + lam[:, :1] * (si[1] - si[0])
        b = sj[0] + lam[:, 1:] * (sj[1] - sj[0])
        return np.concatenate([(a + b) / 2.0, np.linalg.norm(a - b, axis=1, keepdims=True)], axis=1)

    # -- space -> parameters (S2 §4.2) ------------------------------------------------------------
    def parameters(
        self, point: object, *, region: tuple[int, int], near: tuple[float, float] | None = None
    ) -> tuple[float, float]:
        """The parameters ``(li, lj)`` of a stereo point in a region, so that
        ``point(i, li, j, lj) == point`` (S2 §4.2).

        Parameters
        ----------
        point : array_like, shape (4,)
            Mid-point and interocular distance.
        region : (int, int)
            The region ``(i, j)``, ``i <= j``.
        near : (float, float), optional
            Parameters of a reference pair (the current view): of two solutions, the one whose baseline
            points the same way as the baseline at ``near`` is returned.

        Notes
        -----
        The mid-point equation ``[s_i1 - s_i0 | s_j1 - s_j0] [λi, λj]^T = 2 p_xyz - s_i0 - s_j0``
        (S2 §4.2; S2 writes the sum of the eyes, hence no factor 2 there) is solved by least squares.
        If the segments are parallel (every triangle) the system is singular: the first eye is then
        the point of line ``i`` at distance ``p_w / 2`` from the mid-point (Pythagoras), on either side,
        and the second eye its mirror through the mid-point. A zero-length segment fixes its eye and
        gets the parameter 0.

        Raises
        ------
        ValueError
            If the point is not in the region, or on bad input. The message gives the distance to the
            region's point at the parameters that fit best (an upper bound of the distance to the region).
        """
        i, j = self.check_region(region)
        p = as_float_array("point", point, shape=(4,))
        if p[3] < 0.0:
            raise ValueError(f"point must have an interocular distance >= 0; got {p[3]:g}")
        ref = None
        if near is not None:
            ref = self._eyes((i, j), *self._check_parameters((i, j), *_pair("near", near)))
        best, off = self._solve((i, j), p, ref)
        if best is None:
            raise ValueError(f"point is not in region {(i, j)}: its best fit in the region is {off:.3g} away")
        return float(best[0]), float(best[1])

    def locate(self, point: object, *, current: StereoState | None = None) -> StereoState:
        """The state of a stereo point in the first region that holds it, in :attr:`regions` order.

        Regions may intersect; S2 §4.2 "simply choose[s] to map in the first region we find". Within a
        region the solution is chosen as in :meth:`parameters`, with the baseline of ``current`` (the
        current view) as the reference orientation.

        Raises
        ------
        ValueError
            If no region holds the point (the message gives the closest fit, as :meth:`parameters`).
        """
        p = as_float_array("point", point, shape=(4,))
        if p[3] < 0.0:
            raise ValueError(f"point must have an interocular distance >= 0; got {p[3]:g}")
        ref = None if current is None else self.eyes(current)
        closest, where = np.inf, None
        for region in self.regions:
            lam, off = self._solve(region, p, ref)
            if lam is not None:
                return StereoState(region, float(lam[0]), float(lam[1]))
            if off < closest:
                closest, where = off, region
        raise ValueError(f"point is not in the stereospace: its best fit, in region {where}, is {closest:.3g} away")

    def _solve(self, region: tuple[int, int], p: np.ndarray, ref: np.ndarray | None) -> tuple[np.ndarray | None, float]:
        """The parameters of ``p`` in ``region`` (or None) and how far off the region the point is."""
        best, best_off = None, np.inf
        for lam in self._candidates(region, p):
            lam = np.clip(self._polish(region, lam, p), 0.0, 1.0)
            if region[0] == region[1] and lam[0] > lam[1]:  # nearest pair of the triangle's half li <= lj
                lam[:] = lam.mean()
            off = float(np.linalg.norm(self._points(region, lam[None])[0] - p))
            if off > self.tolerance:
                best_off = min(best_off, off)
            elif best is None or self._prefer(region, lam, best, ref):
                best, best_off = lam, 0.0
        return best, best_off

    def _candidates(self, region: tuple[int, int], p: np.ndarray) -> list[np.ndarray]:
        """Parameter pairs (unclipped) whose mid-point is ``p[:3]``: one, or two for parallel segments."""
        si, sj = self.segments[region[0]], self.segments[region[1]]
        ui, uj = si[1] - si[0], sj[1] - sj[0]
        ni, nj = np.linalg.norm(ui), np.linalg.norm(uj)
        tol = self.tolerance
        rhs = 2.0 * p[:3] - si[0] - sj[0]  # mid-point equation, S2 §4.2 with the factor 2
        if ni <= tol and nj <= tol:
            return [np.zeros(2)]
        if ni <= tol:  # first eye fixed at si[0]: the second is its mirror through the mid-point
            return [np.array([0.0, rhs @ uj / nj**2])]
        if nj <= tol:
            return [np.array([rhs @ ui / ni**2, 0.0])]
        if np.linalg.norm(np.cross(ui, uj)) > PARALLEL_SINE * ni * nj:
            A = np.stack([ui, uj], axis=1)
            return [np.linalg.lstsq(A, rhs, rcond=None)[0]]
        # Parallel: eyes on line i at distance p_w / 2 from the mid-point m (Pythagoras, S2 §4.2).
        m, r = p[:3], p[3] / 2.0
        foot = (m - si[0]) @ ui / ni**2
        h2 = float(np.sum((si[0] + foot * ui - m) ** 2))
        along = np.sqrt(max(r * r - h2, 0.0)) / ni
        out = []
        for li in (foot - along, foot + along):
            b = 2.0 * m - (si[0] + li * ui)
            out.append(np.array([li, (b - sj[0]) @ uj / nj**2]))
        return out

    def _polish(self, region: tuple[int, int], lam: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Gauss-Newton on the 4 equations ``s(λ) = p``; keeps a step only if it lowers the residual."""
        res = self._points(region, lam[None])[0] - p
        for _ in range(_POLISH_STEPS):
            J = self._jacobian(region, lam)
            step = np.linalg.lstsq(J, -res, rcond=None)[0]
            new_res = self._points(region, (lam + step)[None])[0] - p
            if np.linalg.norm(new_res) >= np.linalg.norm(res):
                break
            lam, res = lam + step, new_res
        return lam

    def _prefer(self, region: tuple[int, int], lam: np.ndarray, other: np.ndarray, ref: np.ndarray | None) -> bool:
        """True if ``lam`` keeps the reference orientation better than ``other`` (see module docstring)."""
        si = self.segments[region[0]]
        axis = si[1] - si[0] if ref is None else ref[1] - ref[0]
        if not np.any(axis):
            sj = self.segments[region[1]]
            axis = sj[1] - sj[0]
        score = [float(np.diff(self._eyes(region, *x), axis=0)[0] @ axis) for x in (lam, other)]
        return score[0] > score[1]

    # -- derivatives (S2 §4.1) --------------------------------------------------------------------
    def _jacobian(self, region: tuple[int, int], lam: np.ndarray) -> np.ndarray:
        """d s / d (λi, λj), shape (4, 2); the last row is the gradient of s_w (0 where the eyes meet)."""
        si, sj = self.segments[region[0]], self.segments[region[1]]
        ui, uj = si[1] - si[0], sj[1] - sj[0]
        a, b = self._eyes(region, *lam)
        d = a - b
        n = np.linalg.norm(d)
        grad = np.zeros(2) if n == 0.0 else np.array([d @ ui, -(d @ uj)]) / n
        return np.vstack([np.stack([ui, uj], axis=1) / 2.0, grad])

    def gradient(self, state: StereoState) -> np.ndarray:
        """The gradient of the interocular distance s_w over (li, lj), metres per unit parameter.

        ``∇s_w = (d · u_i, -d · u_j) / |d|`` with ``d = c(i, li) - c(j, lj)`` and ``u_k = s_k1 - s_k0``
        (S2 §4.1). Where the eyes coincide s_w is not differentiable; there the gradient is (0, 0)
        and :func:`~vergence.stereospace.zoom` uses the direction of steepest growth instead.
        """
        state = self.check_state(state)
        return self._jacobian(state.region, np.array([state.li, state.lj]))[3]


def _pair(name: str, value: object) -> tuple[float, float]:
    arr = as_float_array(name, value, shape=(2,))
    return float(arr[0]), float(arr[1])
