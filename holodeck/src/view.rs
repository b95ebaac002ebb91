//! A picture of one view made from the holodeck's samples alone, for inspecting a holodeck
//! (`holocave holodeck view`) and for tests: a simple reprojection in the spirit of the
//! paper's display drivers (§2.4), not the render node's render cache.
//!
//! Every sample's ray is decoded (entry and exit points, so its direction) and its surface
//! point — the entry point plus the stored distance along the ray — is projected into the
//! view. A sample is used only where its ray passes close to the eye: the angle between the
//! ray and the eye's line of sight to the point must be below [`ViewOptions::max_angle`]
//! (the paper keeps "the sample whose direction passes closest to the current view
//! direction", §2.4.2). Per pixel, the nearest depth wins, and the samples within
//! [`ViewOptions::depth_tolerance`] of it are averaged (each sample is one path, so
//! averaging is what brings the noise down). Escaped rays project as directions, behind
//! everything else.

use glam::DVec3;
use holocave_cave::WallView;

use crate::distance_code::DistanceCode;
use crate::file::{FileError, HoloFile};
use crate::rgbe;
use crate::sample::PackedSample;

/// How samples are chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewOptions {
    /// Largest angle (radians) between a sample's ray and the eye's line of sight to its
    /// surface point.
    pub max_angle: f64,
    /// Samples up to this relative depth behind a pixel's nearest one are averaged.
    pub depth_tolerance: f64,
}

impl Default for ViewOptions {
    fn default() -> Self {
        Self {
            max_angle: 10f64.to_radians(),
            depth_tolerance: 0.05,
        }
    }
}

/// The reconstructed picture.
#[derive(Clone, Debug, PartialEq)]
pub struct Picture {
    pub width: u32,
    pub height: u32,
    /// Linear RGB radiance per pixel, row by row from the top; black where no sample landed.
    pub pixels: Vec<[f32; 3]>,
    /// Samples averaged per pixel.
    pub counts: Vec<u32>,
    /// Samples read from the file.
    pub samples_read: u64,
    /// Samples used (summed over pixels).
    pub samples_used: u64,
}

impl Picture {
    /// Fraction of pixels with at least one sample.
    pub fn coverage(&self) -> f64 {
        let n = self.counts.iter().filter(|&&c| c > 0).count();
        n as f64 / self.counts.len().max(1) as f64
    }

    /// Fills empty pixels with the mean of their non-empty 3×3 neighbours, `passes` times
    /// (each pass reaches one pixel further). Filled pixels keep a count of 0.
    pub fn fill_holes(&mut self, passes: u32) {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut filled: Vec<bool> = self.counts.iter().map(|&c| c > 0).collect();
        for _ in 0..passes {
            let (src, have) = (self.pixels.clone(), filled.clone());
            for y in 0..h {
                for x in 0..w {
                    if have[y * w + x] {
                        continue;
                    }
                    let (mut sum, mut n) = ([0f32; 3], 0);
                    for ny in y.saturating_sub(1)..(y + 2).min(h) {
                        for nx in x.saturating_sub(1)..(x + 2).min(w) {
                            if have[ny * w + nx] {
                                for (s, v) in sum.iter_mut().zip(src[ny * w + nx]) {
                                    *s += v;
                                }
                                n += 1;
                            }
                        }
                    }
                    if n > 0 {
                        self.pixels[y * w + x] = sum.map(|v| v / n as f32);
                        filled[y * w + x] = true;
                    }
                }
            }
        }
    }
}

/// A stored sample decoded into world space: the ray's entry and exit points on its
/// section, its unit direction, the surface point it reached and its radiance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldSample {
    pub entry: DVec3,
    pub exit: DVec3,
    /// Unit direction, entry to exit (the direction the ray looks along).
    pub dir: DVec3,
    /// Distance from the entry point to the surface point; infinite for an escaped ray.
    pub distance: f32,
    pub radiance: [f32; 3],
}

impl WorldSample {
    /// Decodes sample `s` of `beam` of `section` (`code` is the section's distance code);
    /// `None` if the beam does not exist or its cells coincide.
    pub fn decode(
        section: &crate::Section,
        code: &DistanceCode,
        beam: u32,
        s: &PackedSample,
    ) -> Option<WorldSample> {
        let (entry, exit) = section.sample_points(beam, s.entry, s.exit)?;
        let dir = (exit - entry).normalize_or_zero();
        if dir == DVec3::ZERO {
            return None;
        }
        Some(WorldSample {
            entry,
            exit,
            dir,
            distance: code.decode(s.dist),
            radiance: rgbe::decode(s.rgbe),
        })
    }

    /// Whether the ray escaped the scene.
    pub fn escaped(&self) -> bool {
        !self.distance.is_finite()
    }

    /// The surface point (for an escaped ray: `far` beyond the exit point, along the ray).
    pub fn point(&self, far: f64) -> DVec3 {
        if self.escaped() {
            self.exit + self.dir * far
        } else {
            self.entry + self.dir * f64::from(self.distance)
        }
    }

    /// The distance by which the ray's line misses `eye`.
    pub fn miss(&self, eye: DVec3) -> f64 {
        let v = eye - self.entry;
        (v - self.dir * v.dot(self.dir)).length()
    }

    /// The point of the ray's line nearest `eye`.
    pub fn nearest_to(&self, eye: DVec3) -> DVec3 {
        self.entry + self.dir * (eye - self.entry).dot(self.dir)
    }

    /// Whether `eye` may use this sample: the angle between the ray and the eye's line of
    /// sight to the surface point is below `max_angle` (for an escaped ray: to a point one
    /// `size` beyond the exit, as far as the section can tell parallax). Returns the line
    /// of sight (for an escaped ray, the ray's direction) and the depth (infinite for an
    /// escaped ray).
    pub fn seen_from(&self, eye: DVec3, max_angle: f64, size: f64) -> Option<(DVec3, f64)> {
        let sees = |x: DVec3| {
            let v = x - eye;
            let len = v.length();
            (len > 0.0 && self.dir.dot(v) >= len * max_angle.cos()).then_some((v, len))
        };
        if self.escaped() {
            // No parallax, so it projects as its direction, but whether the eye's own line
            // of sight escapes too depends on where the ray passed. It must pass the eye
            // as closely as a point one section size beyond its exit would need to.
            sees(self.exit + self.dir * size)?;
            Some((self.dir, f64::INFINITY))
        } else {
            sees(self.point(0.0))
        }
    }
}

struct Hit {
    pixel: usize,
    depth: f64,
    rgb: [f32; 3],
}

/// The pixel and depth of a decoded sample in a section of size `size`; `None` if it is
/// not usable for this view.
fn project(
    view: &WallView,
    opts: &ViewOptions,
    ws: &WorldSample,
    size: f64,
) -> Option<(usize, f64)> {
    // A batch fill spreads its rays over every line through the section, so few pass
    // within a fraction of a degree of a given eye; the bound trades occlusion and
    // view-dependence errors against coverage.
    let (v, depth) = ws.seen_from(view.eye.as_dvec3(), opts.max_angle, size)?;
    let (x, y) = view.project(v)?;
    if !(x >= 0.0 && y >= 0.0 && x < f64::from(view.size.width) && y < f64::from(view.size.height))
    {
        return None;
    }
    let pixel = y as usize * view.size.width as usize + x as usize;
    Some((pixel, depth))
}

/// Reconstructs `view` from every sample of every section of `file`.
pub fn reconstruct(
    file: &HoloFile,
    view: &WallView,
    opts: &ViewOptions,
) -> Result<Picture, FileError> {
    let n = view.size.area();
    let mut nearest = vec![f64::INFINITY; n];
    let mut hits = Vec::new();
    let mut samples = Vec::new();
    let mut samples_read = 0;
    for (si, section) in file.sections().iter().enumerate() {
        let code = DistanceCode::new(section.size());
        for beam in 0..section.beam_count() {
            if file.count(si, beam) == 0 {
                continue;
            }
            samples.clear();
            file.read_beam(si, beam, &mut samples)?;
            samples_read += samples.len() as u64;
            for s in &samples {
                let Some(ws) = WorldSample::decode(section, &code, beam, s) else {
                    continue;
                };
                if let Some((pixel, depth)) = project(view, opts, &ws, section.size()) {
                    nearest[pixel] = nearest[pixel].min(depth);
                    hits.push(Hit {
                        pixel,
                        depth,
                        rgb: ws.radiance,
                    });
                }
            }
        }
    }
    let mut sum = vec![[0f64; 3]; n];
    let mut counts = vec![0u32; n];
    for h in &hits {
        let near = nearest[h.pixel];
        let keep = if near.is_finite() {
            h.depth <= near * (1.0 + opts.depth_tolerance)
        } else {
            h.depth.is_infinite()
        };
        if keep {
            for (s, v) in sum[h.pixel].iter_mut().zip(h.rgb) {
                *s += f64::from(v);
            }
            counts[h.pixel] += 1;
        }
    }
    let pixels = sum
        .iter()
        .zip(&counts)
        .map(|(s, &c)| {
            if c == 0 {
                [0.0; 3]
            } else {
                s.map(|v| (v / f64::from(c)) as f32)
            }
        })
        .collect();
    let samples_used = counts.iter().map(|&c| u64::from(c)).sum();
    Ok(Picture {
        width: view.size.width,
        height: view.size.height,
        pixels,
        counts,
        samples_read,
        samples_used,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::section::{Section, ViewClass};
    use crate::server::{Mode, Server, ServerConfig};
    use glam::Vec3;
    use holocave_cave::Size;
    use holocave_protocol::holodeck::SamplePacket;

    /// An analytic scene around an interior section: a back plane z = -2 whose colour
    /// depends on x (red left of 0, green right), everything else escapes (black).
    fn answer(p: &holocave_protocol::holodeck::RayPacket) -> SamplePacket {
        let mut s = SamplePacket {
            id: p.id,
            results: Vec::new(),
        };
        for (o, d) in p.rays().unwrap() {
            if d[2] < 0.0 {
                let t = (-2.0 - o[2]) / d[2];
                let x = o[0] + t * d[0];
                let rgb = if x < 0.0 {
                    [1.0, 0.0, 0.0]
                } else {
                    [0.0, 1.0, 0.0]
                };
                s.push(rgb, t);
            } else {
                s.push([0.0; 3], f32::INFINITY);
            }
        }
        s
    }

    #[test]
    fn a_view_from_inside_shows_the_plane_at_the_right_place() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.hdk");
        let section = Section::new(
            DVec3::new(-1.0, -1.0, -1.0),
            [DVec3::X * 2.0, DVec3::Y * 2.0, DVec3::Z * 2.0],
            [4, 4, 4],
            ViewClass::Interior,
        )
        .unwrap();
        let h = HoloFile::create(&p, vec![section], Default::default()).unwrap();
        let mut srv = Server::new(h, Mode::Batch, ServerConfig::default());
        let w = srv.add_worker();
        let mut t = 0.0;
        while srv.stats().added < 400_000 {
            for pk in srv.next_packets(w, t) {
                t += 0.01;
                srv.complete(w, &answer(&pk), t).unwrap();
            }
        }
        let h = srv.into_file().unwrap();
        // Eye off the centre, looking at -z through a screen 1 m ahead; the plane's colour
        // boundary x = 0 appears where the line of sight to (0, y, -2) crosses the screen.
        let eye = Vec3::new(0.3, 0.1, 0.2);
        let view = WallView {
            eye,
            pa: eye + Vec3::new(-0.5, -0.5, -1.0),
            pb: eye + Vec3::new(0.5, -0.5, -1.0),
            pc: eye + Vec3::new(-0.5, 0.5, -1.0),
            size: Size::new(40, 40),
        };
        let pic = reconstruct(&h, &view, &ViewOptions::default()).unwrap();
        assert!(pic.coverage() > 0.85, "coverage {}", pic.coverage());
        // Boundary at screen x = 0.3 × (1 / 2.2) left of the eye: column 20 − 0.136 × 40.
        let boundary = 20.0 - 0.3 / 2.2 * 40.0;
        let mut wrong = 0;
        for y in 0..40 {
            for x in 0..40 {
                let c = pic.counts[y * 40 + x];
                if c == 0 || (x as f64 + 0.5 - boundary).abs() < 1.5 {
                    continue;
                }
                let [r, g, _] = pic.pixels[y * 40 + x];
                if (x as f64) < boundary { r < g } else { g < r }.then(|| wrong += 1);
            }
        }
        assert_eq!(wrong, 0, "pixels on the wrong side of the boundary");
        let mut filled = pic.clone();
        filled.fill_holes(3);
        assert!(
            filled.pixels.iter().all(|p| p[0] + p[1] > 0.0),
            "holes remain"
        );
        // Looking the other way (+z) sees only escaped, black rays.
        let back = WallView {
            pa: eye + Vec3::new(0.5, -0.5, 1.0),
            pb: eye + Vec3::new(-0.5, -0.5, 1.0),
            pc: eye + Vec3::new(0.5, 0.5, 1.0),
            ..view
        };
        let pic = reconstruct(&h, &back, &ViewOptions::default()).unwrap();
        assert!(pic.coverage() > 0.5, "coverage {}", pic.coverage());
        assert!(pic.pixels.iter().all(|p| *p == [0.0; 3]));
    }
}
