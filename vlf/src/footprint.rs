//! What a pixel covers on the surface it sees: the running means carry an estimate only
//! within it ([`crate::pixel_direct`]), and the caustics are averaged over it
//! ([`crate::caustics`]), as the path tracer averages a pixel.

use glam::Vec3;
use holocave_cave::WallView;

use crate::pixel_direct::DirectPoint;

/// The screen of a view, as a pixel's footprint needs it.
#[derive(Clone, Copy, Debug)]
pub struct Screen {
    pub eye: Vec3,
    /// Metres per pixel on the screen.
    pub pixel: f32,
    /// The screen's unit normal.
    pub normal: Vec3,
    /// The eye's distance from the screen's plane.
    pub to_screen: f32,
}

/// The ellipse on a surface that a pixel covers: its centre, the unit direction of the
/// view's trace on the surface, and its half-axes along that trace and across it.
#[derive(Clone, Copy, Debug)]
pub struct Ellipse {
    pub centre: Vec3,
    pub trace: Vec3,
    pub along: f32,
    pub across: f32,
}

impl Screen {
    /// The screen of `view`, its pixels divided into `k × k`.
    pub fn of(view: &WallView, k: u32) -> Screen {
        let normal = (view.pb - view.pa)
            .cross(view.pc - view.pa)
            .normalize_or_zero();
        Screen {
            eye: view.eye,
            pixel: (view.pb - view.pa).length() / (view.size.width * k.max(1)) as f32,
            normal,
            to_screen: (view.pa - view.eye).dot(normal).abs(),
        }
    }

    /// The footprint of the pixel that sees `p` straight from the eye, `scale` pixels
    /// wide. At the point's depth a pixel covers `pixel · depth / to_screen` in the plane
    /// parallel to the screen; on the surface, that square is stretched along the view's
    /// trace by `cos(screen) / cos(surface)` (a floor seen at a grazing angle from a wall:
    /// many times) and keeps its width across.
    pub fn footprint(&self, p: &DirectPoint, scale: f32) -> Ellipse {
        let v = p.position - self.eye;
        let dir = v.normalize_or_zero();
        let depth_cos = dir.dot(self.normal).abs();
        let width = self.pixel * v.length() * depth_cos / self.to_screen.max(f32::MIN_POSITIVE);
        let length = width * depth_cos / dir.dot(p.normal).abs().max(1e-3);
        Ellipse {
            centre: p.position,
            trace: (dir - p.normal * p.normal.dot(dir)).normalize_or_zero(),
            along: length * scale,
            across: width * scale,
        }
    }
}

/// How the point a pixel's ray finds on the plane of `p` (through `p.position`, normal
/// `p.normal`) moves as the ray sweeps one cell of the pixel divided into `k × k`: across
/// the cell's width and down its height. Within a pixel the map from the screen to the
/// plane is affine up to the pixel's angle squared, so the cell covers `p.position + s ·
/// span[0] + t · span[1]`, `s, t ∈ [−½, ½]`, on the plane. Zero where the plane or the
/// screen is seen edge on.
pub fn pixel_span(view: &WallView, k: u32, p: &DirectPoint) -> [Vec3; 2] {
    let k = k.max(1) as f32;
    let across = (view.pb - view.pa) / (view.size.width as f32 * k);
    let down = (view.pa - view.pc) / (view.size.height as f32 * k);
    let screen = (view.pb - view.pa).cross(view.pc - view.pa);
    let v = p.position - view.eye;
    // The ray through the cell's centre meets the screen at `eye + d` and the point at
    // `eye + t d`; moved by `δ` on the screen, it meets the plane `t (δ − d (n·δ)/(n·d))`
    // further on.
    let d = v * ((view.pa - view.eye).dot(screen) / v.dot(screen));
    let t = v.dot(screen) / (view.pa - view.eye).dot(screen);
    let n = p.normal;
    let moved = |delta: Vec3| t * (delta - d * (n.dot(delta) / n.dot(d)));
    let span = [moved(across), moved(down)];
    if span.iter().all(|s| s.is_finite()) {
        span
    } else {
        [Vec3::ZERO; 2]
    }
}

impl Ellipse {
    pub fn contains(&self, q: Vec3) -> bool {
        let d = q - self.centre;
        let along = d.dot(self.trace);
        let across = (d - self.trace * along).length();
        (along / self.along).powi(2) + (across / self.across).powi(2) <= 1.0
    }

    pub fn area(&self) -> f32 {
        std::f32::consts::PI * self.along * self.across
    }
}
