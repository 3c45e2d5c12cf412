//! Where the camera stands: the scene's own viewpoint (inside the indoor
//! scenes, where the ray tracing literature renders them: the atrium of
//! Sponza, the nave of Šibenik), a named viewpoint, the framing view from
//! outside the scene's box, or an eye, a point looked at and a field of
//! view given on the command line (`--camera`).

use glam::DVec3;

use super::Camera;
use crate::aabb::Aabb;

/// A viewpoint of a mesh of the data directory, in the mesh's own
/// coordinates (both indoor meshes stand with +z up).
struct Viewpoint {
    /// The mesh's name, as `--scene` takes it.
    scene: &'static str,
    name: &'static str,
    eye: [f64; 3],
    at: [f64; 3],
    up: [f64; 3],
    /// Vertical field of view, degrees.
    fov: f64,
}

/// The viewpoints; a scene's first is its default.
const VIEWPOINTS: &[Viewpoint] = &[
    // Dabrovic's Sponza atrium (x from −17.4 to 17.4 along the atrium,
    // z up to 15.6): from the atrium's floor near one end, looking down
    // its length.
    Viewpoint {
        scene: "sponza-dabrovic",
        name: "atrium",
        eye: [-14.0, 0.0, 2.0],
        at: [10.0, 0.0, 5.0],
        up: [0.0, 0.0, 1.0],
        fov: 60.0,
    },
    // Šibenik cathedral (the mesh holds the square around it too: x from
    // −1,360 to 1,594, z up to 717; the nave runs along x, from the
    // entrance near x = 600 to the dome over x = 0): in the nave near the
    // entrance, looking down it to the altar.
    Viewpoint {
        scene: "sibenik",
        name: "nave",
        eye: [520.0, 40.0, 120.0],
        at: [-300.0, 40.0, 220.0],
        up: [0.0, 0.0, 1.0],
        fov: 70.0,
    },
];

/// What `--camera` asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum View {
    /// The scene's own viewpoint, or the framing view where it has none.
    Default,
    /// The whole box seen from outside ([`Camera::framing`]).
    Framing,
    /// A viewpoint by name (`atrium`, `nave`).
    Named(String),
    /// An eye, a point it looks at, +z or +y up (whichever is less
    /// parallel to the view), a vertical field of view in degrees.
    Look { eye: DVec3, at: DVec3, fov: f64 },
}

impl View {
    /// Reads `default`, `framing`, a viewpoint's name, or
    /// `EX,EY,EZ:AX,AY,AZ[:FOV]`.
    pub fn parse(s: &str) -> Result<View, String> {
        let bad = |why: &str| {
            format!(
                "--camera {s}: {why}; give default, framing, a viewpoint ({}) or EX,EY,EZ:AX,AY,AZ[:FOV]",
                names().join(", ")
            )
        };
        match s {
            "default" => return Ok(View::Default),
            "framing" => return Ok(View::Framing),
            _ => {}
        }
        if VIEWPOINTS.iter().any(|v| v.name == s) {
            return Ok(View::Named(s.to_string()));
        }
        if !s.contains(':') {
            return Err(bad("no such viewpoint"));
        }
        let parts: Vec<&str> = s.split(':').collect();
        if !(2..=3).contains(&parts.len()) {
            return Err(bad(
                "an eye and a point looked at, and at most a field of view",
            ));
        }
        let point = |p: &str| -> Result<DVec3, String> {
            let v: Vec<f64> = (p.split(','))
                .map(|c| c.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| bad(&format!("{p:?} is not three numbers")))?;
            match v.as_slice() {
                &[x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(x, y, z)),
                _ => Err(bad(&format!("{p:?} is not three finite numbers"))),
            }
        };
        let (eye, at) = (point(parts[0])?, point(parts[1])?);
        if eye == at {
            return Err(bad("the eye and the point looked at are the same"));
        }
        let fov = match parts.get(2) {
            None => 45.0,
            Some(f) => match f.parse::<f64>() {
                Ok(f) if f > 0.0 && f < 180.0 => f,
                _ => {
                    return Err(bad(&format!(
                        "field of view {f:?}: degrees above 0, below 180"
                    )));
                }
            },
        };
        Ok(View::Look { eye, at, fov })
    }

    /// The camera for scene `scene` (its name as loaded) with bounds
    /// `bounds`, `width` × `height` pixels; a named viewpoint of another
    /// scene is an error that names the scenes it belongs to.
    pub fn camera(
        &self,
        scene: &str,
        bounds: &Aabb,
        width: u32,
        height: u32,
    ) -> Result<Camera, String> {
        let stem = scene.trim_end_matches(".gz").trim_end_matches(".obj");
        let of = |v: &Viewpoint| {
            let f = |a: [f64; 3]| DVec3::from_array(a);
            Camera::look(f(v.eye), f(v.at), f(v.up), v.fov, width, height)
        };
        Ok(match self {
            View::Default => match VIEWPOINTS.iter().find(|v| v.scene == stem) {
                Some(v) => of(v),
                None => Camera::framing(bounds, width, height),
            },
            View::Framing => Camera::framing(bounds, width, height),
            View::Named(n) => match VIEWPOINTS.iter().find(|v| v.name == n && v.scene == stem) {
                Some(v) => of(v),
                None => {
                    let owner = VIEWPOINTS.iter().find(|v| v.name == n).map(|v| v.scene);
                    return Err(format!(
                        "--camera {n}: a viewpoint of {}, not of {scene}",
                        owner.unwrap_or("no scene")
                    ));
                }
            },
            View::Look { eye, at, fov } => {
                let dir = (*at - *eye).normalize();
                let up = if dir.z.abs() < 0.9 {
                    DVec3::Z
                } else {
                    DVec3::Y
                };
                Camera::look(*eye, *at, up, *fov, width, height)
            }
        })
    }

    /// How the view is spelled on the command line.
    pub fn spelled(&self) -> String {
        match self {
            View::Default => "default".into(),
            View::Framing => "framing".into(),
            View::Named(n) => n.clone(),
            View::Look { eye, at, fov } => format!(
                "{},{},{}:{},{},{}:{fov}",
                eye.x, eye.y, eye.z, at.x, at.y, at.z
            ),
        }
    }
}

/// The named viewpoints.
pub fn names() -> Vec<&'static str> {
    VIEWPOINTS.iter().map(|v| v.name).collect()
}

/// Whether `scene` (its name as loaded) has a viewpoint of its own, which
/// [`View::Default`] takes.
pub fn has_viewpoint(scene: &str) -> bool {
    let stem = scene.trim_end_matches(".gz").trim_end_matches(".obj");
    VIEWPOINTS.iter().any(|v| v.scene == stem)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn views_parse_and_refuse() {
        assert_eq!(View::parse("default"), Ok(View::Default));
        assert_eq!(View::parse("atrium"), Ok(View::Named("atrium".into())));
        let v = View::parse("0,0,5:0,0,0:30").unwrap();
        assert_eq!(
            v,
            View::Look {
                eye: DVec3::new(0.0, 0.0, 5.0),
                at: DVec3::ZERO,
                fov: 30.0
            }
        );
        assert_eq!(View::parse(&v.spelled()), Ok(v));
        for bad in [
            "hall",
            "1,2:3,4,5",
            "0,0,0:0,0,0",
            "0,0,1:0,0,0:180",
            "0,0,1:0,0,0:x",
            "1,2,nan:0,0,0",
        ] {
            assert!(View::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_default_is_inside_where_a_scene_has_a_viewpoint() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let inside = View::Default
            .camera("sponza-dabrovic.obj", &b, 64, 48)
            .unwrap();
        assert_eq!(inside.eye, DVec3::new(-14.0, 0.0, 2.0));
        let outside = View::Default.camera("bunny.obj", &b, 64, 48).unwrap();
        assert_eq!(outside.eye, Camera::framing(&b, 64, 48).eye);
        assert!(
            View::Named("nave".into())
                .camera("bunny.obj", &b, 8, 8)
                .is_err()
        );
        assert!(has_viewpoint("sibenik.obj") && !has_viewpoint("dragon.obj"));
    }
}
