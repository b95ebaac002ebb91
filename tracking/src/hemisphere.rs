//! Quaternion hemisphere continuity. `q` and `-q` are the same rotation and trackers
//! (the HoloLens traces among them) flip between them; filters and interpolation that
//! treat quaternions as 4-vectors need consecutive samples on the same side.

use glam::Quat;

/// Keeps a stream of quaternions in one hemisphere: each output has a non-negative dot
/// product with the previous output.
#[derive(Clone, Debug, Default)]
pub struct Hemisphere {
    last: Option<Quat>,
    flips: u64,
}

impl Hemisphere {
    pub fn new() -> Self {
        Self::default()
    }

    /// `q` or `-q`, whichever is nearer the previous output.
    pub fn align(&mut self, q: Quat) -> Quat {
        let q = match self.last {
            Some(last) if last.dot(q) < 0.0 => {
                self.flips += 1;
                -q
            }
            _ => q,
        };
        self.last = Some(q);
        q
    }

    /// How many inputs were negated so far.
    pub fn flips(&self) -> u64 {
        self.flips
    }

    /// Forgets the previous output (after a tracking gap).
    pub fn reset(&mut self) {
        self.last = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flipped_samples_are_brought_back() {
        let mut h = Hemisphere::new();
        let seq = [0.0_f32, 0.1, 0.2, 0.3].map(Quat::from_rotation_z);
        let flipped = [seq[0], -seq[1], seq[2], -seq[3]];
        let out: Vec<Quat> = flipped.iter().map(|&q| h.align(q)).collect();
        for (o, s) in out.iter().zip(seq.iter()) {
            assert!((*o - *s).length() < 1e-6);
        }
        assert_eq!(h.flips(), 2);
    }

    #[test]
    fn continuity_holds_across_a_full_turn() {
        let mut h = Hemisphere::new();
        let mut prev = h.align(Quat::IDENTITY);
        for i in 1..=400 {
            let q = Quat::from_rotation_y(i as f32 * 0.05);
            let a = h.align(if i % 3 == 0 { -q } else { q });
            assert!(a.dot(prev) >= 0.0);
            prev = a;
        }
    }
}
