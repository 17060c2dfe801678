"""A corpus mesh's finest Catmull-Clark level, for the estimates beside this file: the
positions on Draco's grid (float32, as `subwave compress --bits` quantises) and the
coarse mesh recovered from the fine quads of the production vertex order."""
import collections, json
from types import SimpleNamespace
import numpy as np


def load(corpus, name, bits):
    man = {m['name']: m for m in json.load(open(f'{corpus}/manifest.json'))['meshes']}[name]
    V, F = [], []
    for line in open(f'{corpus}/{name}.obj'):
        if line.startswith('v '):
            V.append([float(t) for t in line.split()[1:4]])
        elif line.startswith('f '):
            F.append([int(t.split('/')[0]) - 1 for t in line.split()[1:]])
    V = np.array(V, dtype=np.float32)
    mn = V.min(0)
    step = np.float32((V.max(0) - mn).max() / np.float32(2 ** bits - 1))
    X = np.floor((V - mn) / step + np.float32(0.5)).astype(np.int64)
    c = man['level_stats'][-2]
    nv, ne, nf = c['V'], c['E'], c['F']
    # Old vertices, edge points, face points: `vef` or `fev` (manifest.json).
    if man['vertex_order'] == 'vef':
        ov, oe, of = 0, nv, nv + ne
    else:
        of, oe, ov = 0, nf, nf + ne
    kind = lambda i: 'v' if ov <= i < ov + nv else ('e' if oe <= i < oe + ne else 'f')
    ends = collections.defaultdict(set)    # edge point -> its coarse ends
    efaces = collections.defaultdict(set)  # edge point -> its face points
    fedges = collections.defaultdict(set)  # face point -> its edge points
    quads = []                             # fine quads from their old vertex
    for q in F:
        j = [kind(i) for i in q].index('v')
        q = q[j:] + q[:j]
        quads.append(q)
        v, e1, f, e2 = q
        ends[e1].add(v); ends[e2].add(v)
        efaces[e1].add(f); efaces[e2].add(f)
        fedges[f].update([e1, e2])
    # A coarse face's corners in order: from each corner, across the edge point after it.
    succ = collections.defaultdict(dict)
    for v, e1, f, e2 in quads:
        succ[f][v] = next(u for u in ends[e1] if u != v)
    corners = {}
    for f in range(of, of + nf):
        s = succ[f]; start = min(s); cyc = [start]
        while s[cyc[-1]] != start:
            cyc.append(s[cyc[-1]])
        corners[f] = cyc
    return SimpleNamespace(X=X, F=F, nv=nv, ne=ne, nf=nf, ov=ov, oe=oe, of=of,
                           ends=ends, efaces=efaces, fedges=fedges, corners=corners)
