//! False colour: luminance in cd/m² shown on a logarithmic scale, blue (dim) through
//! green to red (bright) — the `spec` palette of Radiance's `falsecolor`, its original
//! default — with a legend drawn into the picture: a colour bar with a label per decade
//! and the unit, in a tiny built-in 3×5 pixel font. The reading aid of lighting designers;
//! a projector cannot show glare, but it can show how bright a surface is.
//!
//! The legend is made here once per picture size and scale; the GPU draws the same pixels
//! (`present/screen.wgsl` takes them as a buffer), so a window shows what a PNG does.

use glam::Vec3;
use holocave_tracer::film::srgb8;

/// The scale: `decades` decades of luminance from `10^log_min` cd/m².
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FalseColor {
    pub log_min: f32,
    pub decades: f32,
}

impl Default for FalseColor {
    /// 0.001 to 100 000 cd/m² (eight decades): a moonlit room to a sunlit window.
    fn default() -> Self {
        FalseColor {
            log_min: -3.0,
            decades: 8.0,
        }
    }
}

/// The `spec` palette at `v` in 0..1 (linear display values): red `1.6v − 0.6`, green
/// `8v/3` below 0.375 and `1.6 − 1.6v` above, blue `1 − 8v/3`, each clipped to 0..1.
pub fn palette(v: f32) -> Vec3 {
    let v = v.clamp(0.0, 1.0);
    let g = if v < 0.375 {
        8.0 / 3.0 * v
    } else {
        1.6 - 1.6 * v
    };
    Vec3::new(1.6 * v - 0.6, g, 1.0 - 8.0 / 3.0 * v).clamp(Vec3::ZERO, Vec3::ONE)
}

impl FalseColor {
    /// Where luminance `l` (cd/m²) lies on the scale, 0..1 (0 for black).
    pub fn position(&self, l: f32) -> f32 {
        if l <= 0.0 {
            return 0.0;
        }
        ((l.log10() - self.log_min) / self.decades).clamp(0.0, 1.0)
    }

    /// The 8-bit colour of luminance `l` cd/m².
    pub fn colour(&self, l: f32) -> [u8; 3] {
        let c = palette(self.position(l));
        [srgb8(c.x), srgb8(c.y), srgb8(c.z)]
    }
}

/// Glyphs of the legend's font: 3 columns × 5 rows, bit `4 − column` of row `r` (top first).
fn glyph(c: char) -> Option<[u8; 5]> {
    Some(match c {
        '0' => [0b111, 0b101, 0b101, 0b101, 0b111],
        '1' => [0b010, 0b110, 0b010, 0b010, 0b111],
        '2' => [0b111, 0b001, 0b111, 0b100, 0b111],
        '3' => [0b111, 0b001, 0b011, 0b001, 0b111],
        '4' => [0b101, 0b101, 0b111, 0b001, 0b001],
        '5' => [0b111, 0b100, 0b111, 0b001, 0b111],
        '6' => [0b111, 0b100, 0b111, 0b101, 0b111],
        '7' => [0b111, 0b001, 0b010, 0b010, 0b010],
        '8' => [0b111, 0b101, 0b111, 0b101, 0b111],
        '9' => [0b111, 0b101, 0b111, 0b001, 0b111],
        '-' => [0b000, 0b000, 0b111, 0b000, 0b000],
        'E' => [0b111, 0b100, 0b110, 0b100, 0b111],
        'c' => [0b000, 0b111, 0b100, 0b100, 0b111],
        'd' => [0b001, 0b111, 0b101, 0b101, 0b111],
        '/' => [0b001, 0b001, 0b010, 0b100, 0b100],
        'm' => [0b000, 0b111, 0b111, 0b101, 0b101],
        ' ' => [0; 5],
        _ => return None,
    })
}

/// A legend: `width × height` pixels at the picture's top-left corner, RGB, drawn over
/// the picture where `opaque`.
#[derive(Clone, Debug, PartialEq)]
pub struct Legend {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[u8; 3]>,
}

impl Legend {
    /// The legend of `scale` for a picture of `width × height` (None when the picture is
    /// too small for a legible one: under 64 pixels high or 48 wide). Font pixels are
    /// `s = height / 160` (at least 1) screen pixels; the bar runs from the top (brightest)
    /// to the bottom with a label `1E<k>` at each decade `10^k`, and `cd/m2` above it.
    pub fn new(scale: &FalseColor, width: u32, height: u32) -> Option<Legend> {
        if height < 64 || width < 48 {
            return None;
        }
        let s = (height / 160).max(1);
        let lw = 30 * s;
        let mut l = Legend {
            width: lw.min(width),
            height,
            pixels: vec![[0, 0, 0]; (lw.min(width) * height) as usize],
        };
        let (top, bottom) = (10 * s, height - 4 * s);
        let (bar0, bar1) = (2 * s, 8 * s);
        for y in top..bottom {
            let v = (bottom as f32 - y as f32 - 0.5) / (bottom - top) as f32;
            let c = palette(v);
            for x in bar0..bar1 {
                l.set(x, y, [srgb8(c.x), srgb8(c.y), srgb8(c.z)]);
            }
        }
        l.text("cd/m2", 2 * s, 2 * s, s);
        let decades = scale.decades.round().max(1.0) as i32;
        let first = scale.log_min.round() as i32;
        for d in 0..=decades {
            let y = bottom as f32 - (bottom - top) as f32 * d as f32 / decades as f32;
            let label = format!("1E{}", first + d);
            let y0 = (y - 2.5 * s as f32).round().max(0.0) as u32;
            l.text(&label, 10 * s, y0.min(height - 5 * s), s);
            // A tick on the bar's edge.
            let yt = (y.round() as u32).min(height - 1);
            for x in bar1..bar1 + s {
                l.set(x, yt, [255, 255, 255]);
            }
        }
        Some(l)
    }

    fn set(&mut self, x: u32, y: u32, c: [u8; 3]) {
        if x < self.width && y < self.height {
            self.pixels[(y * self.width + x) as usize] = c;
        }
    }

    /// Writes `text` in white with its top-left at `(x, y)`, font pixels `s` wide.
    fn text(&mut self, text: &str, x: u32, y: u32, s: u32) {
        for (k, ch) in text.chars().enumerate() {
            let Some(g) = glyph(ch) else { continue };
            let cx = x + 4 * s * k as u32;
            for (r, bits) in g.iter().enumerate() {
                for col in 0..3 {
                    if bits >> (2 - col) & 1 == 1 {
                        for dy in 0..s {
                            for dx in 0..s {
                                self.set(cx + col * s + dx, y + r as u32 * s + dy, [255; 3]);
                            }
                        }
                    }
                }
            }
        }
    }

    /// The legend's pixel over picture pixel `(x, y)`, if it covers it.
    pub fn at(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        (x < self.width && y < self.height).then(|| self.pixels[(y * self.width + x) as usize])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scale_runs_blue_to_red_one_decade_per_eighth() {
        let s = FalseColor::default();
        assert_eq!(s.position(1e-3), 0.0);
        assert_eq!(s.position(1e5), 1.0);
        assert!((s.position(10.0) - 0.5).abs() < 1e-6);
        assert_eq!(palette(0.0), Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(palette(1.0), Vec3::new(1.0, 0.0, 0.0));
        // Green peaks at 0.375.
        assert!((palette(0.375).y - 1.0).abs() < 1e-6);
    }

    #[test]
    fn the_legend_has_the_bar_the_labels_and_the_unit() {
        let l = Legend::new(&FalseColor::default(), 320, 240).unwrap();
        assert_eq!((l.width, l.height), (30, 240));
        // The bar: red at the top, blue at the bottom.
        let top = l.at(4, 11).unwrap();
        let bottom = l.at(4, 234).unwrap();
        assert!(top[0] > 200 && top[2] < 20, "{top:?}");
        assert!(bottom[2] > 200 && bottom[0] < 20, "{bottom:?}");
        // White label pixels right of the bar, nine labels' worth at least.
        let white = l.pixels.iter().filter(|p| **p == [255; 3]).count();
        assert!(white > 9 * 3 * 10, "{white} white pixels");
        assert!(Legend::new(&FalseColor::default(), 40, 40).is_none());
    }
}
