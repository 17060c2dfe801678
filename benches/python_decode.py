#!/usr/bin/env python3
"""subwave.decompress beside DracoPy.decode (issue 33), in one process, one thread,
alternating runs, medians.

Each mesh is quantised to Draco's 16-bit grid by both (subwave `bits=16`; DracoPy
`quantization_bits=16`, compression level 10, triangles: quads split in two), then each
container is decoded `--repeats` times, subwave and Draco alternating. Prints a table
(milliseconds, container bytes) and the medians' ratio; `--markdown` prints it for
benches/RESULTS.md.

    pip install ./python DracoPy==2.2.0
    python3 benches/python_decode.py [MESH...] [--repeats 15] [--markdown]

Without meshes: armadillo_cc5, bunny_cc4 and jacksboro_grid257 of ../shared/corpus.
"""
import argparse
import os
import statistics
import sys
import time

import numpy as np

import subwave

HERE = os.path.dirname(os.path.abspath(__file__))
SHARED = os.path.join(HERE, "..", "..", "shared", "corpus")
DEFAULT = ["armadillo_cc5.obj", "bunny_cc4.obj", "jacksboro_grid257.obj"]


def triangles(mesh):
    flat, off = mesh.flat_faces, mesh.face_offsets
    return np.array(
        [
            (flat[off[i]], flat[off[i] + j], flat[off[i] + j + 1])
            for i in range(len(off) - 1)
            for j in range(1, off[i + 1] - off[i] - 1)
        ],
        dtype=np.uint32,
    )


def side_by_side(paths, repeats, encode=False):
    """Per mesh: (name, vertices, subwave bytes, Draco bytes, subwave decode ms, Draco
    decode ms, decode speed ratio, subwave encode ms, Draco encode ms, encode speed
    ratio, subwave decode ms on two threads, its speed ratio); medians of `repeats`
    alternating runs, one thread unless said. Encode times only with `encode` (else
    None)."""
    import DracoPy

    rows = []
    for path in paths:
        mesh = subwave.read(path)
        tris = triangles(mesh)
        v32 = mesh.vertices.astype(np.float32)
        enc = {
            "subwave": lambda: subwave.compress(
                mesh.vertices, mesh.flat_faces, face_offsets=mesh.face_offsets, bits=16, threads=1
            ),
            "draco": lambda: DracoPy.encode(v32, tris, quantization_bits=16, compression_level=10),
        }
        swv, drc = enc["subwave"](), enc["draco"]()
        dec = {
            "subwave": lambda: subwave.decompress(swv),
            "draco": lambda: DracoPy.decode(drc),
            "subwave2": lambda: subwave.decompress(swv, threads=2),
        }
        times = {(k, n): [] for k in ("dec", "enc") for n in ("subwave", "draco", "subwave2")}
        for _ in range(repeats):
            for name in ("subwave", "draco", "subwave2"):
                for kind, fns in (("dec", dec), ("enc", enc)):
                    if kind == "enc" and (not encode or name not in fns):
                        continue
                    t = time.perf_counter()
                    fns[name]()
                    times[(kind, name)].append((time.perf_counter() - t) * 1e3)
        med = {k: statistics.median(v) if v else None for k, v in times.items()}
        s, d = med[("dec", "subwave")], med[("dec", "draco")]
        es, ed = med[("enc", "subwave")], med[("enc", "draco")]
        s2 = med[("dec", "subwave2")]
        rows.append(
            (os.path.basename(path), len(mesh.vertices), len(swv), len(drc), s, d, d / s, es, ed, ed / es if encode else None, s2, d / s2)
        )
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("meshes", nargs="*")
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args()
    paths = args.meshes or [os.path.join(SHARED, m) for m in DEFAULT]
    rows = side_by_side(paths, args.repeats)
    if args.markdown:
        print("| mesh | vertices | subwave bytes | Draco cl10 bytes | subwave.decompress ms | DracoPy.decode ms | speed vs Draco |")
        print("|---|---:|---:|---:|---:|---:|---:|")
        for r in rows:
            print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]:.1f} | {r[5]:.1f} | {r[6]:.2f} x |")
    else:
        print(f"{'mesh':28} {'verts':>8} {'swv B':>9} {'drc B':>9} {'swv ms':>8} {'drc ms':>8} {'speed':>6}")
        for r in rows:
            print(f"{r[0]:28} {r[1]:8} {r[2]:9} {r[3]:9} {r[4]:8.1f} {r[5]:8.1f} {r[6]:5.2f}x")
    speeds = [r[6] for r in rows]
    print(f"median speed vs DracoPy: {statistics.median(speeds):.2f} x", file=sys.stderr)


if __name__ == "__main__":
    main()
