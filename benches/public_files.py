#!/usr/bin/env python3
"""Public files survey (issue 35): every OBJ, PLY, OFF and STL under the folders given
(e.g. copies of trimesh's models/ and libigl-tutorial-data), in the default mode and
with --keep-order.

For each file: `subwave verify --json` (compress + decompress in memory, exact values),
then `compress --keep-order` + `decompress` and a byte comparison with the input.
Prints one line per file and a summary; `--json OUT` also writes the rows.

    python3 benches/public_files.py DIR... [--json rows.json]
"""
import json, os, subprocess, sys, tempfile, time

EXTS = (".obj", ".ply", ".off", ".stl")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "subwave")


def run(args, timeout=600):
    t = time.time()
    p = subprocess.run([BIN, "-q", *args], capture_output=True, timeout=timeout)
    return p, time.time() - t


def survey(path, tmp):
    row = {"file": path, "bytes": os.path.getsize(path)}
    p, secs = run(["verify", path, "--json"])
    row["secs"] = round(secs, 2)
    if p.returncode != 0:
        row["default"] = "refused"
        row["why"] = p.stderr.decode(errors="replace").strip().splitlines()[-1:] or [""]
        row["why"] = row["why"][0]
    else:
        v = json.loads(p.stdout)
        row["default"] = "exact" if v.get("exact") else "NOT EXACT"
        row["vertices"] = v.get("vertices")
        row["swv"] = v.get("bytes")
    ext = os.path.splitext(path)[1].lower()
    swv, out = os.path.join(tmp, "k.swv"), os.path.join(tmp, "k" + ext)
    p, _ = run(["-f", "compress", path, swv, "--keep-order"])
    if p.returncode != 0:
        row["keep_order"] = "refused"
    else:
        p, _ = run(["-f", "decompress", swv, out])
        if p.returncode != 0:
            row["keep_order"] = "decode failed"
        else:
            same = open(path, "rb").read() == open(out, "rb").read()
            row["keep_order"] = "same bytes" if same else "DIFFERENT BYTES"
            row["swv_keep_order"] = os.path.getsize(swv)
    return row


def main():
    args = sys.argv[1:]
    out_json = None
    if "--json" in args:
        i = args.index("--json")
        out_json = args[i + 1]
        del args[i : i + 2]
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "subwave-cli"], cwd=ROOT, check=True)
    files = sorted(
        os.path.join(d, f)
        for top in args
        for d, _, fs in os.walk(top)
        for f in fs
        if f.lower().endswith(EXTS)
    )
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for f in files:
            r = survey(f, tmp)
            rows.append(r)
            print(f"{r['default']:9} {r['keep_order']:15} {r['bytes']:>10} {f}"
                  + (f"  ({r['why']})" if "why" in r else ""), flush=True)
    n = len(rows)
    ok = sum(r["default"] == "exact" for r in rows)
    same = sum(r["keep_order"] == "same bytes" for r in rows)
    print(f"{n} files: {ok} exact in the default mode, {same} the same bytes with --keep-order")
    if out_json:
        with open(out_json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
