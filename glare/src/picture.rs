//! The fisheye for a person to look at: the image's PNG preview (the previews' one
//! exposure rule and curve, [`Image::to_preview`]) with each glare source's outline drawn
//! in a colour of its own and a cross at its position; and the same fisheye as a
//! Radiance picture (`.hdr`) for `evalglare`.

use std::io::Write;
use std::path::Path;

use holocave_tracer::film::Image;

use crate::error::GlareError;
use crate::figures::Figures;
use crate::fisheye::Fisheye;

/// Outline colours, one per source in turn (`evalglare`'s check-file colours: red,
/// green, blue, yellow, magenta, cyan).
const COLOURS: [[u8; 3]; 6] = [
    [255, 40, 40],
    [40, 255, 40],
    [60, 90, 255],
    [255, 230, 0],
    [255, 0, 255],
    [0, 230, 230],
];

/// The preview with the sources of `figures` outlined: a source's pixel is outlined
/// when one of its four neighbours is not in the same source.
pub fn preview(image: &Image, figures: &Figures) -> image::RgbImage {
    let mut png = image.to_preview(image.auto_exposure());
    let n = image.width;
    let mut owner = vec![u32::MAX; (n * image.height) as usize];
    for (s, src) in figures.sources.iter().enumerate() {
        for &p in &src.pixels {
            owner[p as usize] = s as u32;
        }
    }
    let at = |x: i64, y: i64| {
        if x < 0 || y < 0 || x >= i64::from(n) || y >= i64::from(image.height) {
            u32::MAX
        } else {
            owner[(y * i64::from(n) + x) as usize]
        }
    };
    for y in 0..image.height {
        for x in 0..n {
            let s = owner[(y * n + x) as usize];
            if s == u32::MAX {
                continue;
            }
            let (xi, yi) = (i64::from(x), i64::from(y));
            let edge = [(1, 0), (-1, 0), (0, 1), (0, -1)]
                .iter()
                .any(|(dx, dy)| at(xi + dx, yi + dy) != s);
            if edge {
                png.put_pixel(x, y, image::Rgb(COLOURS[s as usize % COLOURS.len()]));
            }
        }
    }
    for (s, src) in figures.sources.iter().enumerate() {
        let (cx, cy) = (src.position.0 as i64, src.position.1 as i64);
        for d in -3i64..=3 {
            for (x, y) in [(cx + d, cy), (cx, cy + d)] {
                if x >= 0 && y >= 0 && x < i64::from(n) && y < i64::from(image.height) {
                    png.put_pixel(x as u32, y as u32, image::Rgb(COLOURS[s % COLOURS.len()]));
                }
            }
        }
    }
    png
}

/// Writes [`preview`] to `path`.
pub fn write_preview(path: &Path, image: &Image, figures: &Figures) -> Result<(), GlareError> {
    preview(image, figures)
        .save(path)
        .map_err(|e| GlareError::Write {
            path: path.into(),
            message: e.to_string(),
        })
}

/// One RGBE pixel (Ward's shared-exponent encoding, as Radiance's `setcolr`).
fn rgbe(c: [f32; 3]) -> [u8; 4] {
    let m = c[0].max(c[1]).max(c[2]);
    if m <= 1e-32 {
        return [0; 4];
    }
    // m = f · 2^e with f in [0.5, 1).
    let e = m.log2().floor() as i32 + 1;
    let scale = 256.0 / 2f32.powi(e);
    let q = |v: f32| (v * scale).clamp(0.0, 255.0) as u8;
    [q(c[0]), q(c[1]), q(c[2]), (e + 128) as u8]
}

/// Writes the fisheye's luminance as a Radiance picture (flat RGBE, `-vta` view in its
/// header) for `evalglare`: grey pixels of value `L / 179` (Radiance's own luminous
/// efficacy), so that `evalglare` reads each pixel's luminance `L` in cd/m² whatever
/// the scene's efficacy.
pub fn write_radiance_hdr(
    path: &Path,
    fisheye: &Fisheye,
    luminance: &[f64],
) -> Result<(), GlareError> {
    let err = |e: std::io::Error| GlareError::Write {
        path: path.into(),
        message: e.to_string(),
    };
    let n = fisheye.size;
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).map_err(err)?);
    let (p, d, u) = (fisheye.eye, fisheye.look, fisheye.up);
    write!(
        out,
        "#?RADIANCE\nSOFTWARE= holocave glare\nVIEW= -vta -vp {} {} {} -vd {} {} {} -vu {} {} {} -vh 180 -vv 180\nFORMAT=32-bit_rle_rgbe\n\n-Y {n} +X {n}\n",
        p.x, p.y, p.z, d.x, d.y, d.z, u.x, u.y, u.z
    )
    .map_err(err)?;
    for &l in luminance {
        let v = (l / 179.0) as f32;
        out.write_all(&rgbe([v, v, v])).map_err(err)?;
    }
    out.flush().map_err(err)
}
