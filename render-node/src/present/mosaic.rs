//! The unfolded CAVE as one picture: each wall's image pasted at its place in the layout
//! (`holocave_cave::unfolded`), so that each seam of the picture is a seam of the room.

use std::path::{Path, PathBuf};

use holocave_cave::{Eye, Unfolded, Wall};
use image::{Rgb, RgbImage};

use crate::RenderNodeError;
use crate::present::output::frame_png;

/// Grey of the empty parts of the picture.
const EMPTY: Rgb<u8> = Rgb([48, 48, 48]);

/// The walls' `images` at their places in `layout`; a wall without an image leaves its
/// place grey, and an image larger than its place is cut to it.
pub fn cave_mosaic(layout: &Unfolded, images: &[(&str, &RgbImage)]) -> RgbImage {
    let size = layout.size;
    let mut out = RgbImage::from_pixel(size.width.max(1), size.height.max(1), EMPTY);
    for (wall, img) in images {
        let Some(p) = layout.place(wall) else {
            continue;
        };
        for (x, y, px) in img.enumerate_pixels() {
            if x < p.size.width && y < p.size.height {
                out.put_pixel(p.x + x, p.y + y, *px);
            }
        }
    }
    out
}

/// The mosaic of each of `frames` from the first-eye previews `walls`' nodes wrote in
/// `OUT/<wall>/` (a wall that did not write the frame is left grey), written to
/// `OUT/mosaic/NNNNN.png`; the paths written.
pub fn write_mosaics(
    out: &Path,
    walls: &[Wall],
    layout: &Unfolded,
    frames: &[u64],
) -> Result<Vec<PathBuf>, RenderNodeError> {
    let dir = out.join("mosaic");
    let failed = |path: &Path, message: String| RenderNodeError::Write {
        path: path.display().to_string(),
        message,
    };
    std::fs::create_dir_all(&dir).map_err(|e| failed(&dir, e.to_string()))?;
    let mut written = Vec::new();
    for &frame in frames {
        let images: Vec<(&str, RgbImage)> = (walls.iter())
            .filter_map(|wall| {
                let eye = Eye::for_mode(wall.stereo)[0];
                let img = image::open(frame_png(&out.join(&wall.name), frame, eye)).ok()?;
                Some((wall.name.as_str(), img.to_rgb8()))
            })
            .collect();
        let images: Vec<(&str, &RgbImage)> = images.iter().map(|(n, i)| (*n, i)).collect();
        let path = dir.join(format!("{frame:05}.png"));
        (cave_mosaic(layout, &images).save(&path)).map_err(|e| failed(&path, e.to_string()))?;
        written.push(path);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use holocave_cave::{Size, unfold};

    #[test]
    fn each_image_lands_on_its_place_and_a_missing_one_leaves_it_grey() {
        let solid = |w, h, v| RgbImage::from_pixel(w, h, Rgb([v, v, v]));
        let layout = unfold(
            &[
                ("front", Size::new(4, 3)),
                ("left", Size::new(4, 3)),
                ("right", Size::new(4, 3)),
                ("floor", Size::new(4, 4)),
            ]
            .map(|(n, s)| (n.to_owned(), s)),
        );
        let (l, f, g) = (solid(4, 3, 10), solid(4, 3, 20), solid(4, 4, 40));
        let m = cave_mosaic(&layout, &[("front", &f), ("left", &l), ("floor", &g)]);
        assert_eq!(m.dimensions(), (12, 7));
        assert_eq!(m.get_pixel(0, 0)[0], 10);
        assert_eq!(m.get_pixel(4, 2)[0], 20);
        assert_eq!(m.get_pixel(11, 0)[0], 48, "the right wall wrote no image");
        assert_eq!(
            m.get_pixel(4, 3)[0],
            40,
            "the floor is under the front wall"
        );
        assert_eq!(m.get_pixel(0, 6)[0], 48, "nothing under the side walls");
    }
}
