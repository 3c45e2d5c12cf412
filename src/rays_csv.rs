//! The ray and hit files of `cellbih raycast`, a contract other tools rely
//! on.
//!
//! Rays: header `ox,oy,oz,dx,dy,dz,tmin,tmax`, then one ray a line; numbers
//! are decimal (`inf` allowed for `tmax`); the direction need not be
//! normalized and `t` is in units of it, but it must have a normal
//! (not subnormal) component: a direction such as `(0, 0, -1e-320)` would
//! put every hit at a `t` beyond `f64`, and is an error naming its line;
//! so is a component beyond ±1e200 ([`MAX_COMPONENT`]), which would
//! overflow the triangle test's arithmetic in `f64`. `raycast` traces each ray
//! at unit scale ([`Ray::at_unit_scale`]), so that origin and direction
//! may both be that large. A UTF-8 byte-order mark before the header is
//! skipped.
//!
//! Hits: header `ray,prim,t`, one line per ray in input order; `prim` is the
//! 0-based triangle id, a miss is `-1` with an empty `t`. `t` is written
//! with the shortest decimal that reads back as the same `f64`.

use std::io::{BufRead, Write};

use glam::DVec3;
use thiserror::Error;

use crate::bih::{Hit, Ray};
use crate::text_input::TextError;

/// The largest magnitude an origin or direction component may have: up
/// to here the offsets from the origin to the scene's coordinates (up to
/// 3.4e38) and the slab distances stay far inside `f64`. The triangle
/// test resolves a triangle where its size is well above the origin's
/// precision (`|o|·2⁻⁵³`: docs/tree.md, "The triangle test"); beyond
/// that every path gives the same answer, a hit or a miss.
pub const MAX_COMPONENT: f64 = 1e200;

pub const RAYS_HEADER: &str = "ox,oy,oz,dx,dy,dz,tmin,tmax";
pub const HITS_HEADER: &str = "ray,prim,t";

#[derive(Debug, Error)]
pub enum RaysError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}:1: the header must be '{RAYS_HEADER}', found '{found}'")]
    Header { path: String, found: String },
    #[error("{path}:{line}: {what}")]
    Line {
        path: String,
        line: usize,
        what: String,
    },
}

/// Reads a ray file; `path` names it in errors, with the line.
pub fn read_rays(path: &str, input: impl BufRead) -> Result<Vec<Ray>, RaysError> {
    let io = |source| RaysError::Io {
        path: path.into(),
        source,
    };
    let mut rays = Vec::new();
    let mut saw_header = false;
    let mut lines = crate::text_input::Lines::new(input);
    loop {
        let (line_no, line) = match lines.next_line() {
            Ok(Some(l)) => l,
            Ok(None) => break,
            Err(TextError::Io(e)) => return Err(io(e)),
            Err(TextError::LongLine { line }) => {
                return Err(RaysError::Line {
                    path: path.into(),
                    line,
                    what: format!(
                        "longer than {} MiB without a newline: not a ray file",
                        crate::text_input::MAX_LINE_BYTES >> 20
                    ),
                });
            }
            Err(e @ TextError::Nul { line, .. }) => {
                return Err(RaysError::Line {
                    path: path.into(),
                    line,
                    what: e.to_string(),
                });
            }
        };
        let Ok(line) = std::str::from_utf8(&line) else {
            return Err(RaysError::Line {
                path: path.into(),
                line: line_no,
                what: "not UTF-8 text".into(),
            });
        };
        if !saw_header {
            saw_header = true;
            let header = line.strip_prefix('\u{feff}').unwrap_or(line);
            if header.trim() != RAYS_HEADER {
                return Err(RaysError::Header {
                    path: path.into(),
                    found: short(header.trim_end()),
                });
            }
            continue;
        }
        if line.trim().is_empty() {
            continue;
        }
        let bad = |what: String| RaysError::Line {
            path: path.into(),
            line: line_no,
            what,
        };
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != 8 {
            return Err(bad(format!("expected 8 fields, found {}", fields.len())));
        }
        let mut v = [0f64; 8];
        for (k, f) in fields.iter().enumerate() {
            v[k] = f
                .parse()
                .map_err(|_| bad(format!("field {} ('{}') is not a number", k + 1, short(f))))?;
        }
        if v[..6].iter().any(|x| !x.is_finite()) {
            return Err(bad("origin and direction must be finite".into()));
        }
        if let Some(x) = v[..6].iter().find(|x| x.abs() > MAX_COMPONENT) {
            return Err(bad(format!(
                "{x:e} is beyond ±1e200: the triangle test shears the offsets from the \
                 origin to the scene's coordinates by the direction, and f64 would overflow \
                 (a hit at finite t is then missed); scale the ray"
            )));
        }
        if v[3..6].iter().all(|&x| x == 0.0) {
            return Err(bad("the direction is zero".into()));
        }
        if v[3..6].iter().all(|&x| x.abs() < f64::MIN_POSITIVE) {
            return Err(bad(
                "the direction is too short: every component is subnormal (below 2.2e-308), \
                 so a hit's t in its units would overflow f64; scale it up"
                    .into(),
            ));
        }
        if v[6].is_nan() || v[7].is_nan() {
            return Err(bad("tmin and tmax must not be NaN".into()));
        }
        rays.push(Ray {
            origin: DVec3::new(v[0], v[1], v[2]),
            dir: DVec3::new(v[3], v[4], v[5]),
            tmin: v[6],
            tmax: v[7],
        });
    }
    if !saw_header {
        return Err(RaysError::Header {
            path: path.into(),
            found: String::new(),
        });
    }
    Ok(rays)
}

/// `s`, cut to 60 characters for an error message.
/// A field as an error quotes it: at most 60 characters, control
/// characters escaped (a binary file must not drive the terminal).
fn short(s: &str) -> String {
    let shown = |t: &str| -> String { t.chars().flat_map(char::escape_default).collect() };
    let plain = |t: &str| t.chars().any(char::is_control);
    let cut = match s.char_indices().nth(60) {
        Some((i, _)) => &s[..i],
        None => s,
    };
    let text = if plain(cut) {
        shown(cut)
    } else {
        cut.to_string()
    };
    match cut.len() < s.len() {
        true => format!("{text}…"),
        false => text,
    }
}

/// Writes one line per ray, in order.
pub fn write_hits(mut out: impl Write, hits: &[Option<Hit>]) -> std::io::Result<()> {
    writeln!(out, "{HITS_HEADER}")?;
    for (i, h) in hits.iter().enumerate() {
        match h {
            Some(h) => writeln!(out, "{i},{},{:?}", h.prim, h.t)?,
            None => writeln!(out, "{i},-1,")?,
        }
    }
    Ok(())
}

/// Writes a ray file (used by tests and by tools that make rays).
pub fn write_rays(mut out: impl Write, rays: &[Ray]) -> std::io::Result<()> {
    writeln!(out, "{RAYS_HEADER}")?;
    for r in rays {
        let (o, d) = (r.origin, r.dir);
        writeln!(
            out,
            "{:?},{:?},{:?},{:?},{:?},{:?},{:?},{}",
            o.x,
            o.y,
            o.z,
            d.x,
            d.y,
            d.z,
            r.tmin,
            if r.tmax.is_infinite() {
                "inf".to_string()
            } else {
                format!("{:?}", r.tmax)
            }
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_round_trip_and_errors_name_the_line() {
        let rays = vec![
            Ray {
                origin: DVec3::new(1e-15, -2.5, 3.0),
                dir: DVec3::new(0.0, -0.0, 1e15),
                tmin: 0.0,
                tmax: f64::INFINITY,
            },
            Ray {
                origin: DVec3::ZERO,
                dir: DVec3::X,
                tmin: 0.125,
                tmax: 7.0,
            },
        ];
        let mut buf = Vec::new();
        write_rays(&mut buf, &rays).unwrap();
        let back = read_rays("r.csv", &buf[..]).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(
            back[0].dir.y.to_bits(),
            (-0.0f64).to_bits(),
            "the sign of a zero survives"
        );
        assert_eq!(back, rays);
        let e = read_rays("r.csv", "ox,oy,oz,dx,dy,dz,tmin,tmax\n1,2,3\n".as_bytes()).unwrap_err();
        assert_eq!(e.to_string(), "r.csv:2: expected 8 fields, found 3");
        let e = read_rays(
            "r.csv",
            "ox,oy,oz,dx,dy,dz,tmin,tmax\n0,0,0,0,0,0,0,1\n".as_bytes(),
        )
        .unwrap_err();
        assert_eq!(e.to_string(), "r.csv:2: the direction is zero");
        let e = read_rays(
            "r.csv",
            "ox,oy,oz,dx,dy,dz,tmin,tmax\nnan,0,0,1,0,0,0,1\n".as_bytes(),
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "r.csv:2: origin and direction must be finite"
        );
        let e = read_rays(
            "r.csv",
            "ox,oy,oz,dx,dy,dz,tmin,tmax\n0,0,1,0,0,-1e-320,0,inf\n".as_bytes(),
        )
        .unwrap_err();
        assert!(
            e.to_string()
                .starts_with("r.csv:2: the direction is too short"),
            "{e}"
        );
        // A direction with one normal component is fine, however small the
        // others are.
        let ok = "ox,oy,oz,dx,dy,dz,tmin,tmax\n0,0,1,1e-320,0,-1e-300,0,inf\n";
        assert_eq!(read_rays("r.csv", ok.as_bytes()).unwrap().len(), 1);
    }

    #[test]
    fn a_byte_order_mark_before_the_header_is_skipped() {
        let text = "\u{feff}ox,oy,oz,dx,dy,dz,tmin,tmax\n0,0,0,1,0,0,0,inf\n";
        let rays = read_rays("bom.csv", text.as_bytes()).unwrap();
        assert_eq!(rays.len(), 1);
        // A mark anywhere else is still an error.
        let e = read_rays("x.csv", "ox,oy\u{feff}".as_bytes()).unwrap_err();
        assert!(
            e.to_string().starts_with("x.csv:1: the header must be"),
            "{e}"
        );
    }

    #[test]
    fn misses_have_an_empty_t() {
        let mut buf = Vec::new();
        write_hits(
            &mut buf,
            &[
                None,
                Some(Hit {
                    prim: 3,
                    t: 0.1,
                    u: 0.0,
                    v: 0.0,
                }),
            ],
        )
        .unwrap();
        assert_eq!(
            String::from_utf8(buf).unwrap(),
            "ray,prim,t\n0,-1,\n1,3,0.1\n"
        );
    }
}
