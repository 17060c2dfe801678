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
import os, sys
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import finest

corpus, name, Q, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
m = finest.load(corpus, name, Q)
X, F = m.X, m.F
os.makedirs(out, exist_ok=True)
with open(f'{out}/{name}.full.obj', 'w') as o:
    o.writelines('v %d %d %d\n' % tuple(x) for x in X)
    o.writelines('f ' + ' '.join(str(i + 1) for i in q) + '\n' for q in F)
with open(f'{out}/{name}.coarser.obj', 'w') as o:
    o.writelines('v %d %d %d\n' % tuple(X[i]) for i in range(m.ov, m.ov + m.nv))
    for f in range(m.of, m.of + m.nf):
        o.write('f ' + ' '.join(str(i - m.ov + 1) for i in m.corners[f]) + '\n')
print(f'{name}: {len(X)} vertices -> {m.nv} vertices, {m.nf} faces')
