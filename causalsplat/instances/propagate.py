"""Labels for weakly seen Gaussians, carried along surfaces from the well-seen ones.

Masks only describe the front surface of a view. A Gaussian that every view sees through
something else (the floor under a table top, the back of a cabinet) carries a little blending
weight inside the *occluder's* masks, so its votes name the occluder, whatever view it is
seen from. Its label is better read from the surface it lies on. This module does that:

1. **Surface graph** (:func:`surface_graph`): each active Gaussian is joined to its ``k``
   nearest neighbours within ``radius``, with weight
   ``exp(-(d / s)**2) * exp(-e / 2)``, ``d`` the distance of the centres, ``s`` the median
   neighbour distance of the scene, and ``e`` the squared offset of each centre from the
   other's tangent plane in units of the two discs' thickness,
   ``e = g_i (n_i·Δ)² / (t_i² + t_j²) + g_j (n_j·Δ)² / (t_i² + t_j²)``, ``n`` the axis of the
   smallest scale ``t`` and ``g = clip(2 (1 - t / mid scale), 0, 1)`` how flat the Gaussian
   is (a disc whose thickness is at most half its width counts fully; a sphere, which has
   no normal, not at all). Two discs of one surface are joined strongly; a disc and one of a
   parallel surface a few thicknesses away (a cabinet's back and the wall behind it), or of
   a crossing surface (a table leg and the floor), weakly. A Gaussian flatter as its
   neighbourhood than as itself takes its plane from its neighbours (:func:`local_planes`):
   the normal, thickness and width of the principal axes of its :data:`PLANE_NEIGHBORS`
   nearest centres, the thickness at least :data:`MIN_THICKNESS` median Gaussian sizes.
   Spheres, as a mesh's or a point cloud's vertices become, have no normal of their own,
   but the floor they tile is as flat as a disc's. Every length is relative to the
   scene's own scales, so a scene in millimetres and the same one in kilometres give the
   same graph weights.
   Each edge is then weighted by the agreement of the two Gaussians' features,
   ``max(0.1, f_i·f_j) ** p`` (:func:`feature_weighted`): the field tells a microwave's
   barely seen side from the cabinet it sits in, which the surface alone joins; the floor
   of 0.1 keeps a surface joined where the features of its hidden part lean to its
   occluder. Edges to a Gaussian no mask supervised keep their weight: its feature means
   nothing.
   Each edge is also weighted by how alike the two Gaussians' base colours are,
   ``exp(-(dE / sigma)**2 / 2)`` with ``dE`` their CIELAB distance (:func:`colour_weighted`):
   two touching surfaces of different colours are likely two objects, such as a cabinet's
   back, which no view sees, and the wall it stands flush against.
2. **Harmonic labels** (:func:`harmonic_labels`): the well-seen, labelled Gaussians are
   fixed; every other Gaussian gets, for each entity, the probability that a random walk
   on the graph from it first reaches a fixed Gaussian of that entity (the harmonic
   function of Zhu, Ghahramani and Lafferty, 2003: one sparse linear solve), and takes the
   most probable entity. Gaussians whose component of the graph holds no fixed Gaussian
   keep the label they had.

**Degenerate graphs** never make the solve fail (:mod:`causalsplat.instances._absorb`).
Weights that are not finite and positive (an ``exp`` that underflowed to 0, a NaN) are no
edges; the weights are rescaled by a power of two, so tiny or huge ones neither underflow
nor overflow. Near-duplicate Gaussians (densified scenes: copies of one Gaussian a tiny
jitter apart) make clusters whose edges to the rest of the surface weigh ``1e-100`` and
less: such a nearly closed part of the graph is singular in floating point
(``1 + 1e-100 == 1``). It is solved with a tiny killing rate added (``1e-10`` of each
Gaussian's degree): the walk mixes over the cluster before it leaves, so the cluster takes
the entity with the most weight out of it, the limit of the exact answer. Everything else
is solved exactly, as before; an exact solution is checked (each Gaussian's
probabilities must sum to 1) and its component solved again regularised when it fails.
A Gaussian whose probabilities underflow to 0 keeps its label, like one whose component
holds no fixed Gaussian. With ``k`` or more copies of a Gaussian its ``k`` neighbours may
all be copies: such a cluster has no edge out at all and keeps its labels.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from causalsplat.colors import srgb_to_lab
from causalsplat.instances._absorb import absorbing_labels
from causalsplat.io._geometry import quat_to_rotmat


def surface_graph(
    means: np.ndarray,
    scales: np.ndarray,
    quats: np.ndarray | None,
    *,
    k: int,
    radius: float,
    coplanar: bool = True,
) -> sp.csr_matrix:
    """(N, N) symmetric weights of the surface graph of ``N`` Gaussians (module docstring).

    ``means`` (N, 3), ``scales`` (N, 3) standard deviations, ``quats`` (N, 4) wxyz (any
    non-zero norm; without them every Gaussian is taken for a sphere, whose plane is its
    neighbours'). With ``coplanar=False`` only the distance term is used. Edges are at
    most ``radius`` long; the matrix has no stored zeros.
    """
    pts = np.asarray(means, dtype=np.float64)
    n = pts.shape[0]
    kk = min(int(k), n - 1)
    if kk < 1 or not np.isfinite(radius) or radius <= 0:
        return sp.csr_matrix((n, n))
    tree = cKDTree(pts)
    dist, nb = tree.query(pts, k=kk + 1, distance_upper_bound=radius)
    dist, nb = dist[:, 1:], nb[:, 1:]
    ok = np.isfinite(dist) & (nb != np.arange(n)[:, None])
    if not ok.any():
        return sp.csr_matrix((n, n))
    src = np.broadcast_to(np.arange(n)[:, None], ok.shape)[ok]
    dst = nb[ok]
    d = dist[ok]
    s = float(np.median(d))
    if s <= 0:  # most neighbours coincide: any positive length keeps them joined
        s = float(radius)
    weight = np.exp(-((d / s) ** 2))
    if coplanar:
        normal, thin, flat = local_planes(pts, np.asarray(scales, np.float64), quats, tree=tree)
        weight *= np.exp(-0.5 * _plane_offsets(pts, normal, thin, flat, src, dst))
    graph = sp.csr_matrix((weight, (src, dst)), shape=(n, n))
    graph = graph.maximum(graph.T).tocsr()
    graph.eliminate_zeros()
    return graph


#: The least agreement an edge's two features count as (:func:`feature_weighted`): a floor
#: seen only through a table top has features that lean to the table, and the surface it
#: continues must still carry the floor's label to it. Set on the dev scenes with the
#: power: 0 (disagreeing features cut the edge) cost the synthetic rooms 0.004-0.008 PQ.
MIN_AGREEMENT = 0.1


#: Edges whose weight factor (feature agreement, colour) is computed at once (bounds the
#: memory of a dense graph).
EDGE_BLOCK = 1 << 20


def feature_weighted(
    graph: sp.spmatrix, features: np.ndarray, power: float, known: np.ndarray | None = None
) -> sp.csr_matrix:
    """``graph`` (N, N) with each edge ``(i, j)`` times
    ``max(MIN_AGREEMENT, f_i·f_j) ** power`` for the (N, C) unit ``features``. ``known``
    (N,) bool: the Gaussians whose features mean something (some mask supervised them);
    an edge with an end outside it keeps its weight.

    >>> g = sp.csr_matrix(np.array([[0., 1, 1, 1], [1, 0, 0, 0], [1, 0, 0, 0], [1, 0, 0, 0]]))
    >>> f = np.array([[1., 0], [0.6, 0.8], [-1, 0], [0, 0]])
    >>> feature_weighted(g, f, 1.0, np.array([True, True, True, False])).toarray()
    array([[0. , 0.6, 0.1, 1. ],
           [0.6, 0. , 0. , 0. ],
           [0.1, 0. , 0. , 0. ],
           [1. , 0. , 0. , 0. ]])
    """
    coo = sp.coo_matrix(graph)
    f = np.asarray(features)
    agree = _per_edge(coo, lambda rows, cols: np.einsum(
        "ij,ij->i", f[rows].astype(np.float64), f[cols].astype(np.float64)))  # fmt: skip
    agree = np.clip(agree, MIN_AGREEMENT, None) ** power
    if known is not None:
        known = np.asarray(known, dtype=bool)
        agree[~(known[coo.row] & known[coo.col])] = 1.0
    return _scaled(coo, agree)


def colour_weighted(graph: sp.spmatrix, colors: np.ndarray, sigma: float) -> sp.csr_matrix:
    """``graph`` (N, N) with each edge ``(i, j)`` times ``exp(-(dE / sigma)**2 / 2)``,
    ``dE`` the CIELAB (D65) distance of the (N, 3) sRGB ``colors`` (in [0, 1]) of ``i`` and
    ``j``; ``sigma`` > 0.

    Two greys 20 apart keep 0.63 of their edge; grey and red (80 apart), nothing visible:

    >>> g = sp.csr_matrix(np.array([[0.0, 1, 1], [1, 0, 0], [1, 0, 0]]))
    >>> rgb = np.array([[0.5, 0.5, 0.5], [0.7, 0.7, 0.7], [0.9, 0.2, 0.2]])
    >>> colour_weighted(g, rgb, 20.0).toarray().round(2)
    array([[0.  , 0.63, 0.  ],
           [0.63, 0.  , 0.  ],
           [0.  , 0.  , 0.  ]])
    """
    coo = sp.coo_matrix(graph)
    lab = srgb_to_lab(np.asarray(colors, dtype=np.float64))
    d2 = _per_edge(coo, lambda rows, cols: ((lab[rows] - lab[cols]) ** 2).sum(axis=1))
    return _scaled(coo, np.exp(-0.5 * d2 / float(sigma) ** 2))


def _per_edge(coo: sp.coo_matrix, of: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> np.ndarray:
    """(nnz,) float64 ``of(rows, cols)`` for the edges of ``coo``, :data:`EDGE_BLOCK` edges
    at a time: both ends' features for every edge at once took 6 GiB on 1.46 M
    Gaussians."""
    out = np.empty(coo.nnz, dtype=np.float64)
    for a in range(0, coo.nnz, EDGE_BLOCK):
        rows, cols = coo.row[a : a + EDGE_BLOCK], coo.col[a : a + EDGE_BLOCK]
        out[a : a + rows.size] = of(rows, cols)
    return out


def _scaled(coo: sp.coo_matrix, factor: np.ndarray) -> sp.csr_matrix:
    """``coo`` with each edge's weight times ``factor`` (nnz,), as CSR without zeros."""
    out = sp.csr_matrix((coo.data * factor, (coo.row, coo.col)), shape=coo.shape)
    out.eliminate_zeros()
    return out


#: Centres (the Gaussian's own among them) whose principal axes give a Gaussian without a
#: shape of its own its plane (:func:`local_planes`). Set on scene0000_00 (spheres at its
#: mesh's vertices): 8 raised PQ from 0.782 to 0.793 (exact masks) and 0.733 to 0.742
#: (default noise); 16 gave 0.786 / 0.737. The synthetic rooms' discs keep their own.
PLANE_NEIGHBORS = 8

#: The least thickness of a plane taken from neighbours, in median Gaussian sizes (the
#: largest axis): centres that lie exactly in a plane are no surface thinner than the
#: Gaussians that make it.
MIN_THICKNESS = 0.25

#: Gaussians whose neighbourhoods' principal axes are computed at once (bounds memory).
PLANE_BLOCK = 1 << 17


def local_planes(
    means: np.ndarray,
    scales: np.ndarray,
    quats: np.ndarray | None,
    *,
    tree: cKDTree | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each Gaussian's plane: (N, 3) unit normal, (N,) thickness and (N,) flatness in
    [0, 1], ``clip(2 (1 - thickness / width), 0, 1)`` (module docstring, step 1).

    A Gaussian's own plane is its thinnest axis, its thinnest and middle scales the
    thickness and width (none without ``quats``: a sphere). Its neighbours' plane is that
    of the principal axes of the :data:`PLANE_NEIGHBORS` nearest centres (standard
    deviations along them), the thickness at least :data:`MIN_THICKNESS` median sizes.
    The flatter of the two is used; a Gaussian already fully flat (a disc at most half as
    thick as it is wide) keeps its own without its neighbours being looked up. ``tree``:
    a ``cKDTree`` of ``means`` already built.

    >>> grid = np.array([[x, y, 0.0] for x in range(3) for y in range(3)])
    >>> normal, thin, flat = local_planes(grid, np.full((9, 3), 0.5), None)
    >>> np.abs(normal[4]).round(6).tolist(), float(flat[4])
    ([0.0, 0.0, 1.0], 1.0)
    """
    pts = np.asarray(means, dtype=np.float64)
    sc = np.asarray(scales, dtype=np.float64)
    n = pts.shape[0]
    order = np.argsort(sc, axis=1)
    own = np.take_along_axis(sc, order, axis=1)
    thin, width = own[:, 0].copy(), own[:, 1].copy()
    if quats is None:
        normal, flat = np.zeros((n, 3)), np.zeros(n)
    else:
        rot = quat_to_rotmat(np.asarray(quats))
        normal = rot[np.arange(n), :, order[:, 0]]  # column of the thinnest axis
        flat = _flatness(thin, width)
    k = min(PLANE_NEIGHBORS, n)
    size = float(np.median(sc.max(axis=1))) if n else 0.0
    if k < 3 or not (np.isfinite(size) and size > 0):
        return normal, thin, flat
    open_ = np.flatnonzero(flat < 1.0)  # no neighbourhood is flatter than 1
    if open_.size == 0:
        return normal, thin, flat
    search = tree if tree is not None else cKDTree(pts)
    for a in range(0, open_.size, PLANE_BLOCK):
        block = open_[a : a + PLANE_BLOCK]
        _, nb = search.query(pts[block], k=k)
        centred = pts[nb] - pts[nb].mean(axis=1, keepdims=True)
        var, axes = np.linalg.eigh(np.einsum("nki,nkj->nij", centred, centred) / k)
        sd = np.sqrt(np.clip(var, 0.0, None))  # ascending
        their_thin = np.maximum(sd[:, 0], MIN_THICKNESS * size)
        their_flat = _flatness(their_thin, sd[:, 1])
        use = their_flat > flat[block]
        rows = block[use]
        normal[rows] = axes[use, :, 0]
        thin[rows], width[rows], flat[rows] = their_thin[use], sd[use, 1], their_flat[use]
    return normal, thin, flat


def _flatness(thin: np.ndarray, width: np.ndarray) -> np.ndarray:
    """``clip(2 (1 - thin / width), 0, 1)``; 0 where the width is 0."""
    ratio = np.divide(thin, width, out=np.ones_like(thin), where=width > 0)
    return np.clip(2.0 * (1.0 - ratio), 0.0, 1.0)


def _plane_offsets(
    pts: np.ndarray,
    normal: np.ndarray,
    thin: np.ndarray,
    flat: np.ndarray,
    src: np.ndarray,
    dst: np.ndarray,
) -> np.ndarray:
    """``e`` of the module docstring for the edges ``src -> dst`` (0 between spheres)."""
    delta = pts[dst] - pts[src]
    thick2 = thin[src] ** 2 + thin[dst] ** 2
    off2 = (flat[src] * np.einsum("ij,ij->i", normal[src], delta) ** 2
            + flat[dst] * np.einsum("ij,ij->i", normal[dst], delta) ** 2)  # fmt: skip
    e = np.full(src.size, np.inf)
    np.divide(off2, thick2, out=e, where=thick2 > 0)
    e[(thick2 <= 0) & (off2 == 0)] = 0.0  # zero-thickness discs exactly in one plane
    return e


def harmonic_labels(graph: sp.spmatrix, labels: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """Labels of the non-fixed nodes by the harmonic function on ``graph`` (step 2).

    ``graph`` (N, N) weights (a weight that is not finite and positive is no edge);
    ``labels`` (N,) int; ``fixed`` (N,) bool: nodes whose label (>= 0) is kept and spread.
    Returns a copy of ``labels`` in which every non-fixed node of a graph component holding
    a fixed node takes the entity a random walk from it most likely reaches first (ties:
    the smaller label). Never raises on degenerate graphs (module docstring).
    """
    labels = np.asarray(labels, dtype=np.int64)
    fixed = np.asarray(fixed, dtype=bool) & (labels >= 0)
    out = labels.copy()
    free = np.flatnonzero(~fixed)
    known = np.flatnonzero(fixed)
    if free.size == 0 or known.size == 0:
        return out
    rows = edge_weights(graph)[free]
    w_ff = rows[:, free].tocsr()
    boundary = rows[:, known].tocsr()
    n_comp, comp = connected_components(w_ff, directed=False)
    touches = np.zeros(n_comp, dtype=bool)
    touches[comp[np.asarray(boundary.sum(axis=1)).ravel() > 0]] = True
    solve = np.flatnonzero(touches[comp])
    if solve.size == 0:
        return out
    n_labels = int(labels[known].max()) + 1
    onehot = sp.csr_matrix(
        (np.ones(known.size), (np.arange(known.size), labels[known])),
        shape=(known.size, n_labels),
    )
    degree = np.asarray(rows[solve].sum(axis=1)).ravel()
    laplacian = sp.diags(degree) - w_ff[solve][:, solve]
    best = absorbing_labels(laplacian, boundary[solve] @ onehot, degree, comp[solve])
    reached = best.label >= 0
    out[free[solve[reached]]] = best.label[reached]
    return out


def edge_weights(graph: sp.spmatrix) -> sp.csr_matrix:
    """``graph`` as float64 CSR without its non-edges (weights not finite and positive),
    scaled by a power of two (exactly) so that its largest weight lies in [0.5, 1): a
    graph of tiny or huge weights then neither underflows nor overflows in the solve."""
    weights = sp.csr_matrix(graph, dtype=np.float64, copy=True)
    weights.data[~(np.isfinite(weights.data) & (weights.data > 0))] = 0.0
    weights.eliminate_zeros()
    if weights.nnz:
        weights.data = np.ldexp(weights.data, -int(np.frexp(weights.data.max())[1]))
    return weights
