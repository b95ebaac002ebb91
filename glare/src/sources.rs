//! Glare sources, found by `evalglare`'s rules ([`crate::rules::Rules`]):
//!
//! 1. every pixel in the view brighter than the threshold is a source pixel;
//! 2. source pixels merge into one source when `2 · angle ≤ search_radius` between their
//!    centres' directions, or when a chain of such pixels joins them (`evalglare` grows
//!    sources pixel by pixel in a first scan and joins the sources that touch in a second
//!    one until nothing changes; the result is these connected groups);
//! 3. peak extraction: the pixels of a source at or above the peak limit are split off,
//!    merged among themselves by the same rule, into sources of their own; the rest of
//!    the source stays one source;
//! 4. a source's solid angle is the sum of its pixels', its luminance their mean weighted
//!    by solid angle, its position the mean of its pixels' image positions weighted the
//!    same way (as `evalglare`'s `add_pixel_to_gs`), its direction the one seen there and
//!    its position index [`crate::position_index`] of that direction.
//!
//! Not done (off in `evalglare` unless asked for): smoothing (`-s`), task areas (`-t`),
//! luminance limits (`-m`), masks and zones.

use glam::DVec3;

use crate::fisheye::Fisheye;
use crate::position_index::position_index;

/// One glare source.
#[derive(Clone, Debug, PartialEq)]
pub struct Source {
    /// Unit direction from the eye, scene coordinates.
    pub direction: DVec3,
    /// Where it is in the fisheye: the solid-angle-weighted mean image position, pixels
    /// from the top-left corner.
    pub position: (f64, f64),
    pub solid_angle_sr: f64,
    /// Mean luminance, cd/m², weighted by solid angle.
    pub luminance_cd_m2: f64,
    pub position_index: f64,
    /// Split off by peak extraction.
    pub peak: bool,
    /// Its pixels (indices, rows from the top).
    pub pixels: Vec<u32>,
}

impl Source {
    /// Its term of DGP's and UGR's sums: `L² ω / P²`.
    pub fn glare_term(&self) -> f64 {
        (self.luminance_cd_m2 / self.position_index).powi(2) * self.solid_angle_sr
    }
}

/// A disjoint-set forest over `n` items (union by size, path halving).
struct Sets {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl Sets {
    fn new(n: usize) -> Self {
        Sets {
            parent: (0..n as u32).collect(),
            size: vec![1; n],
        }
    }

    fn root(&mut self, mut a: u32) -> u32 {
        while self.parent[a as usize] != a {
            let p = self.parent[a as usize];
            self.parent[a as usize] = self.parent[p as usize];
            a = p;
        }
        a
    }

    fn join(&mut self, a: u32, b: u32) {
        let (mut a, mut b) = (self.root(a), self.root(b));
        if a == b {
            return;
        }
        if self.size[a as usize] < self.size[b as usize] {
            std::mem::swap(&mut a, &mut b);
        }
        self.parent[b as usize] = a;
        self.size[a as usize] += self.size[b as usize];
    }
}

/// The groups of `pixels` (indices into the fisheye) joined by chains of pairs whose
/// directions are at most `angle` radians apart; each group in scan order, the groups in
/// the order of their first pixel.
pub fn merge(
    fisheye: &Fisheye,
    dirs: &[Option<DVec3>],
    pixels: &[u32],
    angle: f64,
) -> Vec<Vec<u32>> {
    let n = fisheye.size as i64;
    let mut slot = vec![u32::MAX; dirs.len()];
    for (s, &p) in pixels.iter().enumerate() {
        slot[p as usize] = s as u32;
    }
    // Two directions `angle` apart are at most (π/2)·angle/k pixels apart in the image:
    // the equidistant mapping stretches tangential distances by θ/sin θ ≤ π/2 on the
    // hemisphere, and the arc between them stays in it.
    let reach =
        (std::f64::consts::FRAC_PI_2 * angle / fisheye.radians_per_pixel()).ceil() as i64 + 1;
    let cos_limit = angle.cos();
    let mut sets = Sets::new(pixels.len());
    for (s, &p) in pixels.iter().enumerate() {
        let (x, y) = (i64::from(p) % n, i64::from(p) / n);
        let Some(d) = dirs[p as usize] else { continue };
        for dy in 0..=reach {
            let qy = y + dy;
            if qy >= n {
                break;
            }
            let from = if dy == 0 { 1 } else { -reach };
            for dx in from..=reach {
                let qx = x + dx;
                if !(0..n).contains(&qx) {
                    continue;
                }
                let q = (qy * n + qx) as usize;
                let t = slot[q];
                if t == u32::MAX {
                    continue;
                }
                if let Some(e) = dirs[q]
                    && d.dot(e) >= cos_limit
                {
                    sets.join(s as u32, t);
                }
            }
        }
    }
    let mut group_of = vec![u32::MAX; pixels.len()];
    let mut groups: Vec<Vec<u32>> = Vec::new();
    for (s, &p) in pixels.iter().enumerate() {
        let r = sets.root(s as u32) as usize;
        if group_of[r] == u32::MAX {
            group_of[r] = groups.len() as u32;
            groups.push(Vec::new());
        }
        groups[group_of[r] as usize].push(p);
    }
    groups
}

/// The source made of `pixels`.
fn source(
    fisheye: &Fisheye,
    omega: &[f64],
    luminance: &[f64],
    pixels: Vec<u32>,
    peak: bool,
) -> Source {
    let n = fisheye.size;
    let (mut w, mut wl, mut wx, mut wy) = (0.0, 0.0, 0.0, 0.0);
    for &p in &pixels {
        let o = omega[p as usize];
        w += o;
        wl += o * luminance[p as usize];
        wx += o * (f64::from(p % n) + 0.5);
        wy += o * (f64::from(p / n) + 0.5);
    }
    let position = (wx / w, wy / w);
    // The mean of points in the circle is in the circle (it is convex).
    let direction = fisheye
        .direction(position.0, position.1)
        .unwrap_or(fisheye.look);
    Source {
        direction,
        position,
        solid_angle_sr: w,
        luminance_cd_m2: wl / w,
        position_index: position_index(direction, fisheye.look, fisheye.up, fisheye.right),
        peak,
        pixels,
    }
}

/// The glare sources of a fisheye: pixels in the view (`omega > 0`) brighter than
/// `threshold` cd/m², merged by `search_radius`, peaks at or above `peak_limit` split off.
pub fn find(
    fisheye: &Fisheye,
    omega: &[f64],
    dirs: &[Option<DVec3>],
    luminance: &[f64],
    threshold: f64,
    search_radius: f64,
    peak_limit: Option<f64>,
) -> Vec<Source> {
    let bright: Vec<u32> = (0..luminance.len() as u32)
        .filter(|&p| omega[p as usize] > 0.0 && luminance[p as usize] > threshold)
        .collect();
    // evalglare's test doubles the angle: 2·angle ≤ r.
    let angle = search_radius / 2.0;
    let is_peak = |p: u32| peak_limit.is_some_and(|l| luminance[p as usize] >= l);
    let mut out = Vec::new();
    for group in merge(fisheye, dirs, &bright, angle) {
        let (peaks, rest): (Vec<u32>, Vec<u32>) = group.into_iter().partition(|&p| is_peak(p));
        if !rest.is_empty() {
            out.push(source(fisheye, omega, luminance, rest, false));
        }
        for g in merge(fisheye, dirs, &peaks, angle) {
            out.push(source(fisheye, omega, luminance, g, true));
        }
    }
    // The strongest first.
    out.sort_by(|a, b| b.glare_term().total_cmp(&a.glare_term()));
    out
}
