//! Prints the accuracy figures (`holocave_vlf::accuracy`) of EXR images against a
//! reference, and writes each as a PNG beside it (`NAME.same.png`) at the reference's
//! exposure, so that the pictures compare by eye: `figures REFERENCE.exr IMAGE.exr…`.
//! A reference given as `A.exr+B.exr` (two renders with different seeds) is their mean,
//! written as `A.mean.exr`, and its own noise (a quarter of their relative MSE against
//! each other) is printed.

use std::path::Path;

use holocave_tracer::film::Image;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
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
    let r = match reference.split_once('+') {
        Some((a, b)) => {
            let (a, b) = (read(a), read(b));
            let noise = a.relative_mse(&b) / 4.0;
            let mut mean = a.clone();
            for (m, b) in mean.pixels.iter_mut().zip(&b.pixels) {
                *m = (*m + *b) * 0.5;
            }
            println!("reference: the mean of two renders, its own relative MSE {noise:.5}");
            let out = Path::new(reference.split('+').next().unwrap_or(reference))
                .with_extension("mean.exr");
            if let Err(e) = mean.write_exr(&out) {
                eprintln!("{}: {e}", out.display());
            }
            mean
        }
        None => read(reference),
    };
    let exposure = r.auto_exposure();
    for p in images {
        let image = read(p);
        println!("{p}: {}", holocave_vlf::accuracy::figures(&image, &r, 16));
        let png = Path::new(p).with_extension("same.png");
        if let Err(e) = image.write_png(&png, exposure) {
            eprintln!("{}: {e}", png.display());
        }
    }
}
