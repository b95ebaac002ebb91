//! Prints the accuracy figures (`holocave_vlf::accuracy`) of EXR images against a
//! reference, and writes each as a PNG beside it (`NAME.same.png`) at the reference's
//! exposure, so that the pictures compare by eye: `figures REFERENCE.exr IMAGE.exr…`.
//! A reference given as `A.exr+B.exr+…` (renders with different seeds) is their mean,
//! written as `A.mean.exr`, and its own noise (a quarter of the relative MSE between its
//! two halves' means) is printed. With `--montage OUT.png` first, the reference and the images
//! are also written side by side into one PNG (at the reference's exposure).

use std::path::Path;

use holocave_tracer::film::Image;

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let montage =
        (args.first().map(String::as_str) == Some("--montage") && args.len() > 1).then(|| {
            let out = args[1].clone();
            args.drain(..2);
            out
        });
    let Some((reference, images)) = args.split_first() else {
        eprintln!("usage: figures REFERENCE.exr IMAGE.exr…");
        std::process::exit(2);
    };
    let read = |p: &str| {
        Image::read_exr(Path::new(p)).unwrap_or_else(|e| {
            eprintln!("{p}: {e}");
            std::process::exit(1)
        })
    };
    // A reference of several renders (`A.exr+B.exr+…`) is their mean; its own noise is a
    // quarter of the relative MSE between the means of its two halves (each has twice
    // the whole's variance).
    let parts: Vec<&str> = reference.split('+').collect();
    let r = if parts.len() > 1 {
        let renders: Vec<Image> = parts.iter().map(|p| read(p)).collect();
        let mean_of = |rs: &[Image]| {
            let mut m = rs[0].clone();
            for (k, px) in m.pixels.iter_mut().enumerate() {
                *px = rs.iter().map(|r| r.pixels[k]).sum::<glam::Vec3>() / rs.len() as f32;
            }
            m
        };
        let half = renders.len() / 2;
        let noise =
            mean_of(&renders[..half]).relative_mse(&mean_of(&renders[half..2 * half])) / 4.0;
        let mean = mean_of(&renders);
        println!(
            "reference: the mean of {} renders, its own relative MSE {noise:.5}",
            renders.len()
        );
        let out = Path::new(parts[0]).with_extension("mean.exr");
        if let Err(e) = mean.write_exr(&out) {
            eprintln!("{}: {e}", out.display());
        }
        mean
    } else {
        read(reference)
    };
    let exposure = r.auto_exposure();
    let mut all = vec![r.clone()];
    for p in images {
        let image = read(p);
        all.push(image.clone());
        println!("{p}: {}", holocave_vlf::accuracy::figures(&image, &r, 16));
        let png = Path::new(p).with_extension("same.png");
        if let Err(e) = image.write_png(&png, exposure) {
            eprintln!("{}: {e}", png.display());
        }
    }
    if let Some(out) = montage {
        // Side by side with a 4-pixel black gap.
        let gap = 4;
        let (w, h) = (r.width, r.height);
        let n = all.len() as u32;
        let mut m = Image::new(n * w + (n - 1) * gap, h);
        for (k, im) in all.iter().enumerate() {
            for y in 0..h {
                for x in 0..w {
                    let at = (y * m.width + k as u32 * (w + gap) + x) as usize;
                    m.pixels[at] = im.at(x, y);
                }
            }
        }
        if let Err(e) = m.write_png(Path::new(&out), exposure) {
            eprintln!("{out}: {e}");
        }
    }
}
