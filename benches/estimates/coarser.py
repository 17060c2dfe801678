#!/usr/bin/env python3
"""Writes a corpus mesh and its level L-1 (the fine mesh's old vertices, which keep
their positions, and the coarse faces) as integer OBJ files on the full mesh's Draco
grid, so that `subwave compress` (exact mode) codes both on the same grid:

    python3 benches/estimates/coarser.py ../shared/corpus camelhead_cc4 16 /tmp/est

writes /tmp/est/camelhead_cc4.full.obj and /tmp/est/camelhead_cc4.coarser.obj. Needs
numpy. Used to estimate what a transform chosen per level would give: the finest level
coded by one transform (its LEVL section in the full mesh's container) plus the coarser
mesh coded by `auto` (benches/RESULTS.md, 'Estimates after format 26').
"""
import collections, json, os, sys
import numpy as np

corpus, name, Q, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
man = {m['name']: m for m in json.load(open(f'{corpus}/manifest.json'))['meshes']}[name]
V, F = [], []
for line in open(f'{corpus}/{name}.obj'):
    if line.startswith('v '):
        V.append([float(t) for t in line.split()[1:4]])
    elif line.startswith('f '):
        F.append([int(t.split('/')[0]) - 1 for t in line.split()[1:]])
V = np.array(V, dtype=np.float32)
mn = V.min(0)
step = np.float32((V.max(0) - mn).max() / np.float32(2 ** Q - 1))
X = np.floor((V - mn) / step + np.float32(0.5)).astype(np.int64)

c = man['level_stats'][-2]
nv, ne, nf = c['V'], c['E'], c['F']
if man['vertex_order'] == 'vef':
    ov, oe, of = 0, nv, nv + ne
else:
    of, oe, ov = 0, nf, nf + ne
kind = lambda i: 'v' if ov <= i < ov + nv else ('e' if oe <= i < oe + ne else 'f')
ends = collections.defaultdict(set)
quads = []
for q in F:
    j = [kind(i) for i in q].index('v')
    q = q[j:] + q[:j]
    quads.append(q)
    ends[q[1]].add(q[0]); ends[q[3]].add(q[0])
succ = collections.defaultdict(dict)
for v, e1, f, e2 in quads:
    succ[f][v] = next(u for u in ends[e1] if u != v)
os.makedirs(out, exist_ok=True)
with open(f'{out}/{name}.full.obj', 'w') as o:
    o.writelines('v %d %d %d\n' % tuple(x) for x in X)
    o.writelines('f ' + ' '.join(str(i + 1) for i in q) + '\n' for q in F)
with open(f'{out}/{name}.coarser.obj', 'w') as o:
    o.writelines('v %d %d %d\n' % tuple(X[i]) for i in range(ov, ov + nv))
    for f in range(of, of + nf):
        s = succ[f]; start = min(s); cyc = [start]
        while s[cyc[-1]] != start:
            cyc.append(s[cyc[-1]])
        o.write('f ' + ' '.join(str(i - ov + 1) for i in cyc) + '\n')
print(f'{name}: {len(X)} vertices -> {nv} vertices, {nf} faces')
