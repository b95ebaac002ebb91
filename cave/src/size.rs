//! An image's size in pixels: a wall's pixels, an eye image, a window. Written and read
//! as `WxH` (flags, file names, summaries).

use std::fmt;
use std::str::FromStr;

/// The most pixels one image may have (2^28: a 16k × 16k image).
pub const MAX_PIXELS: u64 = 1 << 28;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Size {
    pub width: u32,
    pub height: u32,
}

impl Size {
    pub const fn new(width: u32, height: u32) -> Size {
        Size { width, height }
    }

    /// Its pixels' count.
    pub fn area(self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Width over height.
    pub fn aspect(self) -> f32 {
        self.width as f32 / self.height as f32
    }

    /// Each side times `factor`, rounded to the nearest pixel, at least `min`.
    pub fn scaled(self, factor: f64, min: u32) -> Size {
        let side = |p: u32| ((f64::from(p) * factor).round() as u32).max(min);
        Size::new(side(self.width), side(self.height))
    }
}

impl fmt::Display for Size {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

/// `WxH`: both positive, at most [`MAX_PIXELS`].
impl FromStr for Size {
    type Err = String;

    fn from_str(s: &str) -> Result<Size, String> {
        let (w, h) = s
            .split_once('x')
            .ok_or_else(|| format!("{s:?}: expected WxH"))?;
        let w: u32 = w.parse().map_err(|e| format!("{s:?}: {e}"))?;
        let h: u32 = h.parse().map_err(|e| format!("{s:?}: {e}"))?;
        if w == 0 || h == 0 || u64::from(w) * u64::from(h) > MAX_PIXELS {
            return Err(format!(
                "{s:?}: size must be positive and at most 2^28 pixels"
            ));
        }
        Ok(Size::new(w, h))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_size_reads_back_what_it_writes_and_names_bad_input() {
        let s: Size = "64x48".parse().unwrap();
        assert_eq!(s, Size::new(64, 48));
        assert_eq!(s.to_string().parse::<Size>().unwrap(), s);
        assert!("64".parse::<Size>().unwrap_err().contains("WxH"));
        assert!("0x48".parse::<Size>().unwrap_err().contains("positive"));
        assert!("64x-1".parse::<Size>().unwrap_err().contains("\"64x-1\""));
        assert!("65536x65536".parse::<Size>().unwrap_err().contains("2^28"));
        assert!("16384x16384".parse::<Size>().is_ok());
        assert_eq!(Size::new(1024, 768).scaled(0.125, 8), Size::new(128, 96));
        assert_eq!(Size::new(40, 30).scaled(0.125, 8), Size::new(8, 8));
    }
}
