//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use subwave::Mesh;

/// The project's own small meshes.
pub fn own_corpus() -> Vec<PathBuf> {
    list(&Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus"))
}

/// The shared corpus beside the checkout, when it exists.
pub fn shared_corpus() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/corpus");
    p.join("manifest.json").exists().then_some(p)
}

pub fn list(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| subwave::Format::from_path(&p.to_string_lossy()).is_some())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// An order-independent fingerprint of a mesh: its sorted positions and its sorted faces,
/// each face written as the positions of its corners starting at the smallest one
/// (orientation kept). Computed without any help from the encoder.
pub fn fingerprint(m: &Mesh) -> (Vec<[i64; 3]>, Vec<Vec<[i64; 3]>>) {
    let mut pos = m.positions.clone();
    pos.sort_unstable();
    let mut faces: Vec<Vec<[i64; 3]>> = m
        .iter_faces()
        .map(|f| {
            let p: Vec<[i64; 3]> = f.iter().map(|&v| m.positions[v as usize]).collect();
            let k = (0..p.len())
                .min_by(|&a, &b| {
                    let ra = p[a..].iter().chain(&p[..a]);
                    let rb = p[b..].iter().chain(&p[..b]);
                    ra.cmp(rb)
                })
                .unwrap_or(0);
            p[k..].iter().chain(&p[..k]).copied().collect()
        })
        .collect();
    faces.sort_unstable();
    (pos, faces)
}

/// A generated mesh's positions scaled and rounded to integers.
pub fn to_mesh(p: &subwave_corpus::PolyMesh, scale: f64) -> Mesh {
    let mut m = Mesh::new();
    m.positions = p
        .positions
        .iter()
        .map(|v| v.map(|c| (c * scale).round() as i64))
        .collect();
    for f in &p.faces {
        m.push_face(f);
    }
    m
}

/// Decoding options that stop at refinement level `level`.
pub fn up_to(level: u8) -> subwave::DecodeOptions {
    subwave::DecodeOptions {
        max_level: Some(level),
        ..Default::default()
    }
}

/// The container `bytes` with its header payload replaced by `h` (every other section as
/// it is): a header the encoder would not write, for the decoder to judge.
pub fn with_header(bytes: &[u8], h: &subwave::Header) -> Vec<u8> {
    use subwave_container::{Container, ContainerWriter, Limits, SectionKind};
    let c = Container::parse(bytes, &Limits::default()).unwrap();
    let mut w = ContainerWriter::new();
    for s in c.sections.iter().filter(|s| s.kind != SectionKind::END) {
        let p = if s.kind == SectionKind::HEADER {
            h.write()
        } else {
            s.payload.to_vec()
        };
        w.section(s.kind, &p);
    }
    w.finish()
}
