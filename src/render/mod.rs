//! Pictures of a scene through a tree: a shaded image (headlight Lambert)
//! and a heat map of traversal cost per pixel. Rows are traced in parallel
//! with rayon; each pixel's ray is independent, so the image is the same
//! whatever the thread count.

use glam::DVec3;
use image::{Rgb, RgbImage};
use rayon::prelude::*;

use crate::aabb::Aabb;
use crate::bih::{Hit, Ray, RayStats, Tracer};

mod view;
pub use view::{View, ViewsArg, has_viewpoint};

/// The widest or tallest image [`trace`] makes.
pub const MAX_SIDE: u32 = 16_384;
/// The most pixels [`trace`] makes: 64 Mi pixels take about 1.4 GB while
/// traced (about 20 bytes a pixel, measured on a 4000 × 4000 render) and
/// 200 MB as an image.
pub const MAX_PIXELS: u64 = 64 << 20;

/// Checks an image size against [`MAX_SIDE`] and [`MAX_PIXELS`] before
/// anything is allocated.
pub fn check_size(width: u32, height: u32) -> Result<(), String> {
    if width == 0 || height == 0 {
        return Err(format!(
            "an image of {width} × {height} pixels has no pixel"
        ));
    }
    if width > MAX_SIDE || height > MAX_SIDE {
        return Err(format!(
            "an image of {width} × {height} pixels: each side is at most {MAX_SIDE}"
        ));
    }
    if width as u64 * height as u64 > MAX_PIXELS {
        return Err(format!(
            "an image of {width} × {height} pixels: at most {MAX_PIXELS} pixels"
        ));
    }
    Ok(())
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    pub eye: DVec3,
    /// Direction through the image's center, scaled so that the image plane
    /// is at distance 1.
    pub forward: DVec3,
    pub right: DVec3,
    pub up: DVec3,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// A camera that sees the whole box from the front (+z), a little from
    /// above and to the right, with a 45° vertical field of view.
    pub fn framing(bounds: &Aabb, width: u32, height: u32) -> Self {
        let center = (bounds.min.as_dvec3() + bounds.max.as_dvec3()) * 0.5;
        let radius = (bounds.extent_f64().length() * 0.5).max(f64::MIN_POSITIVE);
        let fov = 45f64.to_radians();
        let dist = radius / (fov * 0.5).sin();
        let dir = DVec3::new(0.35, 0.3, 1.0).normalize();
        Self::aimed(center + dir * dist, -dir, DVec3::Y, fov, (width, height))
    }

    /// A camera at `eye` looking along `forward` (of unit length), `up`
    /// the image's up (made square to the view), `fov` radians vertically.
    fn aimed(eye: DVec3, forward: DVec3, up: DVec3, fov: f64, (width, height): (u32, u32)) -> Self {
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        let half = (fov * 0.5).tan();
        Camera {
            eye,
            forward,
            right: right * half * width as f64 / height as f64,
            up: up * half,
            width,
            height,
        }
    }

    /// A camera at `eye` looking at `at`, `up` the image's up (made
    /// square to the view), `fov` degrees vertically.
    pub fn look(eye: DVec3, at: DVec3, up: DVec3, fov: f64, width: u32, height: u32) -> Self {
        let forward = (at - eye).normalize();
        Self::aimed(eye, forward, up, fov.to_radians(), (width, height))
    }

    /// The ray through the center of pixel `(x, y)`, `y = 0` at the top.
    pub fn ray(&self, x: u32, y: u32) -> Ray {
        let sx = (x as f64 + 0.5) / self.width as f64 * 2.0 - 1.0;
        let sy = 1.0 - (y as f64 + 0.5) / self.height as f64 * 2.0;
        Ray::new(self.eye, self.forward + self.right * sx + self.up * sy)
    }

    /// Every pixel's ray, row by row.
    pub fn rays(&self) -> Vec<Ray> {
        (0..self.height)
            .flat_map(|y| (0..self.width).map(move |x| (x, y)))
            .map(|(x, y)| self.ray(x, y))
            .collect()
    }
}

/// The traced image: the closest hit's shading and the cost of each pixel.
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// Gray level in [0, 1] per pixel, `None` where the ray missed.
    pub shade: Vec<Option<f32>>,
    /// Nodes visited + triangles tested per pixel.
    pub cost: Vec<u32>,
    pub stats: RayStats,
}

/// Traces one ray per pixel.
pub fn trace(tracer: &Tracer, scene_triangles: &[crate::scene::Triangle], cam: &Camera) -> Frame {
    let rows: Vec<(Vec<Option<f32>>, Vec<u32>, RayStats)> = (0..cam.height)
        .into_par_iter()
        .map(|y| {
            let mut row_stats = RayStats::default();
            let mut shade = Vec::with_capacity(cam.width as usize);
            let mut cost = Vec::with_capacity(cam.width as usize);
            for x in 0..cam.width {
                let ray = cam.ray(x, y);
                let mut s = RayStats::default();
                let hit = tracer.closest(&ray, &mut s);
                shade.push(shading(scene_triangles, &ray, hit));
                cost.push((s.nodes_visited + s.triangles_tested) as u32);
                row_stats += s;
            }
            (shade, cost, row_stats)
        })
        .collect();
    let mut f = Frame {
        width: cam.width,
        height: cam.height,
        shade: Vec::new(),
        cost: Vec::new(),
        stats: RayStats::default(),
    };
    for (s, c, st) in rows {
        f.shade.extend(s);
        f.cost.extend(c);
        f.stats += st;
    }
    f
}

/// A headlight Lambert gray for the ray's hit, `None` for a miss.
fn shading(triangles: &[crate::scene::Triangle], ray: &Ray, hit: Option<Hit>) -> Option<f32> {
    hit.map(|h| {
        let t = &triangles[h.prim as usize];
        let [a, b, c] = t.v.map(|p| p.as_dvec3());
        let n = (b - a).cross(c - a).normalize_or_zero();
        (0.15 + 0.85 * n.dot(ray.dir.normalize()).abs()) as f32
    })
}

impl Frame {
    /// The frame of hits cast elsewhere (on the emulated Cell,
    /// `crate::cast`): `hits` and `costs` (nodes + triangles) are the
    /// camera's rays' in [`Camera::rays`] order. Shaded as [`trace`]
    /// shades, so the same hits make the same image.
    pub fn of_hits(
        cam: &Camera,
        triangles: &[crate::scene::Triangle],
        hits: &[Option<Hit>],
        costs: &[u32],
        stats: RayStats,
    ) -> Frame {
        assert_eq!(hits.len(), (cam.width * cam.height) as usize);
        let rays = (0..cam.height).flat_map(|y| (0..cam.width).map(move |x| cam.ray(x, y)));
        Frame {
            width: cam.width,
            height: cam.height,
            shade: (rays.zip(hits))
                .map(|(r, &h)| shading(triangles, &r, h))
                .collect(),
            cost: costs.to_vec(),
            stats,
        }
    }

    /// The shaded image: gray surfaces on a dark blue background.
    pub fn shaded(&self) -> RgbImage {
        RgbImage::from_fn(self.width, self.height, |x, y| {
            match self.shade[(y * self.width + x) as usize] {
                Some(g) => {
                    let v = (g.clamp(0.0, 1.0) * 255.0) as u8;
                    Rgb([v, v, v])
                }
                None => Rgb([20, 24, 48]),
            }
        })
    }

    /// The heat map: cost per pixel on a black–blue–red–yellow–white ramp,
    /// scaled so that white is the largest cost in the frame.
    pub fn heatmap(&self) -> RgbImage {
        let max = self.cost.iter().copied().max().unwrap_or(1).max(1) as f32;
        RgbImage::from_fn(self.width, self.height, |x, y| {
            ramp(self.cost[(y * self.width + x) as usize] as f32 / max)
        })
    }

    pub fn max_cost(&self) -> u32 {
        self.cost.iter().copied().max().unwrap_or(0)
    }
}

/// Black → blue → red → yellow → white for `t` in [0, 1].
fn ramp(t: f32) -> Rgb<u8> {
    const STOPS: [[f32; 3]; 5] = [
        [0.0, 0.0, 0.0],
        [0.1, 0.2, 0.9],
        [0.9, 0.1, 0.1],
        [1.0, 0.9, 0.1],
        [1.0, 1.0, 1.0],
    ];
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f32;
    let i = (x as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    let c: [u8; 3] =
        std::array::from_fn(|k| ((STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f) * 255.0) as u8);
    Rgb(c)
}
