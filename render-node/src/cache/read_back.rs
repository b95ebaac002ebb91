//! What the cache holds, read back from the GPU: an eye's image, its coverage, priority and
//! chosen pixels (for debugging images and tests), and the points.

use glam::Vec3;
use holocave_tracer::film::Image;

use super::RenderCache;
use super::records::GpuPoint;

impl RenderCache {
    /// The buffer holding eye `eye`'s image on the GPU (`vec4<f32>` per pixel, row by row
    /// from the top: linear radiance and coverage), for drawing it into a window.
    pub fn color_buffer(&self, eye: usize) -> &wgpu::Buffer {
        &self.eyes[eye].color
    }

    /// The image eye `eye` shows (linear radiance; holes black).
    pub fn image(&self, eye: usize) -> Image {
        let e = &self.eyes[eye];
        let n = u64::from(e.width) * u64::from(e.height);
        let bytes = self.gpu.read(&e.color, 16 * n);
        let px: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
        let mut img = Image::new(e.width, e.height);
        for (d, s) in img.pixels.iter_mut().zip(px) {
            *d = Vec3::new(s[0], s[1], s[2]);
        }
        img
    }

    /// How each pixel of eye `eye` was filled: 1 a point, 0.5 interpolated, 0 empty.
    pub fn coverage(&self, eye: usize) -> Vec<f32> {
        let e = &self.eyes[eye];
        let n = u64::from(e.width) * u64::from(e.height);
        let bytes = self.gpu.read(&e.color, 16 * n);
        let px: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
        px.iter().map(|p| p[3]).collect()
    }

    /// The priority image of eye `eye` (grey).
    pub fn priority_image(&self, eye: usize) -> Image {
        let e = &self.eyes[eye];
        let n = u64::from(e.width) * u64::from(e.height);
        let bytes = self.gpu.read(&e.priority, 4 * n);
        let px: &[f32] = bytemuck::cast_slice(&bytes);
        let mut img = Image::new(e.width, e.height);
        for (d, &s) in img.pixels.iter_mut().zip(px) {
            *d = Vec3::splat(s);
        }
        img
    }

    /// The pixels eye `eye` chose in the last frame (white on black).
    pub fn chosen_image(&self, eye: usize) -> Image {
        let e = &self.eyes[eye];
        let mut img = Image::new(e.width, e.height);
        for &p in &e.last_chosen {
            if let Some(d) = img.pixels.get_mut(p as usize) {
                *d = Vec3::ONE;
            }
        }
        img
    }

    /// All points (for tests and debugging).
    pub fn points(&self) -> Vec<GpuPoint> {
        let size = std::mem::size_of::<GpuPoint>() as u64;
        let bytes = self.gpu.read(&self.points, size * u64::from(self.capacity));
        bytemuck::cast_slice(&bytes).to_vec()
    }
}
