#!/usr/bin/env python3
"""The command's wall time, two builds side by side: `subwave compress` and
`decompress` of meshes from ../shared/corpus, the two binaries alternating, medians.

    python3 benches/cli_times.py OLD_SUBWAVE NEW_SUBWAVE [--runs 9]

(OLD_SUBWAVE, say, from `git worktree add /tmp/base COMMIT` and `CARGO_TARGET_DIR=
/tmp/base_target cargo build --release -p subwave-cli` there.) Prints a markdown table
for benches/RESULTS.md. Each run is a fresh process with the CLI's default threads, its
output written to a temporary folder; both binaries' outputs are compared byte for byte
(a difference is reported and the script exits 1).
"""
import os, statistics, subprocess, sys, tempfile, time

HERE = os.path.dirname(os.path.abspath(__file__))
SHARED = os.path.join(HERE, "..", "..", "shared", "corpus")


def main():
    args = sys.argv[1:]
    runs = 9
    if "--runs" in args:
        i = args.index("--runs")
        runs = int(args[i + 1])
        del args[i : i + 2]
    if len(args) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    old, new = (os.path.abspath(a) for a in args)
    same = True
    with tempfile.TemporaryDirectory() as tmp:
        t = lambda name: os.path.join(tmp, name)
        meshes = [
            ("bunny_cc4.obj", os.path.join(SHARED, "bunny_cc4.obj")),
            ("armadillo_cc5.obj", os.path.join(SHARED, "armadillo_cc5.obj")),
            ("still_life.obj (Blender)", os.path.join(SHARED, "blender", "still_life.obj")),
        ]
        cases = []
        for name, path in meshes:
            cases.append((f"compress {name}", ["compress", path, "{out}.swv", "-f", "-q"], ".swv"))
            subprocess.run([new, "compress", path, t(name[:5] + ".swv"), "-f", "-q"], check=True)
            cases.append((f"decompress {name} -> OBJ", ["decompress", t(name[:5] + ".swv"), "{out}.obj", "-f", "-q"], ".obj"))
        print("| run | old | new | change |")
        print("|---|---:|---:|---:|")
        for name, argv, ext in cases:
            times = {old: [], new: []}
            for _ in range(runs):
                for b in (old, new):
                    out = t("old" if b == old else "new")
                    a = time.perf_counter()
                    subprocess.run([b] + [x.replace("{out}", out) for x in argv], check=True)
                    times[b].append((time.perf_counter() - a) * 1e3)
            if open(t("old") + ext, "rb").read() != open(t("new") + ext, "rb").read():
                print(f"{name}: the two binaries' outputs differ", file=sys.stderr)
                same = False
            mo, mn = statistics.median(times[old]), statistics.median(times[new])
            print(f"| {name} | {mo:.1f} ms | {mn:.1f} ms | {(mn / mo - 1) * 100:+.0f} % |")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
