//! Limits on what a container may ask a decoder to do (SPEC.md 2.5).

/// Bounds checked before anything sized by the input is allocated. The defaults admit
/// every mesh this project has met with wide margin, while keeping a hostile header from
/// asking for more memory than a 24 GiB machine has.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub struct Limits {
    /// Most vertices in a mesh. Default 2^27 (134 M): 3.2 GiB of positions at 24 bytes.
    pub max_vertices: u64,
    /// Most faces in a mesh. Default 2^27.
    pub max_faces: u64,
    /// Most face corners (sum of face degrees). Default 2^29 (2 GiB of indices).
    pub max_corners: u64,
    /// Most corners in one face. Default 2^16: no real polygon comes close.
    pub max_face_degree: u64,
    /// Most refinement levels. Default 16: a quad refined 16 times has 4^16 faces.
    pub max_levels: u64,
    /// Most sections in a container. Default 64 (levels plus a handful).
    pub max_sections: usize,
    /// Longest section payload. Default 2^32 - 1 (the field's range).
    pub max_section_bytes: u64,
    /// Most bytes the decoder may allocate for the decoded mesh and its working state,
    /// estimated from the declared counts before decoding starts. Default 16 GiB.
    pub max_alloc_bytes: u64,
    /// Most bytes of that estimate per byte of container (a decompression-bomb guard):
    /// default 65,536, so a 1 KiB container cannot ask for more than 64 MiB. Real meshes
    /// expand 20 to 700 times (12 down to 0.5 bits per vertex); raise it for synthetic
    /// ones, such as a perfectly flat plane, that compress further.
    pub max_expansion: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_vertices: 1 << 27,
            max_faces: 1 << 27,
            max_corners: 1 << 29,
            max_face_degree: 1 << 16,
            max_levels: 16,
            max_sections: 64,
            max_section_bytes: u32::MAX as u64,
            max_alloc_bytes: 16 << 30,
            max_expansion: 1 << 16,
        }
    }
}

impl Limits {
    /// Tight limits for untrusted input in a small process (fuzzing, services):
    /// 2^20 vertices and faces, 2^22 corners, 256 MiB.
    pub fn tight() -> Self {
        Limits {
            max_vertices: 1 << 20,
            max_faces: 1 << 20,
            max_corners: 1 << 22,
            max_face_degree: 1 << 10,
            max_levels: 10,
            max_sections: 32,
            max_section_bytes: 1 << 26,
            max_alloc_bytes: 256 << 20,
            max_expansion: 1 << 16,
        }
    }
}
