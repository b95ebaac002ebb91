//! Loss of acuity in dim light (Ward Larson, Rushmeier & Piatko 1997, human visual limits;
//! Radiance `pcond4.c`): the finest grating a person resolves, in cycles per degree, falls
//! with the adaptation luminance, after Shaler's (1937) measurements. Each pixel shows the
//! picture blurred so that finer detail than that is gone: its value is read from a box
//! pyramid of the image (level `k` = means of `2^k × 2^k` pixel blocks) at the level whose
//! block is one cycle of the finest visible grating, `log2(pixels per degree / cycles per
//! degree)`, bilinear within a level and linear between levels (`pcond`'s `acusample`).
//! Where that is under a pixel the pixel is left as it is.

use glam::Vec3;
use holocave_tracer::film::Image;

/// Shaler's data as `pcond` tabulates it: log10 adaptation luminance (cd/m²) and the
/// highest resolvable spatial frequency (cycles/degree) there.
pub const SHALER_LOG_LA: [f32; 20] = [
    -3.10503, -2.66403, -2.37703, -2.09303, -1.64403, -1.35803, -1.07403, -0.67203, -0.38503,
    -0.10103, 0.29397, 0.58097, 0.86497, 1.25697, 1.54397, 1.82797, 2.27597, 2.56297, 2.84697,
    3.24897,
];
pub const SHALER_CPD: [f32; 20] = [
    2.09, 3.28, 3.79, 4.39, 6.11, 8.83, 10.94, 18.66, 23.88, 31.05, 37.42, 37.68, 41.60, 43.16,
    45.30, 47.00, 48.43, 48.32, 51.06, 51.09,
];
/// Levels of the pyramid (the image and 7 halvings: blocks up to 128 pixels, a cycle of
/// 2 cycles/degree at 256 pixels per degree).
pub const LEVELS: u32 = 8;

/// The highest spatial frequency resolved at adaptation luminance `la` (cd/m²), cycles
/// per degree: Shaler's data interpolated linearly in log10 luminance, held at the ends
/// of the table (0.00078 and 1770 cd/m²).
pub fn resolvable_cpd(la: f32) -> f32 {
    let l = la
        .max(1e-30)
        .log10()
        .clamp(SHALER_LOG_LA[0], SHALER_LOG_LA[19]);
    let mut i = 0;
    while i < 18 && SHALER_LOG_LA[i + 1] <= l {
        i += 1;
    }
    let t = (l - SHALER_LOG_LA[i]) / (SHALER_LOG_LA[i + 1] - SHALER_LOG_LA[i]);
    SHALER_CPD[i] + (SHALER_CPD[i + 1] - SHALER_CPD[i]) * t
}

/// The pyramid level (fractional, `0..LEVELS-1`) for a pixel with `pixels_per_degree`
/// adapted to `la` cd/m²: log2 of the pixels in one cycle of the finest visible grating.
pub fn level(pixels_per_degree: f32, la: f32) -> f32 {
    (pixels_per_degree / resolvable_cpd(la))
        .max(1.0)
        .log2()
        .min((LEVELS - 1) as f32)
}

/// The box pyramid of an image: level `k` is `ceil(W / 2^k) × ceil(H / 2^k)`, each texel
/// the mean of the pixels of its block (partial at the right and bottom edges).
#[derive(Clone, Debug)]
pub struct Pyramid {
    pub levels: Vec<Image>,
}

/// Size of level `k` of a side of `n` pixels.
pub fn level_size(n: u32, k: u32) -> u32 {
    n.div_ceil(1 << k).max(1)
}

impl Pyramid {
    pub fn new(image: &Image) -> Pyramid {
        let mut levels = vec![image.clone()];
        for k in 1..LEVELS {
            let (w, h) = (level_size(image.width, k), level_size(image.height, k));
            let mut sum = vec![Vec3::ZERO; (w * h) as usize];
            let mut count = vec![0u32; (w * h) as usize];
            for y in 0..image.height {
                for x in 0..image.width {
                    let i = ((y >> k) * w + (x >> k)) as usize;
                    sum[i] += image.at(x, y);
                    count[i] += 1;
                }
            }
            let mut l = Image::new(w, h);
            for (p, (s, c)) in l.pixels.iter_mut().zip(sum.iter().zip(&count)) {
                *p = *s / (*c).max(1) as f32;
            }
            levels.push(l);
        }
        Pyramid { levels }
    }

    /// Level `k` read bilinearly at the centre of pixel `(x, y)` of the full image (edges
    /// clamped): exactly the pixel at level 0.
    pub fn at_level(&self, k: u32, x: u32, y: u32) -> Vec3 {
        let l = &self.levels[k as usize];
        let s = (1u32 << k) as f32;
        let axis = |p: u32, n: u32| {
            let g = (p as f32 + 0.5) / s - 0.5;
            let g0 = g.floor();
            let last = n as i64 - 1;
            let a = (g0 as i64).clamp(0, last) as u32;
            let b = (g0 as i64 + 1).clamp(0, last) as u32;
            (a, b, g - g0)
        };
        let (x0, x1, tx) = axis(x, l.width);
        let (y0, y1, ty) = axis(y, l.height);
        let top = l.at(x0, y0) * (1.0 - tx) + l.at(x1, y0) * tx;
        let bottom = l.at(x0, y1) * (1.0 - tx) + l.at(x1, y1) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// The pixel `(x, y)` seen at fractional `level`: linear between the two levels.
    pub fn sample(&self, level: f32, x: u32, y: u32) -> Vec3 {
        let k0 = level.floor().max(0.0) as u32;
        let k1 = (k0 + 1).min(LEVELS - 1);
        let t = level - k0 as f32;
        let a = self.at_level(k0, x, y);
        if t <= 0.0 {
            return a;
        }
        a * (1.0 - t) + self.at_level(k1, x, y) * t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn acuity_follows_shalers_table_and_rises_with_light() {
        // At the table's points exactly, between them linearly.
        assert!((resolvable_cpd(10f32.powf(-2.09303)) - 4.39).abs() < 1e-3);
        let mid = 0.5 * (SHALER_LOG_LA[4] + SHALER_LOG_LA[5]);
        assert!((resolvable_cpd(10f32.powf(mid)) - 0.5 * (6.11 + 8.83)).abs() < 1e-3);
        // 0.01 cd/m²: 4.75 c/deg; 100 cd/m²: 47.55.
        assert!((resolvable_cpd(0.01) - 4.746).abs() < 0.01);
        assert!((resolvable_cpd(100.0) - 47.55).abs() < 0.01);
        // Held beyond the ends.
        assert_eq!(resolvable_cpd(1e-9), 2.09);
        assert_eq!(resolvable_cpd(1e9), 51.09);
    }

    #[test]
    fn level_zero_is_the_image_and_a_level_is_its_block_means() {
        let mut img = Image::new(5, 3);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = Vec3::splat(i as f32);
        }
        let p = Pyramid::new(&img);
        for y in 0..3 {
            for x in 0..5 {
                assert_eq!(p.sample(0.0, x, y), img.at(x, y));
            }
        }
        // Level 1 is 3 × 2: the top-left block (0, 1, 5, 6), the right edge's (4, 9).
        assert_eq!(p.levels[1].at(0, 0), Vec3::splat(3.0));
        assert_eq!(p.levels[1].at(2, 0), Vec3::splat(6.5));
        assert_eq!(p.levels[1].at(2, 1), Vec3::splat(14.0));
    }
}
