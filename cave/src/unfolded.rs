//! The unfolded CAVE: the walls laid flat as a user facing the front wall would fold them
//! out — left | front | right in a row, standing on the floor, which lies under the front
//! wall — so that each seam of the picture is a seam of the room. Walls with other names
//! go in a row below. One layout for the mosaics `sim` writes and for the windows
//! `sim --window` opens.

use crate::size::Size;

/// Where one wall's image goes in the unfolded CAVE, in pixels from the top-left corner.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Place {
    pub wall: String,
    pub x: u32,
    pub y: u32,
    pub size: Size,
}

/// The walls' places and the size of the whole.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unfolded {
    pub size: Size,
    pub places: Vec<Place>,
}

const ROOM: [&str; 4] = ["front", "left", "right", "floor"];

/// Lays out walls whose images are `(name, size)`; a room wall that is not there takes no
/// room.
pub fn unfold(walls: &[(String, Size)]) -> Unfolded {
    let get = |n: &str| {
        walls
            .iter()
            .find(|(w, _)| w == n)
            .map_or(Size::new(0, 0), |(_, s)| *s)
    };
    let (front, left, right, floor) = (get("front"), get("left"), get("right"), get("floor"));
    // Walls stand on the floor: their bottom edges on the top of the floor row.
    let top = left.height.max(front.height).max(right.height);
    let middle = front.width.max(floor.width);
    let others: Vec<&(String, Size)> = walls
        .iter()
        .filter(|(w, _)| !ROOM.contains(&w.as_str()))
        .collect();
    let others_width: u32 = others.iter().map(|(_, s)| s.width).sum();
    let others_height = others.iter().map(|(_, s)| s.height).max().unwrap_or(0);
    let places = walls
        .iter()
        .map(|(name, size)| {
            let h = size.height;
            let (x, y) = match name.as_str() {
                "left" => (0, top - h),
                "front" => (left.width, top - h),
                "right" => (left.width + middle, top - h),
                "floor" => (left.width, top),
                _ => {
                    let before = others
                        .iter()
                        .take_while(|(o, _)| o != name)
                        .map(|(_, s)| s.width)
                        .sum();
                    (before, top + floor.height)
                }
            };
            Place {
                wall: name.clone(),
                x,
                y,
                size: *size,
            }
        })
        .collect();
    Unfolded {
        size: Size::new(
            (left.width + middle + right.width).max(others_width),
            top + floor.height + others_height,
        ),
        places,
    }
}

impl Unfolded {
    /// The layout scaled by the largest factor that fits `screen` (every place at least one
    /// pixel).
    pub fn fit(&self, screen: Size) -> Vec<Place> {
        let Size { width, height } = screen;
        let zoom = (f64::from(width) / f64::from(self.size.width.max(1)))
            .min(f64::from(height) / f64::from(self.size.height.max(1)));
        let z = |v: u32| (f64::from(v) * zoom).floor() as u32;
        self.places
            .iter()
            .map(|p| Place {
                wall: p.wall.clone(),
                x: z(p.x),
                y: z(p.y),
                size: Size::new(z(p.size.width).max(1), z(p.size.height).max(1)),
            })
            .collect()
    }

    /// The place of `wall`, if it is laid out.
    pub fn place(&self, wall: &str) -> Option<&Place> {
        self.places.iter().find(|p| p.wall == wall)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn walls(list: &[(&str, Size)]) -> Vec<(String, Size)> {
        list.iter().map(|(n, s)| (n.to_string(), *s)).collect()
    }

    #[test]
    fn walls_land_where_the_room_unfolds() {
        let u = unfold(&walls(&[
            ("front", Size::new(4, 3)),
            ("left", Size::new(4, 3)),
            ("right", Size::new(4, 3)),
            ("floor", Size::new(4, 4)),
        ]));
        assert_eq!(u.size, Size::new(12, 7));
        let at = |n: &str| {
            let p = u.place(n).unwrap();
            (p.x, p.y)
        };
        assert_eq!(at("left"), (0, 0));
        assert_eq!(at("front"), (4, 0));
        assert_eq!(at("right"), (8, 0));
        assert_eq!(at("floor"), (4, 3), "the floor is under the front wall");
    }

    #[test]
    fn other_walls_go_in_a_row_below_and_a_shorter_wall_stands_on_the_floor() {
        let u = unfold(&walls(&[
            ("front", Size::new(8, 6)),
            ("left", Size::new(4, 4)),
            ("ceiling", Size::new(8, 8)),
            ("back", Size::new(8, 6)),
        ]));
        // No right wall, no floor: the row below starts under the top row.
        assert_eq!(u.size, Size::new(16, 14));
        let p = u.place("left").unwrap();
        assert_eq!((p.x, p.y), (0, 2), "its bottom on the front wall's");
        let p = u.place("ceiling").unwrap();
        assert_eq!((p.x, p.y), (0, 6));
        let p = u.place("back").unwrap();
        assert_eq!((p.x, p.y), (8, 6));
    }

    #[test]
    fn the_unfolded_cave_fits_the_screen() {
        let u = unfold(&walls(&[
            ("front", Size::new(128, 96)),
            ("left", Size::new(128, 96)),
            ("right", Size::new(128, 96)),
            ("floor", Size::new(128, 128)),
        ]));
        // 384 x 224 eye pixels; 1280 / 384 = 3.33 < 1024 / 224 = 4.57.
        let placed = u.fit(Size::new(1280, 1024));
        let at = |n: &str| placed.iter().find(|p| p.wall == n).unwrap().clone();
        let p = at("left");
        assert_eq!((p.x, p.y, p.size), (0, 0, Size::new(426, 320)));
        assert_eq!((at("front").x, at("front").y), (426, 0));
        assert_eq!((at("right").x, at("right").y), (853, 0));
        let p = at("floor");
        assert_eq!((p.x, p.y, p.size), (426, 320, Size::new(426, 426)));
        for p in &placed {
            assert!(p.x + p.size.width <= 1280 && p.y + p.size.height <= 1024);
        }
    }
}
