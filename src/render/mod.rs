//! Pictures of a scene through a tree: a shaded image (headlight Lambert)
//! and a heat map of traversal cost per pixel. Rows are traced in parallel
//! with rayon; each pixel's ray is independent, so the image is the same
//! whatever the thread count.

use glam::DVec3;
use image::{Rgb, RgbImage};
use rayon::prelude::*;

use crate::aabb::Aabb;
use crate::bih::{Hit, PACKET_RAYS, Ray, RayStats, Tracer};

mod view;
pub use view::{View, has_viewpoint};

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

    /// Every pixel's ray in blocks of `bw × bh` pixels ([`block_order`]),
    /// the order packets of rays take them.
    pub fn rays_in_blocks(&self, bw: u32, bh: u32) -> Vec<Ray> {
        (block_order(self.width, self.height, bw, bh).iter())
            .map(|&i| self.ray(i % self.width, i / self.width))
            .collect()
    }

    /// Every pixel's ray, row by row.
    pub fn rays(&self) -> Vec<Ray> {
        (0..self.height)
            .flat_map(|y| (0..self.width).map(move |x| (x, y)))
            .map(|(x, y)| self.ray(x, y))
            .collect()
    }
}

/// The pixels of a `width × height` image (`y * width + x`) in blocks of
/// `bw × bh`: block after block along each band of `bh` rows, each block
/// row by row; edge blocks are cut to the image. Packets of rays
/// (`crate::cast`'s on the SPEs, [`Tracer::closest_all`] on the host)
/// take consecutive rays of this order.
pub fn block_order(width: u32, height: u32, bw: u32, bh: u32) -> Vec<u32> {
    let mut out = Vec::with_capacity(width as usize * height as usize);
    for by in (0..height).step_by(bh as usize) {
        for bx in (0..width).step_by(bw as usize) {
            for y in by..(by + bh).min(height) {
                out.extend((bx..(bx + bw).min(width)).map(|x| y * width + x));
            }
        }
    }
    out
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

/// Traces one ray per pixel, bands of four rows in parallel, each band's
/// rays as 4 × 4 packets ([`Tracer::closest_packet`]: the single-ray
/// walk's hits and costs).
pub fn trace(tracer: &Tracer, scene_triangles: &[crate::scene::Triangle], cam: &Camera) -> Frame {
    const B: u32 = 4;
    let w = cam.width;
    let bands: Vec<(Vec<Option<f32>>, Vec<u32>, RayStats)> = (0..cam.height.div_ceil(B))
        .into_par_iter()
        .map(|band| {
            let y0 = band * B;
            let h = B.min(cam.height - y0);
            let n = (w * h) as usize;
            let (mut shade, mut cost) = (vec![None; n], vec![0; n]);
            let mut band_stats = RayStats::default();
            let order = block_order(w, h, B, B);
            let rays: Vec<Ray> = (order.iter())
                .map(|&i| cam.ray(i % w, y0 + i / w))
                .collect();
            let mut hits = [None; PACKET_RAYS];
            let mut each = [RayStats::default(); PACKET_RAYS];
            for (r, at) in rays.chunks(PACKET_RAYS).zip(order.chunks(PACKET_RAYS)) {
                let k = r.len();
                each[..k].fill(RayStats::default());
                tracer.closest_packet(r, &mut hits[..k], &mut each[..k]);
                for j in 0..k {
                    let i = at[j] as usize;
                    shade[i] = shading(scene_triangles, &r[j], hits[j]);
                    cost[i] = (each[j].nodes_visited + each[j].triangles_tested) as u32;
                    band_stats += each[j];
                }
            }
            (shade, cost, band_stats)
        })
        .collect();
    let mut f = Frame {
        width: cam.width,
        height: cam.height,
        shade: Vec::new(),
        cost: Vec::new(),
        stats: RayStats::default(),
    };
    for (s, c, st) in bands {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_cover_every_pixel_once_in_blocks() {
        let order = block_order(10, 7, 4, 2);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..70).collect::<Vec<_>>());
        // The first block: rows 0 and 1, columns 0 to 3.
        assert_eq!(&order[..8], &[0, 1, 2, 3, 10, 11, 12, 13]);
        // The band's last block is cut to columns 8 and 9.
        assert_eq!(&order[16..20], &[8, 9, 18, 19]);
        assert_eq!(block_order(3, 2, 1, 1), (0..6).collect::<Vec<_>>());
    }
}
