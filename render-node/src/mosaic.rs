//! The unfolded CAVE as one picture: left | front | right in a row, the floor under the
//! front wall — the walls as a user facing the front wall would see them laid flat, so
//! that each seam of the picture is a seam of the room.

use image::{Rgb, RgbImage};

/// Grey of the empty parts of the picture.
const EMPTY: Rgb<u8> = Rgb([48, 48, 48]);

/// Lays out the walls named `left`, `front`, `right` and `floor` (a missing one leaves
/// its place grey, sized like the front wall).
pub fn cave_mosaic(walls: &[(&str, &RgbImage)]) -> RgbImage {
    let get = |n: &str| walls.iter().find(|(w, _)| *w == n).map(|(_, i)| *i);
    let (fw, fh) = get("front").map_or((1, 1), |i| i.dimensions());
    let size = |n: &str, (w, h): (u32, u32)| get(n).map_or((w, h), |i| i.dimensions());
    let (lw, lh) = size("left", (fw, fh));
    let (rw, rh) = size("right", (fw, fh));
    let (gw, gh) = size("floor", (fw, fw));
    let top = lh.max(fh).max(rh);
    let width = lw + fw.max(gw) + rw;
    let mut out = RgbImage::from_pixel(width, top + gh, EMPTY);
    let mut put = |name: &str, x0: u32, y0: u32| {
        if let Some(img) = get(name) {
            for (x, y, p) in img.enumerate_pixels() {
                out.put_pixel(x0 + x, y0 + y, *p);
            }
        }
    };
    // Walls stand on the floor: align their bottom edges with the top of the floor row.
    put("left", 0, top - lh);
    put("front", lw, top - fh);
    put("right", lw + fw.max(gw), top - rh);
    put("floor", lw, top);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn walls_land_where_the_room_unfolds() {
        let solid = |w, h, v| RgbImage::from_pixel(w, h, Rgb([v, v, v]));
        let (l, f, r, g) = (
            solid(4, 3, 10),
            solid(4, 3, 20),
            solid(4, 3, 30),
            solid(4, 4, 40),
        );
        let m = cave_mosaic(&[("front", &f), ("left", &l), ("right", &r), ("floor", &g)]);
        assert_eq!(m.dimensions(), (12, 7));
        assert_eq!(m.get_pixel(0, 0)[0], 10);
        assert_eq!(m.get_pixel(4, 2)[0], 20);
        assert_eq!(m.get_pixel(11, 0)[0], 30);
        assert_eq!(
            m.get_pixel(4, 3)[0],
            40,
            "the floor is under the front wall"
        );
        assert_eq!(m.get_pixel(0, 6)[0], 48, "nothing under the side walls");
    }
}
