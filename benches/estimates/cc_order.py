#!/usr/bin/env python3
"""Estimate (not the codec): what coding a Catmull-Clark level's face points before its
edge points would save on the finest level of a corpus mesh.

    python3 benches/estimates/cc_order.py ../shared/corpus bunny_cc4 [BITS] [--no-centroids]

Needs numpy. Reads NAME.obj (production vertex order, `vef` or `fev`) and its
`level_stats` from manifest.json, quantises on Draco's grid (float32, as --bits does),
and compares two orders of the finest level's details, each predicted by least squares
(fitted per axis of a float frame: the normal, the edge or face diagonal, their cross
product) from what the decoder would have:

* A, edges first (the codec's order): an edge point from its ends, the vertices beyond
  them on its mesh line (interp4's stencil) and its two coarse faces' centroids (left
  out with --no-centroids, which often codes smaller in this measure); a face
  point from its corners and its (decoded) fine edge points.
* B, faces first: a face point from its corners, the centroids of the faces beyond its
  edges and the edge predictions of A (coarse only); an edge point from A's terms and
  its two (decoded) fine face points.

Cost: the order-0 entropy of each rounded residual component, in bytes; only interior
edges and quad faces count. The codec's adaptive contexts code both smaller; the ratio
B / A is the estimate.
"""
import collections, os, sys
import numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import finest

args = [a for a in sys.argv[1:] if not a.startswith('--')]
corpus, name = args[0], args[1]
Q = int(args[2]) if len(args) > 2 else 16
centroids = '--no-centroids' not in sys.argv
m = finest.load(corpus, name, Q)
X = m.X.astype(float)
ne, oe, of, nf = m.ne, m.oe, m.of, m.nf
ends, efaces, fedges, corners = m.ends, m.efaces, m.fedges, m.corners
edge_of = {frozenset(ends[e]): e for e in range(oe, oe + ne)}
vedges = collections.defaultdict(list)
for e in range(oe, oe + ne):
    for a in ends[e]:
        vedges[a].append(e)

def beyond(e, a):
    """The vertex beyond a on e's mesh line (a interior, four edges, quads beside e)."""
    if len(vedges[a]) != 4 or len(efaces[e]) != 2:
        return None
    side = set()
    for f in efaces[e]:
        cyc = corners[f]
        if len(cyc) != 4:
            return None
        i = cyc.index(a)
        for n in (cyc[i - 1], cyc[(i + 1) % 4]):
            side.add(edge_of[frozenset((a, n))])
    opp = [g for g in vedges[a] if g != e and g not in side]
    if len(opp) != 1 or any(len(efaces[g]) != 2 for g in vedges[a]):
        return None
    return next(u for u in ends[opp[0]] if u != a)

cen = lambda f: X[corners[f]].mean(0)
E, ab, bb, cc, ff = [], [], [], [], []
for e in range(oe, oe + ne):
    if len(efaces[e]) != 2:
        continue
    a, b = sorted(ends[e])
    a2, b2 = beyond(e, a), beyond(e, b)
    if a2 is None or b2 is None:
        continue
    E.append(e); ab.append(X[a] + X[b]); bb.append(X[a2] + X[b2])
    f1, f2 = sorted(efaces[e]); cc.append(cen(f1) + cen(f2)); ff.append(X[f1] + X[f2])
ab, bb, cc, ff = map(np.array, (ab, bb, cc, ff))
yE = X[E]
A_ = np.array([X[sorted(ends[e])[0]] for e in E]); B_ = np.array([X[sorted(ends[e])[1]] for e in E])
c1 = np.array([cen(sorted(efaces[e])[0]) for e in E]); c2 = np.array([cen(sorted(efaces[e])[1]) for e in E])
unit = lambda v: v / np.linalg.norm(v, axis=1)[:, None]
t = unit(B_ - A_); n = unit(np.cross(t, c1 - c2)); s = np.cross(n, t)
edge_frame = (n, t, s)

def fit(frame, feats, y):
    """Least-squares prediction per frame axis; returns the residual's bytes per axis."""
    out = []
    for d in frame:
        A = np.stack([(f * d).sum(1) for f in feats] + [np.ones(len(y))], 1)
        yy = (y * d).sum(1)
        w, *_ = np.linalg.lstsq(A, yy, rcond=None)
        r = np.round(yy - A @ w).astype(np.int64)
        _, cnt = np.unique(r, return_counts=True)
        out.append(-(cnt * np.log2(cnt / cnt.sum())).sum() / 8)
    return out

# A's coarse-only edge prediction (for B's faces).
def predict(frame, feats, y):
    p = np.zeros(y.shape)
    for d in frame:
        A = np.stack([(f * d).sum(1) for f in feats] + [np.ones(len(y))], 1)
        w, *_ = np.linalg.lstsq(A, (y * d).sum(1), rcond=None)
        p += (A @ w)[:, None] * d
    return p
a_terms = [ab, bb, cc] if centroids else [ab, bb]
pe = dict(zip(E, predict(edge_frame, a_terms, yE)))

FI = [f for f in range(of, of + nf) if len(corners[f]) == 4 and all(e in pe for e in fedges[f])]
yF = X[FI]
cor = np.array([X[corners[f]].mean(0) for f in FI])
fed = np.array([X[list(fedges[f])].mean(0) for f in FI])
fpe = np.array([np.mean([pe[e] for e in fedges[f]], 0) for f in FI])
def nbr(f):
    g = [h for e in fedges[f] for h in efaces[e] if h != f]
    return np.mean([cen(h) for h in g], 0)
fnb = np.array([nbr(f) for f in FI])
fr = []
for f in FI:
    P = X[corners[f]] - X[corners[f]].mean(0)
    _, _, vt = np.linalg.svd(P)
    fr.append(vt)
fr = np.array(fr)
face_frame = (fr[:, 2], fr[:, 0], fr[:, 1])

rows = {
    'A edges': fit(edge_frame, a_terms, yE),
    'A faces': fit(face_frame, [cor, fed], yF),
    'B edges': fit(edge_frame, a_terms + [ff], yE),
    'B faces': fit(face_frame, [cor, fnb, fpe], yF),
}
print(f'{name} Q{Q}: {len(E)} interior edges, {len(FI)} quads (normal, tangent, cross; bytes)')
for k, v in rows.items():
    print(f'  {k}: ' + ' '.join('%8.0f' % x for x in v) + '  = %8.0f' % sum(v))
a = sum(rows['A edges']) + sum(rows['A faces'])
b = sum(rows['B edges']) + sum(rows['B faces'])
print(f'  A {a:.0f}  B {b:.0f}  B / A = {b / a:.3f}')

# The fitting's tangential relaxation: how far an interior edge point lies along its edge
# from its coarse edge's midpoint, and from the mean of its four fine neighbours (standard
# deviations in grid steps).
mid = ab / 2
nbr4 = (ab + ff) / 4
sd = lambda p: np.std(((yE - p) * t).sum(1))
print(f'  along-edge residual (std, steps): from the midpoint {sd(mid):.1f}, '
      f'from the four neighbours {sd(nbr4):.1f}')
