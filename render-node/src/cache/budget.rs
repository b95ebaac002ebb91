//! The per-frame sample budget made exact: the dither's choice of pixels cut or filled to
//! the target, without repeating a pixel.

/// Makes the dither's choice exactly `target` of the `pixels` (or all of them), so every
/// frame spends its budget, no more and no less. The dither's count is the target only
/// to within its rounding: each 8 × 8 tile starts from a random error and may hand half a
/// sample on or lose it, so it may choose a few pixels more (as many are dropped, spread
/// evenly over the list from a start that moves with `seed`) or fewer. And it takes at most one sample per pixel: where a tile's
/// priority asks for more than its pixels, the excess is lost, and a budget near one
/// sample per pixel came out about half spent. The rest goes to pixels not yet chosen,
/// spread evenly from a start that moves with `seed`.
pub(super) fn exactly(
    chosen: &mut Vec<u32>,
    target: u32,
    pixels: u32,
    taken: &mut Vec<bool>,
    seed: u32,
) {
    let target = target.min(pixels) as usize;
    if chosen.len() >= target {
        let (n, drop) = (chosen.len(), chosen.len() - target);
        if drop > 0 {
            // Drop positions ⌊(j + f)·n / drop⌋, j = 0..drop, f in [0, 1) from the seed:
            // one in each n/drop of the list, none twice.
            let f = f64::from(seed.wrapping_mul(0x9E37_79B9) >> 8) / f64::from(1u32 << 24);
            let mut j = 0;
            let mut k = 0;
            chosen.retain(|_| {
                let at = ((j as f64 + f) * n as f64 / drop as f64) as usize;
                let keep = !(j < drop && k == at);
                if !keep {
                    j += 1;
                }
                k += 1;
                keep
            });
        }
        return;
    }
    // `taken` is all false on entry, and left so: only the chosen pixels are set, and
    // they are cleared again at the end.
    if taken.len() < pixels as usize {
        taken.resize(pixels as usize, false);
    }
    for &p in chosen.iter() {
        if let Some(t) = taken.get_mut(p as usize) {
            *t = true;
        }
    }
    // A stride prime to the pixel count visits every pixel once, in a scattered order.
    let stride = [7919u64, 104_729, 1_299_709]
        .into_iter()
        .find(|s| u64::from(pixels) % s != 0)
        .unwrap_or(1);
    let n = u64::from(pixels);
    let start = u64::from(seed.wrapping_mul(0x9E37_79B9)) % n;
    for k in 0..n {
        if chosen.len() >= target {
            break;
        }
        let p = ((start + k * stride) % n) as usize;
        if !taken[p] {
            taken[p] = true;
            chosen.push(p as u32);
        }
    }
    for &p in chosen.iter() {
        if let Some(t) = taken.get_mut(p as usize) {
            *t = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::exactly;

    /// The dither's choice is kept, the rest of the target is added without repeating a
    /// pixel, a target beyond the image takes every pixel once, and a choice over the
    /// target is cut to it.
    #[test]
    fn a_choice_is_made_exactly_the_target_with_new_pixels() {
        // One scratch for every size, as the cache's eyes share it.
        let mut taken = Vec::new();
        for pixels in [7919u32 * 3, 1, 7, 12_288] {
            let mut chosen = vec![0, pixels / 2, pixels - 1];
            chosen.dedup();
            let before = chosen.clone();
            let target = pixels.min(1000) * 3 / 4 + 1;
            exactly(&mut chosen, target, pixels, &mut taken, 5);
            assert!(!taken.contains(&true), "scratch left clean");
            assert_eq!(chosen.len(), target.max(before.len() as u32) as usize);
            assert_eq!(chosen[..before.len()], before[..]);
            let mut sorted = chosen.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), chosen.len(), "{pixels}: a pixel chosen twice");
            assert!(chosen.iter().all(|&p| p < pixels));
        }
        let mut all = vec![3];
        exactly(&mut all, 100, 64, &mut Vec::new(), 9);
        assert_eq!(all.len(), 64);
        // More than enough: cut to the target, the pixels dropped spread over the list,
        // in order, with a start that moves with the seed.
        let over: Vec<u32> = (0..100).collect();
        let mut dropped_first = std::collections::BTreeSet::new();
        for seed in 0..50 {
            let mut cut = over.clone();
            exactly(&mut cut, 90, 1000, &mut Vec::new(), seed);
            assert_eq!(cut.len(), 90);
            assert!(cut.windows(2).all(|w| w[0] < w[1]), "kept in order");
            let dropped: Vec<u32> = over.iter().copied().filter(|p| !cut.contains(p)).collect();
            for (j, &d) in dropped.iter().enumerate() {
                assert_eq!(
                    d / 10,
                    j as u32,
                    "seed {seed}: one dropped in each tenth: {dropped:?}"
                );
            }
            dropped_first.insert(dropped[0]);
        }
        assert!(
            dropped_first.len() > 5,
            "the start moves with the seed: {dropped_first:?}"
        );
    }
}
