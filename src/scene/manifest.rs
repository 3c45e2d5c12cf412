//! The manifest of the real meshes (`scripts/meshes.tsv`): each mesh's
//! name, triangle count, the SHA-256 of its OBJ text and where it can be
//! downloaded. `scripts/get-meshes` fills a data directory from it and
//! verifies each mesh; the loader checks a mesh it reads by name from a
//! data directory against it, so that a figure is never measured on
//! another file than the one the docs name without a word.

use sha2::{Digest, Sha256};

/// The manifest, as the repository holds it.
const MANIFEST: &str = include_str!("../../scripts/meshes.tsv");

/// One mesh of the manifest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mesh {
    pub name: &'static str,
    pub triangles: usize,
    /// SHA-256 of the OBJ text (gzip'd or not, the same text).
    pub obj_sha256: &'static str,
    /// Where the OBJ can be downloaded as it is, if it can.
    pub download: Option<&'static str>,
}

/// Every mesh of the manifest, in its order.
pub fn meshes() -> Vec<Mesh> {
    (MANIFEST.lines())
        .filter(|l| !l.starts_with('#') && !l.starts_with("name\t") && !l.is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            assert_eq!(f.len(), 5, "scripts/meshes.tsv: {l}");
            Mesh {
                name: f[0],
                triangles: f[1].parse().expect("scripts/meshes.tsv: a triangle count"),
                obj_sha256: f[2],
                download: (f[4] != "-").then_some(f[4]),
            }
        })
        .collect()
}

/// The SHA-256 of `text`, in hex.
pub fn sha256(text: &[u8]) -> String {
    Sha256::digest(text)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Why the OBJ text `text` of the mesh named `name` is not the manifest's
/// (its checksum differs), or `None` when it is, or when the manifest
/// has no mesh of that name.
pub fn differs(name: &str, text: &[u8]) -> Option<String> {
    let mesh = meshes().into_iter().find(|m| m.name == name)?;
    let have = sha256(text);
    (have != mesh.obj_sha256).then(|| {
        format!(
            "mesh {name}: its OBJ text's SHA-256 is {have}, not the manifest's {} \
             (scripts/meshes.tsv): figures measured on it are not the docs' \
             (scripts/get-meshes fetches and verifies the meshes)",
            mesh.obj_sha256
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_manifest_names_each_mesh_once_with_a_checksum() {
        let m = meshes();
        assert!(m.iter().any(|m| m.name == "bunny" && m.triangles == 69_451));
        for mesh in &m {
            assert_eq!(mesh.obj_sha256.len(), 64, "{mesh:?}");
            assert_eq!(m.iter().filter(|o| o.name == mesh.name).count(), 1);
        }
    }

    #[test]
    fn a_text_other_than_the_manifests_is_named() {
        // The SHA-256 of "abc" (FIPS 180-2's example).
        assert_eq!(
            sha256(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        let why = differs("teapot", b"v 0 0 0\n").unwrap();
        assert!(
            why.contains("mesh teapot") && why.contains("get-meshes"),
            "{why}"
        );
        assert_eq!(differs("not-in-the-manifest", b""), None);
    }
}
