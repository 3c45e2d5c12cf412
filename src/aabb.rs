//! Axis-aligned bounding boxes, the one box type of the crate.
//!
//! Boxes are `f32` like the scene's vertices. An *empty* box has `min = +inf`
//! and `max = -inf`, so that growing it by any point gives that point's box.

use glam::{DVec3, Vec3};

/// An axis-aligned box; `min <= max` on every axis unless it is [`Aabb::EMPTY`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    /// The box that contains nothing: the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min, max }
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    #[must_use]
    pub fn grow(self, p: Vec3) -> Self {
        Aabb::new(self.min.min(p), self.max.max(p))
    }

    #[must_use]
    pub fn union(self, o: Aabb) -> Self {
        Aabb::new(self.min.min(o.min), self.max.max(o.max))
    }

    pub fn center(&self) -> Vec3 {
        self.min * 0.5 + self.max * 0.5
    }

    /// `max - min` in `f32`: infinite on an axis where the box spans more
    /// than `f32::MAX` (a scene from -3e38 to 3e38). Use
    /// [`Aabb::extent_f64`] wherever that can happen.
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// `max - min` in `f64`: finite for every box of finite `f32` bounds.
    pub fn extent_f64(&self) -> DVec3 {
        self.max.as_dvec3() - self.min.as_dvec3()
    }

    /// The axis (0 = x, 1 = y, 2 = z) on which the box is longest; ties go to
    /// the lower axis, so the choice is the same on every host. Compared in
    /// `f64`, so that two axes that both span more than `f32::MAX` are still
    /// told apart.
    pub fn longest_axis(&self) -> usize {
        let e = self.extent_f64();
        if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        }
    }

    /// Surface area, in `f64` so that boxes of 1e15 or 1e-15 neither
    /// overflow nor underflow. An empty box has area 0.
    pub fn surface_area(&self) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent_f64();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// The boxes share at least a point (touching counts).
    pub fn overlaps(&self, o: &Aabb) -> bool {
        self.min.cmple(o.max).all() && o.min.cmple(self.max).all()
    }

    pub fn contains_box(&self, o: &Aabb) -> bool {
        self.min.cmple(o.min).all() && o.max.cmple(self.max).all()
    }
}
