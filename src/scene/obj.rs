//! Wavefront OBJ (and gzip'd OBJ) through `tobj`.
//!
//! tobj parses; it reports errors without a line number and accepts `nan`
//! and `inf` as coordinates. So when tobj fails, or hands back a non-finite
//! position, [`locate_problem`] scans the text once more to name the line
//! and the element at fault. Each `o`/`g` name is one geometry id (the same
//! name twice is the same id); faces keep file order, polygons are fanned
//! into triangles in order.

use std::borrow::Cow;
use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::path::Path;

use glam::Vec3;

use super::{Scene, SceneError, Triangle};

/// Loads an `.obj` or `.obj.gz` file (gzip is recognised by its magic bytes).
pub fn load_obj_file(path: &Path) -> Result<Scene, SceneError> {
    let text = read_obj_text(path)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().trim_end_matches(".gz").to_string())
        .unwrap_or_default();
    parse_obj_named(&path.display().to_string(), &name, &text)
}

/// The OBJ text of an `.obj` or `.obj.gz` file, gunzipped, every line
/// bounded ([`crate::text_input`]): a device or a file without newlines
/// is refused at its first over-long line, not read until memory runs
/// out.
pub fn read_obj_text(path: &Path) -> Result<Vec<u8>, SceneError> {
    use crate::text_input::{TextError, read_text};
    let io = |source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = BufReader::new(std::fs::File::open(path).map_err(io)?);
    let gzip = file.fill_buf().map_err(io)?.starts_with(&[0x1f, 0x8b]);
    let text = if gzip {
        read_text(flate2::bufread::MultiGzDecoder::new(file))
    } else {
        read_text(file)
    };
    text.map_err(|e| match e {
        TextError::Io(e) if gzip && e.kind() != std::io::ErrorKind::PermissionDenied => {
            SceneError::NotObj {
                path: path.display().to_string(),
                why: format!("gzip data is corrupt: {e}"),
            }
        }
        TextError::Io(e) => io(e),
        TextError::LongLine { line } => SceneError::Malformed {
            path: path.display().to_string(),
            line,
            what: e.to_string(),
        },
        TextError::Nul { .. } => SceneError::NotObj {
            path: path.display().to_string(),
            why: e.to_string(),
        },
    })
}

/// Parses OBJ text held in memory; `name` names it in errors.
pub fn parse_obj(name: &str, text: &[u8]) -> Result<Scene, SceneError> {
    parse_obj_named(name, name, text)
}

/// The OBJ text as tobj should read it: without a leading byte-order mark
/// (tobj would take `\u{feff}v` for an unknown statement and drop the first
/// vertex, shifting every index); a file in a single-byte encoding (a
/// Latin-1 byte in a comment or a name) read as Latin-1; and vertex colours
/// (`v x y z r g b`, which tobj refuses when only some vertices have them)
/// dropped, since the BIH needs positions only. Lines keep their numbers.
/// `None`: not text at all (a NUL byte).
fn normalize(text: &[u8]) -> Option<Cow<'_, [u8]>> {
    if text.contains(&0) {
        return None;
    }
    let text = text.strip_prefix(b"\xef\xbb\xbf").unwrap_or(text);
    let mut text: Cow<'_, [u8]> = match std::str::from_utf8(text) {
        Ok(_) => Cow::Borrowed(text),
        Err(_) => Cow::Owned(
            text.iter()
                .map(|&b| b as char)
                .collect::<String>()
                .into_bytes(),
        ),
    };
    let coloured = |l: &&[u8]| {
        l.starts_with(b"v ")
            && l.split(u8::is_ascii_whitespace)
                .filter(|t| !t.is_empty())
                .count()
                >= 7
    };
    if text.split(|&b| b == b'\n').any(|l| coloured(&l)) {
        let mut out = Vec::with_capacity(text.len());
        for (k, line) in text.split(|&b| b == b'\n').enumerate() {
            if k > 0 {
                out.push(b'\n');
            }
            if coloured(&line) {
                let tokens: Vec<&[u8]> = (line.split(u8::is_ascii_whitespace))
                    .filter(|t| !t.is_empty())
                    .take(4)
                    .collect();
                out.extend_from_slice(&tokens.join(&b' '));
            } else {
                out.extend_from_slice(line);
            }
        }
        text = Cow::Owned(out);
    }
    Some(text)
}

pub(super) fn parse_obj_named(path: &str, name: &str, text: &[u8]) -> Result<Scene, SceneError> {
    check_vertices(path, text)?;
    let Some(text) = normalize(text) else {
        let nul = text.iter().position(|&b| b == 0).unwrap_or(0);
        let line = 1 + text[..nul].iter().filter(|&&b| b == b'\n').count();
        return Err(SceneError::NotObj {
            path: path.into(),
            why: crate::text_input::not_text(&text[..text.len().min(64)], line),
        });
    };
    // tobj drops a face of fewer than three corners without a word.
    if let Some((line, corners)) = short_face(&text) {
        return Err(SceneError::Malformed {
            path: path.into(),
            line,
            what: format!(
                "a face with {corners} corner{}: a face needs at least 3 (a file cut short?)",
                if corners == 1 { "" } else { "s" }
            ),
        });
    }
    let text = &text[..];
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let loaded = tobj::load_obj_buf(&mut &text[..], &opts, |_| {
        Err(tobj::LoadError::GenericFailure)
    });
    let models = match loaded {
        Ok((models, _materials)) => models,
        Err(e) => return Err(diagnose(path, text, &e.to_string())),
    };

    let mut triangles = Vec::new();
    let mut geometry_ids = Vec::new();
    let mut geometry_names: Vec<String> = Vec::new();
    let mut by_name: HashMap<String, u32> = HashMap::new();
    for model in &models {
        let mesh = &model.mesh;
        if mesh.indices.is_empty() {
            continue;
        }
        let gid = *by_name.entry(model.name.clone()).or_insert_with(|| {
            geometry_names.push(model.name.clone());
            (geometry_names.len() - 1) as u32
        });
        let pos = |i: u32| {
            let i = i as usize * 3;
            Vec3::new(
                mesh.positions[i],
                mesh.positions[i + 1],
                mesh.positions[i + 2],
            )
        };
        for tri in mesh.indices.chunks_exact(3) {
            triangles.push(Triangle::new(pos(tri[0]), pos(tri[1]), pos(tri[2])));
            geometry_ids.push(gid);
        }
        if mesh.positions.iter().any(|c| !c.is_finite()) {
            return Err(diagnose(path, text, "a vertex has a non-finite coordinate"));
        }
    }
    if triangles.is_empty() {
        let what = if text.iter().all(u8::is_ascii_whitespace) {
            "the file is empty"
        } else {
            "it holds no faces"
        };
        return Err(SceneError::Invalid {
            path: path.into(),
            what: format!("no triangles: {what}"),
        });
    }
    Scene::new(name, triangles, geometry_ids, geometry_names)
}

/// The first face line (1-based) with fewer than three corners, and its
/// corners.
fn short_face(text: &[u8]) -> Option<(usize, usize)> {
    (text.split(|&b| b == b'\n').enumerate()).find_map(|(n, line)| {
        let mut words = line
            .split(u8::is_ascii_whitespace)
            .filter(|w| !w.is_empty());
        if words.next() != Some(b"f") {
            return None;
        }
        let corners = words.count();
        (corners < 3).then_some((n + 1, corners))
    })
}

/// Vertices checked as written, before their colours are dropped (a file
/// with a NUL byte is no text: said after).
fn check_vertices(path: &str, text: &[u8]) -> Result<(), SceneError> {
    match bad_vertex(text).filter(|_| !text.contains(&0)) {
        Some((line, what)) => Err(SceneError::Malformed {
            path: path.into(),
            line,
            what,
        }),
        None => Ok(()),
    }
}

/// The first vertex line (1-based) that is not `x y z`, `x y z w` or
/// `x y z r g b` of finite `f32` numbers, and why.
fn bad_vertex(text: &[u8]) -> Option<(usize, String)> {
    let mut seen = 0;
    for (n, line) in text.split(|&b| b == b'\n').enumerate() {
        let mut words = (line.split(u8::is_ascii_whitespace)).filter(|w| !w.is_empty());
        if words.next() != Some(b"v") {
            continue;
        }
        seen += 1;
        let values: Vec<&[u8]> = words.collect();
        if !matches!(values.len(), 3 | 4 | 6) {
            return Some((
                n + 1,
                format!(
                    "vertex {seen} has {} values: a vertex is x y z, x y z w (a weight) or \
                     x y z r g b (a colour)",
                    values.len()
                ),
            ));
        }
        for (i, v) in values.iter().enumerate() {
            let role = match (i, values.len()) {
                (3.., 6) => "'s colour",
                (3.., _) => "'s weight",
                _ => "",
            };
            let c = String::from_utf8_lossy(v);
            if let Err(why) = coordinate(&c, &format!("vertex {seen}{role}")) {
                return Some((n + 1, why));
            }
        }
    }
    None
}

/// Turns a tobj failure into an error that names the line and element, when
/// the scan can find it; otherwise passes on tobj's own words.
fn diagnose(path: &str, text: &[u8], tobj_says: &str) -> SceneError {
    match locate_problem(std::str::from_utf8(text).unwrap_or("")) {
        Some((line, what)) => SceneError::Malformed {
            path: path.into(),
            line,
            what,
        },
        None => SceneError::Invalid {
            path: path.into(),
            what: tobj_says.into(),
        },
    }
}

/// Why a value of an OBJ line is no `f32` coordinate, said of `what`
/// ("vertex 3", "normal 1's colour"): not a number, outside `f32`'s range
/// (`1e39`), or not finite (`nan`, `inf`).
fn coordinate(c: &str, what: &str) -> Result<f32, String> {
    match c.parse::<f32>() {
        Err(_) => Err(format!("{what}: '{c}' is not a number")),
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) if c.parse::<f64>().is_ok_and(f64::is_finite) => Err(format!(
            "{what} has a coordinate '{c}' outside the range of f32 (magnitudes up to 3.4e38)"
        )),
        Ok(_) => Err(format!("{what} has a non-finite coordinate '{c}'")),
    }
}

/// Finds the first line (1-based) that makes the OBJ invalid for us: an
/// unparsable, out-of-range or non-finite vertex (its colour too), normal
/// or texture coordinate; a face whose index is not a number, is zero, or
/// points outside its list.
fn locate_problem(text: &str) -> Option<(usize, String)> {
    let count = |kind: &str| {
        text.lines()
            .filter(|l| l.split_whitespace().next() == Some(kind))
            .count() as i64
    };
    let totals = [count("v"), count("vt"), count("vn")];
    let mut seen = [0i64; 3];
    for (n, line) in text.lines().enumerate() {
        let line_no = n + 1;
        let mut words = line.split_whitespace();
        let first = words.next();
        let list = match first {
            Some("v") => Some((0, "vertex", 3, "coordinates")),
            Some("vt") => Some((1, "texture coordinate", 1, "values")),
            Some("vn") => Some((2, "normal", 3, "components")),
            _ => None,
        };
        if let Some((k, what, least, parts)) = list {
            seen[k] += 1;
            let values: Vec<&str> = words.collect();
            if values.len() < least {
                return Some((
                    line_no,
                    format!("{what} {} has fewer than {least} {parts}", seen[k]),
                ));
            }
            for (i, c) in values.iter().enumerate() {
                // A vertex's 4th value is a weight, or with two more a colour.
                let role = match (k, i, values.len()) {
                    (0, 3.., 6..) => "'s colour",
                    (0, 3.., _) => "'s weight",
                    _ => "",
                };
                if let Err(why) = coordinate(c, &format!("{what} {}{role}", seen[k])) {
                    return Some((line_no, why));
                }
            }
            continue;
        }
        if first != Some("f") {
            continue;
        }
        for corner in words {
            for (k, index) in corner.split('/').enumerate().take(3) {
                // `1//3`: no texture coordinate.
                if k > 0 && index.is_empty() {
                    continue;
                }
                let (list, lists) = [
                    ("vertex", "vertices"),
                    ("texture coordinate", "texture coordinates"),
                    ("normal", "normals"),
                ][k];
                // Of a vertex index the corner is the index; of the
                // others the corner is named beside it.
                let at = match k {
                    0 => String::new(),
                    _ => format!(" in face corner '{corner}'"),
                };
                let Ok(idx) = index.parse::<i64>() else {
                    return Some((
                        line_no,
                        match k {
                            0 => format!("face corner '{corner}' is not a vertex index"),
                            _ => format!("'{index}'{at} is not a {list} index"),
                        },
                    ));
                };
                let resolved = if idx < 0 { seen[k] + idx + 1 } else { idx };
                if idx == 0 || resolved < 1 || resolved > totals[k] {
                    let index_of = match k {
                        0 => "face index".to_string(),
                        _ => format!("{list} index"),
                    };
                    return Some((
                        line_no,
                        format!(
                            "{index_of} {idx}{at} is out of range (the file has {})",
                            match totals[k] {
                                1 => format!("1 {list}"),
                                n => format!("{n} {lists}"),
                            }
                        ),
                    ));
                }
            }
        }
    }
    None
}
