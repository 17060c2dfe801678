//! The `subwave` command as a user runs it: exit codes, files and pipes, JSON output.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_subwave"))
}

fn corpus(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../corpus")
        .join(name)
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("subwave-cli-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().unwrap()
}

/// `subwave compress input <tmp>/name extra...`, which must succeed: the container.
fn compressed(input: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let swv = tmp(name);
    let mut args = vec!["compress", input.to_str().unwrap(), swv.to_str().unwrap()];
    args.extend_from_slice(extra);
    let o = run(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    swv
}

/// `info`'s level sections in JSON, and its text, for a container.
fn info_levels(swv: &Path) -> (Vec<serde_json::Value>, String) {
    let v = json(&run(&["info", swv.to_str().unwrap(), "--json"]));
    let levels = v["sections"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["kind"] == "LEVL")
        .cloned()
        .collect();
    let out = run(&["info", swv.to_str().unwrap()]);
    (levels, String::from_utf8_lossy(&out.stdout).to_string())
}

fn json(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(&out.stdout)))
}

#[test]
fn compress_decompress_files_is_exact() {
    let input = corpus("cube_cc4.obj");
    let swv = tmp("cube.swv");
    let out = tmp("cube.out.obj");
    let o = run(&[
        "compress",
        input.to_str().unwrap(),
        swv.to_str().unwrap(),
        "--keep-order",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = run(&["decompress", swv.to_str().unwrap(), out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&input).unwrap());
    // Other formats by extension.
    for ext in ["ply", "off"] {
        let p = tmp(&format!("cube.out.{ext}"));
        let o = run(&["decompress", swv.to_str().unwrap(), p.to_str().unwrap()]);
        assert!(o.status.success());
        let m = subwave::load(&std::fs::read(&p).unwrap(), None).unwrap();
        assert_eq!(m.mesh.vertex_count(), 1538);
    }
}

#[test]
fn pipes_work_both_ways() {
    let text = std::fs::read(corpus("mixed_cc2.obj")).unwrap();
    let mut child = bin()
        .args(["compress", "-", "-", "--keep-order"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(&text).unwrap();
    let packed = child.wait_with_output().unwrap();
    assert!(packed.status.success());
    let mut child = bin()
        .args(["decompress", "-", "-", "--format", "obj"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(&packed.stdout)
        .unwrap();
    let back = child.wait_with_output().unwrap();
    assert!(back.status.success());
    assert_eq!(back.stdout, text);
}

/// A reader that stops early (`subwave info FILE | head -1`) closes the pipe: `info`
/// and `verify` end quietly with success, not in a panic.
#[test]
fn a_closed_pipe_ends_info_and_verify_quietly() {
    let swv = compressed(&corpus("mixed_cc2.obj"), "closed_pipe", &[]);
    let swv = swv.to_str().unwrap();
    let obj = corpus("mixed_cc2.obj");
    let obj = obj.to_str().unwrap();
    for args in [
        vec!["info", swv],
        vec!["info", swv, "--json"],
        vec!["verify", obj],
    ] {
        let mut child = bin()
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Close the reading end before the command writes.
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{args:?}: {:?} {err}", out.status);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn info_and_verify_json_have_their_keys() {
    let input = corpus("terrain_grid33.obj");
    let swv = compressed(&input, "terrain.swv", &["--bits", "12"]);
    let o = run(&["info", swv.to_str().unwrap(), "--json"]);
    assert!(o.status.success());
    let v = json(&o);
    for k in [
        "format_version",
        "vertices",
        "faces",
        "base_vertices",
        "base_faces",
        "levels",
        "family",
        "transform",
        "quantization",
        "sections",
        "bits_per_vertex",
    ] {
        assert!(v.get(k).is_some(), "info --json lacks {k}: {v}");
    }
    assert_eq!(v["vertices"], 1089);
    assert_eq!(v["quantization"]["bits"], 12);
    let o = run(&["verify", input.to_str().unwrap(), "--json"]);
    assert!(o.status.success());
    let v = json(&o);
    for k in [
        "bytes",
        "encode_ms",
        "decode_ms",
        "exact",
        "bits_per_vertex",
    ] {
        assert!(v.get(k).is_some(), "verify --json lacks {k}: {v}");
    }
    assert_eq!(v["exact"], true);
    let o = run(&[
        "verify",
        input.to_str().unwrap(),
        "--json",
        "--threads",
        "3",
    ]);
    assert_eq!(json(&o)["encode_threads"], 3);
    let o = run(&["info", swv.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("bits per vertex"));
}

/// A level in mode 9 with joint rounding is named so by `info`, in text and
/// in JSON; other level sections say `"joint": false`.
#[test]
fn info_names_joint_rounding() {
    let swv = corpus("golden/terrain_grid33.interp6.q10.swv");
    let (levels, text) = info_levels(&swv);
    let joint: Vec<_> = levels.iter().filter(|s| s["joint"] == true).collect();
    assert_eq!(joint.len(), 1, "{levels:?}");
    assert_eq!(joint[0]["mode"], 9);
    assert!(
        levels.iter().all(|s| s.get("joint").is_some()),
        "{levels:?}"
    );
    assert!(
        text.contains("(mode 9 joint, unbinned, zero slots 0 1)"),
        "{text}"
    );
}

/// Zero slots: `info` lists a level's left-out slots, in text and in JSON
/// (`"zero_slots": []` where none are).
#[test]
fn info_lists_zero_slots() {
    let sections = |file: &str| info_levels(&corpus(file));
    let (levels, text) = sections("golden/terrain_grid33.interp6.q10.swv");
    assert!(!levels.is_empty());
    for s in &levels {
        assert_eq!(s["zero_slots"], serde_json::json!([0, 1]), "{s}");
    }
    assert!(
        text.contains("(mode 9 joint, unbinned, zero slots 0 1)"),
        "{text}"
    );
    let (levels, text) = sections("golden/cube_cc4.swv");
    for s in &levels {
        assert_eq!(s["zero_slots"], serde_json::json!([]), "{s}");
    }
    assert!(!text.contains("zero slots"), "{text}");
}

/// A subdivision fit's level sections (SPEC.md 10.4) have no mode byte: `info` gives
/// them no mode (it once read their first byte as one).
#[test]
fn info_gives_fit_levels_no_mode() {
    let src = corpus("subdivided_cc3.obj");
    let swv = compressed(&src, "fit.swv", &["--transform", "fit"]);
    let v = json(&run(&["info", swv.to_str().unwrap(), "--json"]));
    assert!(v["transform"].as_str().unwrap().starts_with("fit"), "{v}");
    let (levels, text) = info_levels(&swv);
    assert!(!levels.is_empty(), "{v}");
    assert!(levels.iter().all(|s| s.get("mode").is_none()), "{v}");
    assert!(!text.contains("(mode"), "{text}");
}

#[test]
fn errors_exit_1_with_one_line_naming_the_file() {
    let bad = tmp("bad.swv");
    std::fs::write(&bad, b"not a container at all").unwrap();
    let o = run(&[
        "decompress",
        bad.to_str().unwrap(),
        tmp("x.obj").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("bad.swv") && err.contains("not a subwave container"),
        "{err}"
    );
    let o = run(&[
        "compress",
        "/nonexistent/mesh.obj",
        tmp("y.swv").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!String::from_utf8_lossy(&o.stderr).contains("panicked"));
    let nan = tmp("nan.obj");
    std::fs::write(&nan, b"v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let o = run(&[
        "compress",
        nan.to_str().unwrap(),
        tmp("z.swv").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not a finite number"));
}

#[test]
fn usage_errors_exit_2_and_help_works() {
    assert_eq!(run(&["compress"]).status.code(), Some(2));
    assert_eq!(run(&["frobnicate"]).status.code(), Some(2));
    assert_eq!(
        run(&["compress", "a", "b", "--bits", "31"]).status.code(),
        Some(2)
    );
    let h = run(&["--help"]);
    assert!(h.status.success());
    assert!(String::from_utf8_lossy(&h.stdout).contains("Examples:"));
    let v = run(&["--version"]);
    assert!(String::from_utf8_lossy(&v.stdout).contains(env!("CARGO_PKG_VERSION")));
}

#[test]
fn by_default_a_file_with_attributes_comes_back_whole() {
    // UVs, normals, a material and a group: without options nothing is dropped, the
    // file comes back byte for byte, and no warning is printed.
    let input = corpus("textured_cc3.obj");
    let swv = compressed(&input, "textured_default.swv", &[]);
    let back = tmp("textured_default.obj");
    let o = run(&["decompress", swv.to_str().unwrap(), back.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read(&back).unwrap(),
        std::fs::read(&input).unwrap()
    );
    let v = json(&run(&["info", swv.to_str().unwrap(), "--json"]));
    assert_eq!(v["keep_order"], true, "{v}");
    // info describes the attribute (the `vt` table: two values per entry) and how its
    // nested container codes it.
    let attrs: Vec<&serde_json::Value> = v["sections"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["kind"] == "ATTR")
        .collect();
    assert!(!attrs.is_empty(), "{v}");
    assert_eq!(attrs[0]["attribute"]["width"], 2, "{v}");
    assert_eq!(attrs[0]["attribute"]["name"], "uv", "{v}");
    assert!(attrs[0]["attribute"]["transform"].is_string(), "{v}");
    let text = String::from_utf8_lossy(&run(&["info", swv.to_str().unwrap()]).stdout).to_string();
    assert!(
        text.contains("('uv': ") && text.contains("x 2 values"),
        "{text}"
    );
    // In canonical order the channels are named with their domain.
    let canon = compressed(&input, "textured_canonical.swv", &["--canonical"]);
    let text = String::from_utf8_lossy(&run(&["info", canon.to_str().unwrap()]).stdout).to_string();
    assert!(
        text.contains("('uv' per corner: ") && text.contains("('material' per face: "),
        "{text}"
    );
    // A file of positions and faces alone stays in canonical order (no ORDR).
    let plain = compressed(&corpus("cube_cc4.obj"), "plain_default.swv", &[]);
    let v = json(&run(&["info", plain.to_str().unwrap(), "--json"]));
    assert_eq!(v["keep_order"], false, "{v}");
    // --keep-order and --canonical contradict each other: a usage error.
    let o = run(&[
        "compress",
        input.to_str().unwrap(),
        tmp("both.swv").to_str().unwrap(),
        "--keep-order",
        "--canonical",
    ]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn canonical_warns_what_it_drops_and_q_silences_it() {
    let p = tmp("attrs.obj");
    std::fs::write(
        &p,
        b"mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0 0.5\ng side\nusemtl red\nf 1/1/1 2/1/1 3/1/1\ncurv 0 1 1 2\n",
    )
    .unwrap();
    let o = run(&[
        "compress",
        p.to_str().unwrap(),
        tmp("attrs.swv").to_str().unwrap(),
        "--canonical",
    ]);
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    // UVs, normals, the group, the material and the material library are channels,
    // kept; the free-form curve is not.
    assert!(
        err.contains("'curv' statements")
            && !err.contains("mtllib")
            && !err.contains("group")
            && !err.contains("normals"),
        "{err}"
    );
    let back = tmp("attrs_back.obj");
    let o = run(&[
        "-f",
        "decompress",
        tmp("attrs.swv").to_str().unwrap(),
        back.to_str().unwrap(),
    ]);
    assert!(o.status.success() && o.stderr.is_empty(), "{o:?}");
    let text = std::fs::read_to_string(&back).unwrap();
    assert!(
        text.starts_with("mtllib a.mtl\nv ")
            && text.contains("vt 0.0 0.5\n")
            && text.contains("vn 0 0 1\n")
            && text.contains("/1/1 ")
            && text.contains("g side\nusemtl red\nf "),
        "{text}"
    );
    // A format without such channels says what it does not write.
    let o = run(&[
        "-f",
        "decompress",
        tmp("attrs.swv").to_str().unwrap(),
        tmp("attrs_back.off").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && err.contains("group, material, lines, uv, normal"),
        "{err}"
    );
    let o = run(&[
        "-q",
        "-f",
        "compress",
        p.to_str().unwrap(),
        tmp("attrs.swv").to_str().unwrap(),
        "--canonical",
    ]);
    assert!(o.stderr.is_empty());
    // Without --canonical nothing is dropped, so nothing is said.
    let o = run(&[
        "-f",
        "compress",
        p.to_str().unwrap(),
        tmp("attrs.swv").to_str().unwrap(),
    ]);
    assert!(o.status.success() && o.stderr.is_empty(), "{o:?}");
}

#[test]
fn info_reports_a_polar_hierarchy_and_its_poles() {
    let input = corpus("sphere_polar3.obj");
    let swv = compressed(&input, "polar.swv", &["--keep-order"]);
    let v = json(&run(&["info", swv.to_str().unwrap(), "--json"]));
    assert_eq!(v["family"], "polar");
    assert_eq!(v["levels"], 3);
    assert_eq!(v["poles"].as_array().unwrap().len(), 2);
    assert!(v["disc_transform"].is_string());
    let text = run(&["info", swv.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("poles           2"));
    // The polar wavelet in the discs, forced, round-trips through the command too.
    let forced = compressed(&input, "polar-disc.swv", &["--polar-disc", "lazy-radial"]);
    let v2 = json(&run(&["info", forced.to_str().unwrap(), "--json"]));
    assert_eq!(v2["disc_transform"], "polar-lazy (radial first)");
    let o = run(&[
        "compress",
        input.to_str().unwrap(),
        forced.to_str().unwrap(),
        "--polar-disc",
        "nope",
    ]);
    assert!(!o.status.success());
    let out = tmp("polar.obj");
    assert!(
        run(&["decompress", swv.to_str().unwrap(), out.to_str().unwrap()])
            .status
            .success()
    );
    // The file comes back byte for byte.
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&input).unwrap());
    assert_eq!(v["base_vertices"], 17);
}

#[test]
fn max_level_on_a_cut_file_and_info_reports_cc() {
    let input = corpus("cube_cc4.obj");
    let swv = compressed(&input, "levels.swv", &["--transform", "bilinear"]);
    let v = json(&run(&["info", swv.to_str().unwrap(), "--json"]));
    assert_eq!(v["family"], "cc");
    assert_eq!(v["levels"], 4);
    assert_eq!(v["transform"], "bilinear");
    // Keep the preamble and the sections up to level 2 (HEAD, BASE, LEVL, LEVL).
    let bytes = std::fs::read(&swv).unwrap();
    let sizes: Vec<u64> = v["sections"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["bytes"].as_u64().unwrap())
        .collect();
    let cut = 12 + sizes[..4].iter().sum::<u64>() as usize;
    let cut_path = tmp("levels-cut.swv");
    std::fs::write(&cut_path, &bytes[..cut + 5]).unwrap();
    let out = tmp("level2.obj");
    let o = run(&[
        "decompress",
        cut_path.to_str().unwrap(),
        out.to_str().unwrap(),
        "--max-level",
        "2",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m = subwave::load(&std::fs::read(&out).unwrap(), None).unwrap();
    // The library's level-2 mesh of the whole file, read back through the OBJ writer.
    let lib = subwave::decode(
        &bytes,
        &subwave::DecodeOptions {
            max_level: Some(2),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(m.mesh, lib.mesh);
    let base_faces = v["base_faces"].as_u64().unwrap() as usize;
    assert!(m.mesh.face_count() > base_faces && m.mesh.face_count() < 1536);
    // The whole mesh needs the whole file.
    let o = run(&[
        "-f",
        "decompress",
        cut_path.to_str().unwrap(),
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("truncated"));
}

#[test]
fn thread_counts_write_the_same_file() {
    // cube_cc4 has a Catmull-Clark and a sqrt(2) family; sphere_polar3 ranks its discs.
    for mesh in ["cube_cc4.obj", "sphere_polar3.obj"] {
        let input = corpus(mesh);
        let files: Vec<Vec<u8>> = ["1", "3", "0"]
            .iter()
            .map(|t| {
                let swv = compressed(&input, &format!("threads{t}.{mesh}.swv"), &["--threads", t]);
                std::fs::read(swv).unwrap()
            })
            .collect();
        assert!(files[1] == files[0], "{mesh}: --threads 3");
        assert!(files[2] == files[0], "{mesh}: --threads 0");
    }
    let o = run(&[
        "compress",
        corpus("cube_cc4.obj").to_str().unwrap(),
        "/dev/null",
        "--threads",
        "x",
    ]);
    assert_eq!(o.status.code(), Some(2), "a bad --threads is bad usage");
}

#[test]
fn nothing_is_clobbered_or_half_written() {
    let input = corpus("cube_cc4.obj");
    let swv = tmp("guard.swv");
    let _ = std::fs::remove_file(&swv);
    let (i, o) = (input.to_str().unwrap(), swv.to_str().unwrap());
    // The input is never the output, even with -f.
    let copy = tmp("guard_input.obj");
    std::fs::copy(&input, &copy).unwrap();
    let c = copy.to_str().unwrap();
    for args in [vec!["compress", c, c], vec!["-f", "compress", c, c]] {
        let r = run(&args);
        assert_eq!(r.status.code(), Some(1), "{args:?}");
        assert!(String::from_utf8_lossy(&r.stderr).contains("is the input"));
    }
    assert_eq!(
        std::fs::read(&copy).unwrap(),
        std::fs::read(&input).unwrap()
    );
    // An existing output needs -f; nothing is written without it.
    assert!(run(&["compress", i, o]).status.success());
    let first = std::fs::read(&swv).unwrap();
    let r = run(&["compress", i, o, "--bits", "8"]);
    assert_eq!(r.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&r.stderr).contains("already exists"));
    assert_eq!(std::fs::read(&swv).unwrap(), first);
    assert!(run(&["compress", i, o, "--bits", "8", "-f"])
        .status
        .success());
    assert_ne!(std::fs::read(&swv).unwrap(), first);
    // A failed run leaves no output and no temporary file behind.
    let bad = tmp("guard_bad.obj");
    std::fs::write(&bad, b"v 0 0 0\nf 1 2 3\n").unwrap();
    let out = tmp("guard_bad.swv");
    let _ = std::fs::remove_file(&out);
    assert_eq!(
        run(&["compress", bad.to_str().unwrap(), out.to_str().unwrap()])
            .status
            .code(),
        Some(1)
    );
    assert!(!out.exists());
    // (Only this output's: the other tests write beside it at the same time.)
    let dir = out.parent().unwrap();
    assert!(std::fs::read_dir(dir).unwrap().all(|e| {
        let name = e.unwrap().file_name().to_string_lossy().to_string();
        !(name.starts_with(".guard_bad.swv.") && name.ends_with(".subwave-tmp"))
    }));
    // An output extension that names no mesh format is an error.
    let r = run(&["decompress", o, tmp("guard.xyz").to_str().unwrap()]);
    assert_eq!(r.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&r.stderr).contains("no mesh format"));
}

#[test]
fn a_file_whose_extension_and_content_disagree_is_refused() {
    let misnamed = tmp("misnamed.ply");
    std::fs::copy(corpus("cube_cc4.obj"), &misnamed).unwrap();
    let out = tmp("misnamed.swv");
    let r = run(&[
        "-f",
        "compress",
        misnamed.to_str().unwrap(),
        out.to_str().unwrap(),
    ]);
    assert_eq!(r.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&r.stderr).contains("the extension says PLY"));
}

#[test]
fn a_batch_codes_every_file_and_names_the_ones_that_fail() {
    let root = tmp("batch");
    let _ = std::fs::remove_dir_all(&root);
    let src = root.join("in");
    std::fs::create_dir_all(src.join("deeper")).unwrap();
    for name in ["cube_cc4.obj", "floats_cc2.ply", "cube_cc2.stl"] {
        std::fs::copy(corpus(name), src.join(name)).unwrap();
    }
    std::fs::copy(corpus("open_cc2.obj"), src.join("deeper/open_cc2.obj")).unwrap();
    std::fs::write(src.join("notes.txt"), "not a mesh, not taken by -r").unwrap();
    std::fs::write(src.join("broken.obj"), "hello\n").unwrap();
    let out = root.join("out");
    let (s, o) = (src.to_str().unwrap(), out.to_str().unwrap());
    // A folder needs -r.
    let r = run(&["compress", s, "-o", o]);
    assert_eq!(r.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&r.stderr).contains("use -r"));
    // With -r: every mesh file, the broken one named, the others done, exit 1.
    let r = run(&["-q", "compress", "-r", s, "-o", o, "--threads", "2"]);
    let err = String::from_utf8_lossy(&r.stderr).to_string();
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(err.contains("compressed 4 of 5 files"), "{err}");
    assert!(
        err.contains("1 failed") && err.contains("broken.obj"),
        "{err}"
    );
    for name in [
        "cube_cc4.obj",
        "floats_cc2.ply",
        "cube_cc2.stl",
        "deeper/open_cc2.obj",
    ] {
        assert!(
            out.join("in").join(format!("{name}.swv")).exists(),
            "{name}"
        );
    }
    assert!(!out.join("in/notes.txt.swv").exists());
    // Back: NAME.swv -> NAME, and the values are the inputs'.
    let back = root.join("back");
    let r = run(&["-q", "decompress", "-r", o, "-o", back.to_str().unwrap()]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    for name in [
        "cube_cc4.obj",
        "floats_cc2.ply",
        "cube_cc2.stl",
        "deeper/open_cc2.obj",
    ] {
        let a = subwave::load(&std::fs::read(src.join(name)).unwrap(), None).unwrap();
        let b = subwave::load(
            &std::fs::read(back.join("out/in").join(name)).unwrap(),
            None,
        )
        .unwrap();
        assert_eq!(a.mesh.vertex_count(), b.mesh.vertex_count(), "{name}");
        let values = |l: &subwave::Loaded| {
            let mut v: Vec<[u64; 3]> = (0..l.mesh.vertex_count())
                .map(|i| std::array::from_fn(|k| subwave_value_bits(l, i, k)))
                .collect();
            v.sort();
            v
        };
        assert_eq!(values(&a), values(&b), "{name}");
    }
    // A second run refuses to overwrite, unless forced; several inputs need -o.
    let cube = corpus("cube_cc4.obj");
    let r = run(&["compress", cube.to_str().unwrap(), "-o", o]);
    assert!(r.status.success());
    let r = run(&["compress", cube.to_str().unwrap(), "-o", o]);
    assert_eq!(r.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&r.stderr).contains("already exists"));
    let r = run(&["compress", cube.to_str().unwrap(), "a", "b"]);
    assert_eq!(r.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&r.stderr).contains("-o DIR"));
}

/// A vertex's coordinate as the bits of the value it denotes (f64).
fn subwave_value_bits(l: &subwave::Loaded, v: usize, k: usize) -> u64 {
    match (l.mesh.floats.get(v), l.quantization) {
        (
            Some(f),
            subwave::Quantization::Float {
                width: subwave::FloatWidth::F32,
                ..
            },
        ) => (f32::from_bits(f[k] as u32) as f64).to_bits(),
        (Some(f), _) => f[k],
        (None, q) => q.value_f64(l.mesh.positions[v][k], k).to_bits(),
    }
}

#[test]
fn verify_repeats_and_reports_medians() {
    let cube = corpus("cube_cc4.obj");
    let v = json(&run(&[
        "verify",
        cube.to_str().unwrap(),
        "--repeat",
        "3",
        "--json",
    ]));
    assert_eq!(v["repeat"], 3);
    assert_eq!(v["exact"], true);
    assert!(v["decode_ms"].as_f64().unwrap() > 0.0);
    let text = run(&["verify", cube.to_str().unwrap(), "--repeat", "2"]);
    assert!(text.status.success());
    assert!(String::from_utf8_lossy(&text.stdout).contains("medians of 2"));
    let bad = run(&["verify", cube.to_str().unwrap(), "--repeat", "0"]);
    assert_eq!(bad.status.code(), Some(2));
}

/// `info` names how an ORDR section codes the order (SPEC.md 7), in text and JSON.
#[test]
fn info_names_the_order_method() {
    let swv = compressed(
        &corpus("cube_cc4.shuffled.obj"),
        "ordr.swv",
        &["--keep-order"],
    );
    let v = json(&run(&["info", swv.to_str().unwrap(), "--json"]));
    let sections = v["sections"].as_array().unwrap();
    let ordr = sections
        .iter()
        .find(|s| s["kind"] == "ORDR")
        .expect("an ORDR section");
    let method = ordr["order_method"].as_str().unwrap().to_string();
    assert!(
        [
            "lists",
            "walks",
            "base elements",
            "face blocks and first use"
        ]
        .contains(&method.as_str()),
        "{method}"
    );
    let text = String::from_utf8_lossy(&run(&["info", swv.to_str().unwrap()]).stdout).to_string();
    let want = format!("ORDR {} B ({method})", ordr["bytes"]);
    assert!(text.contains(&want), "{want} not in {text}");
    // Other sections have no method.
    assert!(sections
        .iter()
        .filter(|s| s["kind"] != "ORDR")
        .all(|s| s.get("order_method").is_none()));
}

#[test]
fn geometry_only_leaves_out_every_channel_and_says_so() {
    let p = tmp("geometry.obj");
    std::fs::write(
        &p,
        b"# a comment\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0.5\nusemtl red\nf 1/1 2/1 3/1\n",
    )
    .unwrap();
    let swv = tmp("geometry.swv");
    let (input, out) = (p.to_str().unwrap(), swv.to_str().unwrap());
    let o = run(&["-f", "compress", input, out, "--geometry-only"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("--geometry-only): material, lines, uv"),
        "{err}"
    );
    let back = tmp("geometry_back.obj");
    let o = run(&["-f", "decompress", out, back.to_str().unwrap()]);
    assert!(o.status.success(), "{o:?}");
    let text = std::fs::read_to_string(&back).unwrap();
    assert!(
        !text.contains("vt") && !text.contains('#') && text.contains("f 1 2 3"),
        "{text}"
    );
    // The same mesh, smaller than with its channels.
    let whole = tmp("geometry_whole.swv");
    let o = run(&[
        "-f",
        "compress",
        input,
        whole.to_str().unwrap(),
        "--canonical",
    ]);
    assert!(o.status.success());
    let size = |p: &Path| std::fs::metadata(p).unwrap().len();
    assert!(size(&swv) < size(&whole));
    // With --keep-order it is an error.
    let o = run(&[
        "-f",
        "compress",
        input,
        out,
        "--geometry-only",
        "--keep-order",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--geometry-only"));
}
