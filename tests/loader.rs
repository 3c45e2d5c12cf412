//! Every way a scene can fail to load gives a clear error naming the file
//! and the element; what loads keeps file order and geometry ids.

use std::io::Write;

use cellbih::scene::{self, SceneError, parse_obj};

fn err(text: &str) -> String {
    parse_obj("t.obj", text.as_bytes()).unwrap_err().to_string()
}

#[test]
fn face_index_out_of_range_names_the_line() {
    let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n");
    assert_eq!(
        e,
        "t.obj:5: face index 4 is out of range (the file has 3 vertices)"
    );
}

#[test]
fn negative_index_out_of_range_names_the_line() {
    let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
    assert!(
        e.starts_with("t.obj:4: face index -4 is out of range"),
        "{e}"
    );
}

#[test]
fn nan_and_infinite_coordinates_name_the_vertex() {
    let e = err("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
    assert_eq!(e, "t.obj:2: vertex 2 has a non-finite coordinate 'nan'");
    let e = err("v 0 0 0\nv 1 0 0\n# c\nv 0 1e39 0\nf 1 2 3\n");
    assert_eq!(
        e,
        "t.obj:4: vertex 3 has a coordinate '1e39' outside the range of f32 (magnitudes up to 3.4e38)"
    );
}

/// tobj's own errors for normals, texture coordinates, colours and the
/// other indices of a face carry no line: each is found and named.
#[test]
fn every_parse_error_names_its_line() {
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    for (extra, want) in [
        (
            "vn 1 x 0\nf 1 2 3\n",
            "t.obj:4: normal 1: 'x' is not a number",
        ),
        (
            "vt x 0\nf 1/1 2 3\n",
            "t.obj:4: texture coordinate 1: 'x' is not a number",
        ),
        (
            "vn 0 0 1\nf 1//x 2 3\n",
            "t.obj:5: 'x' in face corner '1//x' is not a normal index",
        ),
        (
            "vn 0 0 1\nf 1//4 2 3\n",
            "t.obj:5: normal index 4 in face corner '1//4' is out of range (the file has 1 normal)",
        ),
    ] {
        assert_eq!(err(&format!("{tri}{extra}")), want, "{extra}");
    }
    let e = err("v 0 0 0 1 x 1\nv 1 0 0 1 1 1\nv 0 1 0 1 1 1\nvn 1 x 0\nf 1 2 3\n");
    assert!(e.starts_with("t.obj:"), "{e}");
}

#[test]
fn unparsable_vertex_and_face_name_the_line() {
    let e = err("v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n");
    assert_eq!(e, "t.obj:2: vertex 2: 'zero' is not a number");
    let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 two 3\n");
    assert_eq!(e, "t.obj:4: face corner 'two' is not a vertex index");
}

#[test]
fn no_triangles_is_an_error() {
    assert_eq!(err(""), "t.obj: no triangles: the file is empty");
    assert_eq!(
        err("v 0 0 0\nv 1 0 0\n"),
        "t.obj: no triangles: it holds no faces"
    );
    assert_eq!(
        err("this is a text file\nnot a mesh\n"),
        "t.obj: no triangles: it holds no faces"
    );
}

#[test]
fn binary_data_is_not_an_obj() {
    let e = parse_obj("t.bin", &[0u8, 159, 146, 150, 255, 1, 2]).unwrap_err();
    assert!(matches!(e, SceneError::NotObj { .. }), "{e}");
}

#[test]
fn missing_file_names_the_path() {
    let e = scene::load("/nonexistent/dir/model.obj", None)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("/nonexistent/dir/model.obj: cannot read"),
        "{e}"
    );
}

#[test]
fn corrupt_gzip_is_reported() {
    let dir = std::env::temp_dir().join(format!("cellbih-loader-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("broken.obj.gz");
    std::fs::write(&p, [0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3, 1, 2, 3]).unwrap();
    let e = scene::load(p.to_str().unwrap(), None).unwrap_err();
    assert!(matches!(e, SceneError::NotObj { .. }), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn gzip_file_loads_like_plain_text() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n";
    let dir = std::env::temp_dir().join(format!("cellbih-gz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("two.obj.gz");
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(text.as_bytes()).unwrap();
    std::fs::write(&p, gz.finish().unwrap()).unwrap();
    let a = scene::load(p.to_str().unwrap(), None).unwrap();
    let b = parse_obj("two", text.as_bytes()).unwrap();
    assert_eq!(a.triangles, b.triangles);
    // A bare name resolves to <data>/<name>.obj.gz.
    let c = scene::load("two", Some(&dir)).unwrap();
    assert_eq!(c.triangles, b.triangles);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn unknown_names_explain_what_is_accepted() {
    let e = scene::load("no-such-mesh", None).unwrap_err().to_string();
    if scene::data_dir(None).is_some() {
        assert!(
            e.contains("no no-such-mesh.obj.gz or no-such-mesh.obj in"),
            "{e}"
        );
    } else {
        assert!(e.contains("--data DIR") && e.contains("rtperf:N"), "{e}");
    }
    let e = scene::load("no-such-mesh", Some(std::path::Path::new("/tmp")))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no no-such-mesh.obj.gz or no-such-mesh.obj in /tmp"),
        "{e}"
    );
    for bad in [
        "rtperf",
        "rtperf:x",
        "rtperf:0",
        "rtperf:100:y",
        "rtperf:1:2:3",
    ] {
        assert!(scene::load(bad, None).is_err(), "{bad} should not load");
    }
}

#[test]
fn groups_are_geometry_ids_and_faces_keep_file_order() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 0 0\n\
                o a\nf 1 2 3\ng b\nf 2 4 3\nf 1 2 3 4\no a\nf 1 5 2\n";
    let s = parse_obj("groups", text.as_bytes()).unwrap();
    // The quad is fanned into two triangles, in order.
    assert_eq!(s.len(), 5);
    assert_eq!(s.geometry_names, vec!["a".to_string(), "b".to_string()]);
    assert_eq!(s.geometry_ids, vec![0, 1, 1, 1, 0]);
    assert_eq!(
        s.triangles[4].v[1].x, 2.0,
        "the last face is the last triangle"
    );
}

#[test]
fn zero_area_triangles_load() {
    let s = parse_obj(
        "z",
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n".as_bytes(),
    )
    .unwrap();
    assert_eq!((s.len(), s.degenerate_count()), (2, 1));
}

#[test]
fn procedural_scenes_are_deterministic_and_sized_like_the_papers() {
    let a = scene::load("rtperf:10000:5", None).unwrap();
    let b = scene::load("rtperf:10000:5", None).unwrap();
    assert_eq!(a.triangles, b.triangles);
    assert_ne!(
        a.triangles,
        scene::load("rtperf:10000:6", None).unwrap().triangles
    );
    assert_eq!(a.len(), 10_000);
    assert_eq!(a.geometry_names.len(), 50);
    // Exact counts (Table 1's stand-ins): the last sphere is cut.
    let iss = scene::load("rtperf:17633", None).unwrap();
    assert_eq!((iss.len(), iss.geometry_names.len()), (17_633, 89));
    assert_eq!(scene::load("rtperf:7", None).unwrap().len(), 7);
    let car = scene::load("car", None).unwrap();
    assert!((20_000..24_000).contains(&car.len()), "{}", car.len());
    assert!(car.geometry_names.len() >= 10);
    let cup = scene::load("cup", None).unwrap();
    assert_eq!((cup.len(), cup.geometry_names.len()), (7040, 1));
    let d = scene::load("default", None).unwrap();
    assert_eq!(d.degenerate_count(), 0);
    assert!(d.geometry_names.len() > 5);
}

/// A byte-order mark before the first line is not part of it: the first
/// vertex is kept and the indices do not shift; an out-of-range index
/// counts every vertex.
#[test]
fn a_byte_order_mark_is_skipped() {
    let with = b"\xef\xbb\xbfv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n";
    let s = parse_obj("t.obj", with).unwrap();
    let plain = parse_obj("t.obj", &with[3..]).unwrap();
    assert_eq!(s.triangles, plain.triangles);
    assert_eq!(s.bounds(), plain.bounds());
    let e = parse_obj("t.obj", b"\xef\xbb\xbfv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").unwrap_err();
    assert!(e.to_string().contains("(the file has 3 vertices)"), "{e}");
}

/// Valid files tobj alone refuses: vertex colours on some vertices only,
/// and a single-byte (Latin-1) character in a comment or a name. A NUL
/// byte is still not text.
#[test]
fn colours_on_some_vertices_and_latin1_bytes_load() {
    let coloured = parse_obj("t.obj", b"v 0 0 0 1 0 0\nv 0 1 0\nv 1 0 0\nf 1 2 3\n").unwrap();
    let plain = parse_obj("t.obj", b"v 0 0 0\nv 0 1 0\nv 1 0 0\nf 1 2 3\n").unwrap();
    assert_eq!(coloured.triangles, plain.triangles);
    let latin1 = parse_obj(
        "t.obj",
        b"# caf\xe9\no caf\xe9\nv 0 0 0\nv 0 1 0\nv 1 0 0\nf 1 2 3\n",
    );
    assert_eq!(latin1.unwrap().triangles, plain.triangles);
    let e = parse_obj("t.obj", b"v 0 0 0\0\n").unwrap_err().to_string();
    assert!(e.contains("not text"), "{e}");
}

/// A face of fewer than three corners, and a last face cut short, are
/// errors naming the file and line (tobj drops them without a word).
#[test]
fn a_face_of_fewer_than_three_corners_names_the_line() {
    let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n");
    assert_eq!(
        e,
        "t.obj:5: a face with 2 corners: a face needs at least 3 (a file cut short?)"
    );
    let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1");
    assert_eq!(
        e,
        "t.obj:4: a face with 1 corner: a face needs at least 3 (a file cut short?)"
    );
    // A face line of three corners with slashes loads.
    assert!(parse_obj("t.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/2 3/3\n").is_ok());
}

/// A UTF-16 file (with or without its byte-order mark) is named as such.
#[test]
fn utf16_is_named_as_unsupported() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let le: Vec<u8> = text.encode_utf16().flat_map(u16::to_le_bytes).collect();
    let be: Vec<u8> = text.encode_utf16().flat_map(u16::to_be_bytes).collect();
    for bytes in [[&[0xff, 0xfe][..], &le].concat(), le, be] {
        let e = parse_obj("t.obj", &bytes).unwrap_err().to_string();
        assert!(e.contains("UTF-16 text, which is not supported"), "{e}");
    }
}
