#!/usr/bin/env python3
"""Measure subwave on meshes and put the numbers beside the peers' (Draco, meshoptimizer,
zstd, xz) from a peers CSV written by ../shared/tools/peers/peers.py.

    python3 benches/compare.py ../shared/corpus --bits 16,12 \
        --peers ../shared/corpus/peers/peers-q16-q12.csv --out benches/results.md

Runs `subwave verify --json --threads 1 --geometry-only` (positions and faces, as the
peers code them; in-memory encode/decode, exactness check; one thread, as issue 4's
speed targets are measured) and, with
--keep-order, `subwave compress --keep-order` for the cost of the stored order.

    python3 benches/compare.py --speed [MESH...] [--repeats 15]

times subwave (the Python package, `pip install ./python`) and Draco cl10 (DracoPy) side
by side in this process at 16 bits, encode and decode alternating, one thread (and a decode on two), and
prints the medians and ratios as a table for benches/RESULTS.md (default meshes:
armadillo_cc5, bunny_cc4 and jacksboro_grid257 of ../shared/corpus).

    python3 benches/compare.py --whole-files [DIR]

the whole-file table (issue 30) over the OBJ and PLY files of DIR (default
../shared/corpus/blender): the file's size; subwave's `--canonical` container
(positions, faces and attribute channels in canonical order, a file's own lines and
other elements too; number styles and line order dropped) and its `--keep-order`
container, the default for such files (the same
bytes back, checked); `xz -9e` and `zstd -19` of the file; and, as the lossy reference, Draco
cl10 (DracoPy) of the mesh as trimesh loads it (vertices split at UV and normal seams)
with 16-bit positions, 12-bit UVs and 10-bit normals, colours as they are (needs
`pip install DracoPy trimesh scipy pillow numpy`; a file it cannot take shows `-`, the
reason on stderr). Medians of keep-order / xz, canonical / xz and keep-order /
canonical per format.
"""
import argparse, csv, json, os, statistics, subprocess, sys, tempfile

def subwave_bin():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "subwave-cli"], cwd=root, check=True)
    return os.path.join(root, "target", "release", "subwave")

def meshes(paths, shuffled):
    out = []
    for p in paths:
        if os.path.isdir(p):
            for f in sorted(os.listdir(p)):
                if f.endswith((".obj", ".ply", ".off")) and (shuffled or ".shuffled." not in f):
                    out.append(os.path.join(p, f))
        else:
            out.append(p)
    return out

def load_peers(path):
    peers = {}
    if not path:
        return peers
    with open(path) as fh:
        for r in csv.DictReader(fh):
            if r.get("status") == "ok":
                peers[(r["mesh"], int(r["bits"]), r["peer"])] = r
    return peers

def speed(args):
    """Side by side with DracoPy, in process (benches/python_decode.py does the timing)."""
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import python_decode

    paths, repeats = list(args), 15
    if "--repeats" in paths:
        i = paths.index("--repeats")
        repeats = int(paths[i + 1])
        del paths[i : i + 2]
    paths = paths or [os.path.join(python_decode.SHARED, m) for m in python_decode.DEFAULT]
    rows = python_decode.side_by_side(paths, repeats, encode=True)
    print("| mesh | vertices | subwave bytes | Draco cl10 bytes | subwave encode ms | Draco encode ms | encode speed vs Draco | subwave decode ms | Draco decode ms | decode speed vs Draco | subwave decode ms, 2 threads | vs Draco |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[7]:.1f} | {r[8]:.1f} | {r[9]:.2f} x | {r[4]:.1f} | {r[5]:.1f} | {r[6]:.2f} x | {r[10]:.1f} | {r[11]:.2f} x |")
    print(f"\nmedians: encode {statistics.median(r[9] for r in rows):.2f} x, decode {statistics.median(r[6] for r in rows):.2f} x (two threads {statistics.median(r[11] for r in rows):.2f} x) Draco cl10's speed")


def draco_whole(path, raw):
    """Draco cl10 bytes of a file (`raw`, its bytes) as trimesh loads it (None when it
    cannot)."""
    try:
        import DracoPy, numpy as np, trimesh
    except ImportError as e:
        print(f"draco: {e}", file=sys.stderr)
        return None
    try:
        m = trimesh.load(path, process=False, force="mesh")
    except Exception as e:
        print(f"draco: {os.path.basename(path)}: trimesh: {e}", file=sys.stderr)
        return None
    kw = dict(quantization_bits=16, compression_level=10)
    uv = getattr(m.visual, "uv", None)
    if uv is not None and len(uv) == len(m.vertices):
        kw.update(tex_coord=np.asarray(uv, dtype=np.float64), tex_coord_quantization_bits=12)
    has_normals = b"\nvn " in raw if path.endswith(".obj") else b" nx\n" in raw.split(b"end_header")[0]
    if has_normals:
        n = np.asarray(m.vertex_normals, dtype=np.float64)
        if len(n) == len(m.vertices):
            kw.update(normals=n, normal_quantization_bits=10)
    colors = getattr(m.visual, "vertex_colors", None) if m.visual.kind == "vertex" else None
    if colors is not None and len(colors) == len(m.vertices):
        kw.update(colors=np.asarray(colors, dtype=np.uint8))
    try:
        return len(DracoPy.encode(np.asarray(m.vertices), np.asarray(m.faces), **kw))
    except Exception as e:
        print(f"draco: {os.path.basename(path)}: {e}", file=sys.stderr)
        return None


def whole_files(args):
    """The whole-file table: subwave --canonical (positions, faces and attribute
    channels, in canonical order) and --keep-order (the default for these files: the
    file's own bytes), xz, zstd, Draco."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    folder = args[0] if args else os.path.join(root, "..", "shared", "corpus", "blender")
    exe = subwave_bin()
    files = sorted(f for f in os.listdir(folder) if f.endswith((".obj", ".ply")))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in files:
            path = os.path.join(folder, name)
            raw = open(path, "rb").read()
            out = {}
            for tag, extra in [("canonical", ["--canonical"]), ("keep", ["--keep-order"])]:
                swv = os.path.join(tmp, tag + ".swv")
                subprocess.run([exe, "-q", "compress", path, swv, "-f"] + extra, check=True)
                out[tag] = os.path.getsize(swv)
            back = os.path.join(tmp, "back" + os.path.splitext(name)[1])
            subprocess.run([exe, "-q", "decompress", os.path.join(tmp, "keep.swv"), back, "-f"], check=True)
            exact = open(back, "rb").read() == raw
            xz = len(subprocess.run(["xz", "-9e", "-c"], input=raw, capture_output=True, check=True).stdout)
            zst = len(subprocess.run(["zstd", "-19", "-c", "-q"], input=raw, capture_output=True, check=True).stdout)
            rows.append((name, len(raw), out["canonical"], out["keep"], exact, xz, zst, draco_whole(path, raw)))
    print("| file | bytes | subwave --canonical (channels) | subwave --keep-order (default) | same bytes back | xz -9e | zstd -19 | Draco cl10 (q16/12/10, lossy) | keep-order / xz | keep-order / canonical |")
    print("|---|---:|---:|---:|---|---:|---:|---:|---:|---:|")
    for r in rows:
        d = "-" if r[7] is None else str(r[7])
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {'yes' if r[4] else 'NO'} | {r[5]} | {r[6]} | {d} | {r[3] / r[5]:.3f} | {r[3] / r[2]:.3f} |")
    for ext in (".obj", ".ply"):
        sel = [r for r in rows if r[0].endswith(ext)]
        if sel:
            print(f"\n{ext[1:].upper()}: {len(sel)} files, {sum(r[4] for r in sel)} byte-exact; median keep-order / xz -9e "
                  f"{statistics.median(r[3] / r[5] for r in sel):.3f}, --canonical / xz -9e {statistics.median(r[2] / r[5] for r in sel):.3f}, "
                  f"keep-order / canonical {statistics.median(r[3] / r[2] for r in sel):.3f}")
    return 0 if all(r[4] for r in rows) else 1


def main():
    if "--speed" in sys.argv[1:]:
        return speed([a for a in sys.argv[1:] if a != "--speed"])
    if "--whole-files" in sys.argv[1:]:
        return whole_files([a for a in sys.argv[1:] if a != "--whole-files"])
    ap = argparse.ArgumentParser()
    ap.add_argument("paths", nargs="+")
    ap.add_argument("--bits", default="16,12", help="comma list; 'exact' for the file's own values")
    ap.add_argument("--peers", default="")
    ap.add_argument("--peer-names", default="draco_cl10")
    ap.add_argument("--shuffled", action="store_true", help="include .shuffled copies")
    ap.add_argument("--keep-order", action="store_true", help="also measure --keep-order")
    ap.add_argument("--transforms", default="", help="comma list of transforms to measure separately (e.g. lazy,bilinear,bicubic,biquintic); the main column is auto")
    ap.add_argument("--topology", default="", help="only meshes whose manifest topology is in this comma list")
    ap.add_argument("--out", default="")
    a = ap.parse_args()
    exe = subwave_bin()
    peers = load_peers(a.peers)
    names = [n for n in a.peer_names.split(",") if n]
    rows = []
    transforms = [t for t in a.transforms.split(",") if t]
    topo = {}
    for p in a.paths:
        mf = os.path.join(p, "manifest.json")
        if os.path.isdir(p) and os.path.exists(mf):
            for e in json.load(open(mf))["meshes"]:
                topo[e["file"]] = e["topology"]
                topo[e["shuffled_file"]] = e["topology"]
    wanted = set(t for t in a.topology.split(",") if t)
    for mesh in meshes(a.paths, a.shuffled):
        if wanted and topo.get(os.path.basename(mesh)) not in wanted:
            continue
        stem = os.path.basename(mesh).rsplit(".", 1)[0]
        for b in a.bits.split(","):
            # Positions and faces, as the peers code them.
            args = [exe, "-q", "verify", mesh, "--json", "--threads", "1", "--geometry-only"] + ([] if b == "exact" else ["--bits", b])
            r = subprocess.run(args, capture_output=True, text=True)
            if r.returncode != 0:
                print(f"{stem} {b}: FAILED {r.stderr.strip()}", file=sys.stderr)
                continue
            v = json.loads(r.stdout)
            row = {"mesh": stem, "bits": b, "V": v["vertices"], "bytes": v["bytes"], "bpv": v["bits_per_vertex"],
                   "enc_ms": v["encode_ms"], "dec_ms": v["decode_ms"], "exact": v["exact"],
                   "family": v["family"], "transform": v["transform"], "levels": v["levels"]}
            for t in transforms:
                r2 = subprocess.run(args + ["--transform", t], capture_output=True, text=True)
                row["t_" + t] = json.loads(r2.stdout)["bits_per_vertex"] if r2.returncode == 0 else None
            if a.keep_order:
                with tempfile.NamedTemporaryFile(suffix=".swv") as t:
                    subprocess.run([exe, "-q", "-f", "compress", mesh, t.name, "--keep-order"] + ([] if b == "exact" else ["--bits", b]), check=True)
                    row["keep_bpv"] = os.path.getsize(t.name) * 8 / v["vertices"]
            for n in names:
                p = peers.get((stem, int(b), n)) if b != "exact" else None
                row[n] = float(p["bpv"]) if p else None
                if p and n == names[0]:
                    row["ratio"] = row["bpv"] / float(p["bpv"])
                    row["peer_dec_ms"] = float(p["dec_ms"]) if p["dec_ms"] else None
                    row["peer_enc_ms"] = float(p["enc_ms"]) if p["enc_ms"] else None
            rows.append(row)
            print(f"{stem:34s} {b:>5s} {row['bpv']:8.2f} bpv" + (f"  {names[0]} {row[names[0]]:.2f}  ratio {row['ratio']:.3f}" if row.get("ratio") else ""), file=sys.stderr)
    lines = ["| mesh | Q | V | family | levels | subwave bpv (auto) | transform |" + "".join(f" {t} |" for t in transforms) + (" keep-order bpv |" if a.keep_order else "") + "".join(f" {n} bpv |" for n in names) + " ratio | enc ms | dec ms |" + (f" {names[0]} enc ms | {names[0]} dec ms |" if names else ""),
             "|---|---|---|---|---|---|---|" + "---|" * len(transforms) + ("---|" if a.keep_order else "") + "---|" * len(names) + "---|---|---|" + ("---|---|" if names else "")]
    fmt = lambda x, d=2: "-" if x is None else f"{x:.{d}f}"
    for r in rows:
        lines.append(f"| {r['mesh']} | {r['bits']} | {r['V']} | {r['family']} | {r['levels']} | {r['bpv']:.2f} | {r['transform']} |" + "".join(f" {fmt(r.get('t_' + t))} |" for t in transforms) + (f" {r['keep_bpv']:.2f} |" if a.keep_order else "") + "".join(f" {fmt(r.get(n))} |" for n in names) + f" {fmt(r.get('ratio'), 3)} | {r['enc_ms']:.1f} | {r['dec_ms']:.1f} |" + (f" {fmt(r.get('peer_enc_ms'), 1)} | {fmt(r.get('peer_dec_ms'), 1)} |" if names else ""))
    for b in a.bits.split(","):
        rs = [r["ratio"] for r in rows if r["bits"] == b and r.get("ratio")]
        if rs:
            lines.append(f"\nQ{b}: median ratio to {names[0]} over {len(rs)} meshes: {statistics.median(rs):.3f}")
    text = "\n".join(lines) + "\n"
    if a.out:
        with open(a.out, "w") as fh:
            fh.write(text)
    print(text)

if __name__ == "__main__":
    main()
