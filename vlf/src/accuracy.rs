//! The figures an image is judged by against a converged reference of the same view
//! (DESIGN.md, "How accuracy is judged", and issue 30's figures): the relative MSE, the
//! bias of the mean (over the whole image and over its upper and lower halves, where the
//! walls and the floor of a room usually are) and the worst relative error of the mean
//! over a block of pixels (16 × 16: what a viewer sees as a patch too bright or too dark).

use glam::Vec3;
use holocave_tracer::film::Image;

/// An image's figures against a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Figures {
    /// `mean((x − ref)² / (ref² + 0.01))` over pixels and channels.
    pub relative_mse: f64,
    /// Relative error of the mean luminance: whole image, upper half, lower half.
    pub bias: f64,
    pub bias_upper: f64,
    pub bias_lower: f64,
    /// The largest `|mean(x) − mean(ref)| / mean(ref)` in luminance over the whole
    /// `block × block` blocks, and where that block starts (pixels).
    pub worst_block: f64,
    pub worst_at: (u32, u32),
}

fn luminance(c: Vec3) -> f64 {
    f64::from(holocave_scene::luminance(c))
}

/// `image`'s figures against `reference` (the same size), blocks of `block` pixels.
pub fn figures(image: &Image, reference: &Image, block: u32) -> Figures {
    assert_eq!(
        (image.width, image.height),
        (reference.width, reference.height),
        "an image and its reference differ in size"
    );
    let (w, h) = (image.width, image.height);
    let mean_over = |im: &Image, x0: u32, y0: u32, x1: u32, y1: u32| -> f64 {
        let mut s = 0.0;
        for y in y0..y1 {
            for x in x0..x1 {
                s += luminance(im.at(x, y));
            }
        }
        s / f64::from((x1 - x0) * (y1 - y0)).max(1.0)
    };
    let rel = |x0, y0, x1, y1| {
        let r = mean_over(reference, x0, y0, x1, y1);
        (mean_over(image, x0, y0, x1, y1) - r) / r.max(1e-12)
    };
    let mut worst = (0.0f64, (0, 0));
    let block = block.max(1);
    for by in 0..h / block {
        for bx in 0..w / block {
            let (x0, y0) = (bx * block, by * block);
            let e = rel(x0, y0, x0 + block, y0 + block).abs();
            if e > worst.0 {
                worst = (e, (x0, y0));
            }
        }
    }
    Figures {
        relative_mse: image.relative_mse(reference),
        bias: rel(0, 0, w, h),
        bias_upper: rel(0, 0, w, h / 2),
        bias_lower: rel(0, h / 2, w, h),
        worst_block: worst.0,
        worst_at: worst.1,
    }
}

/// An image's figures over the pixels a mask marks (a moving object's, or the rest).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Masked {
    /// As [`Figures::relative_mse`], over the marked pixels.
    pub relative_mse: f64,
    /// The relative error of their mean luminance.
    pub bias: f64,
    /// The largest relative error of the mean luminance of a `block × block` block's
    /// marked pixels, over the blocks at least half marked (0 where none is).
    pub worst_block: f64,
    pub pixels: usize,
}

/// `image`'s figures against `reference` over the pixels `mask` marks, blocks of `block`
/// pixels.
pub fn masked(image: &Image, reference: &Image, mask: &[bool], block: u32) -> Masked {
    assert_eq!(image.pixels.len(), mask.len());
    let w = image.width as usize;
    let block = block.max(1) as usize;
    let (bw, bh) = (w / block, image.height as usize / block);
    // Per block: luminance of the image and of the reference, marked pixels.
    let mut blocks = vec![(0.0f64, 0.0f64, 0usize); bw * bh];
    let (mut se, mut lum, mut lum_ref, mut n) = (0.0, 0.0, 0.0, 0usize);
    for (i, ((x, r), _)) in (image.pixels.iter().zip(&reference.pixels).zip(mask))
        .enumerate()
        .filter(|(_, (_, m))| **m)
    {
        for c in 0..3 {
            let (x, r) = (f64::from(x[c]), f64::from(r[c]));
            se += (x - r).powi(2) / (r * r + 0.01);
        }
        let (l, lr) = (luminance(*x), luminance(*r));
        (lum, lum_ref, n) = (lum + l, lum_ref + lr, n + 1);
        let (bx, by) = (i % w / block, i / w / block);
        if bx < bw && by < bh {
            let b = &mut blocks[by * bw + bx];
            *b = (b.0 + l, b.1 + lr, b.2 + 1);
        }
    }
    let worst_block = (blocks.iter())
        .filter(|b| 2 * b.2 >= block * block)
        .map(|b| ((b.0 - b.1) / b.1.max(1e-12)).abs())
        .fold(0.0, f64::max);
    Masked {
        relative_mse: se / (3 * n).max(1) as f64,
        bias: (lum - lum_ref) / lum_ref.max(1e-12),
        worst_block,
        pixels: n,
    }
}

impl std::fmt::Display for Masked {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "relative MSE {:.5}, mean bias {:+.2} %, worst 16×16 block {:.1} %",
            self.relative_mse,
            100.0 * self.bias,
            100.0 * self.worst_block
        )
    }
}

impl std::fmt::Display for Figures {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "relative MSE {:.5}, mean bias {:+.2} % (upper half {:+.2} %, lower half {:+.2} %), worst 16×16 block {:.1} % at {:?}",
            self.relative_mse,
            100.0 * self.bias,
            100.0 * self.bias_upper,
            100.0 * self.bias_lower,
            100.0 * self.worst_block,
            self.worst_at
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_of_a_scaled_patch() {
        let mut reference = Image::new(32, 32);
        reference.pixels.iter_mut().for_each(|p| *p = Vec3::ONE);
        let mut image = reference.clone();
        // The top-left block 10 % too bright: a quarter of the upper half, an eighth of
        // the whole image.
        for y in 0..16 {
            for x in 0..16 {
                image.pixels[y * 32 + x] = Vec3::splat(1.1);
            }
        }
        let f = figures(&image, &reference, 16);
        assert!(
            (f.worst_block - 0.1).abs() < 1e-6 && f.worst_at == (0, 0),
            "{f}"
        );
        assert!((f.bias - 0.025).abs() < 1e-6, "{f}");
        assert!(
            (f.bias_upper - 0.05).abs() < 1e-6 && f.bias_lower.abs() < 1e-9,
            "{f}"
        );
        // 256 of 1024 pixels off by 0.1 in each channel: 0.01/1.01 / 4.
        assert!((f.relative_mse - 0.01 / 1.01 / 4.0).abs() < 1e-6, "{f}");
        // Over the bright block alone: every pixel off by 0.1, the mean 10 % high.
        let mask: Vec<bool> = (0..32 * 32).map(|i| i % 32 < 16 && i / 32 < 16).collect();
        let m = masked(&image, &reference, &mask, 16);
        assert_eq!(m.pixels, 256);
        assert!((m.relative_mse - 0.01 / 1.01).abs() < 1e-6 && (m.bias - 0.1).abs() < 1e-6);
        assert!((m.worst_block - 0.1).abs() < 1e-6, "{m}");
        // Over the bright block's upper half and a pixel of the next block: that block
        // is less than half marked and counts in the mean, not as a block.
        let mask: Vec<bool> = (0..32 * 32)
            .map(|i| (i % 32 < 16 && i / 32 < 8) || i == 16)
            .collect();
        let m = masked(&image, &reference, &mask, 16);
        assert_eq!(m.pixels, 129);
        assert!((m.worst_block - 0.1).abs() < 1e-6, "{m}");
        assert!((m.bias - 0.1 * 128.0 / 129.0).abs() < 1e-6, "{m}");
    }
}
