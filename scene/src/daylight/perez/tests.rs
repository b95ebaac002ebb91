//! The Perez sky against Radiance's own: golden radiances from `gendaylit` 2.5 and
//! `perezlum.cal` (pyradiance 1.3.1's Radiance binaries, run outside the project).
//!
//! Twenty hours of the Chicago O'Hare TMY3 file (7 clear, 7 intermediate, 6 overcast, by
//! gendaylit's ε: ≥ 4.5, 1.23–4.5, < 1.23), each at the middle of its hour, and three
//! made-up hours that reach gendaylit's limits on ε and Δ, made by
//!
//! ```sh
//! export RAYPATH=.:$PYRADIANCE/lib
//! gendaylit M D H.5 -a 41.98 -o 87.92 -m 90 -W DNI DHI -O 1     # the line above each row
//! rcalc -f rayinit.cal -f perezlum.cal -e 'A1=…;…;A10=…' \
//!       -e 'Dx=$1;Dy=$2;Dz=$3;$1=skybright' < directions
//! ```
//!
//! with A1…A10 the ten numbers of gendaylit's `skyfunc` line. Directions are `east north
//! up` (gendaylit's x, y, z): altitudes 15°, 30°, 45°, 60° towards north, east, south and
//! west, the zenith, and two near the sun (5° above it; 10° round the horizon from it). The
//! sun's direction is gendaylit's own, so the test is of the sky model, not of the sun's
//! position. gendaylit normalises with a sum over 145 sky points and blends the sky into
//! its ground near the horizon (`wmean((Dz+1.01)^10, …)`, under 1 % at 15°); the model
//! here normalises with a fine integral, so the two differ by gendaylit's quadrature.

use super::*;

struct Golden {
    kind: &'static str,
    line: usize,
    month: u32,
    day: u32,
    dni: f64,
    dhi: f64,
    day_of_year: u32,
    epsilon: f64,
    /// gendaylit's sun: east, north, up.
    sun: [f64; 3],
    /// W·m⁻²·sr⁻¹ (solar) towards [`directions`].
    radiance: [f64; 19],
}

const GOLDEN: [Golden; 23] = [
    // gendaylit 1 23 9.5 -a 41.98 -o 87.92 -m 90 -W 527.0 91.0 -O 1
    Golden {
        kind: "intermediate",
        line: 546,
        month: 1,
        day: 23,
        dni: 527.0,
        dhi: 91.0,
        day_of_year: 23,
        epsilon: 2.9356,
        sun: [0.583758, -0.744743, 0.323395],
        radiance: [
            27.7791, 44.9071, 66.6746, 26.3751, 18.4098, 32.6377, 47.1892, 17.8305, 14.1902,
            24.8487, 32.3024, 14.0739, 12.3596, 19.2856, 22.2135, 12.5031, 13.2663, 213.12,
            192.167,
        ],
    },
    // gendaylit 1 28 9.5 -a 41.98 -o 87.92 -m 90 -W 9.0 124.0 -O 1
    Golden {
        kind: "overcast",
        line: 666,
        month: 1,
        day: 28,
        dni: 9.0,
        dhi: 124.0,
        day_of_year: 28,
        epsilon: 1.0249,
        sun: [0.591459, -0.732064, 0.338020],
        radiance: [
            27.3403, 38.1506, 41.3963, 27.8394, 31.0783, 43.021, 46.4128, 31.6678, 33.7247, 44.743,
            47.3748, 34.3493, 36.0616, 44.44, 46.0012, 36.6343, 40.9929, 58.7009, 54.4354,
        ],
    },
    // gendaylit 2 15 12.5 -a 41.98 -o 87.92 -m 90 -W 901.0 86.0 -O 1
    Golden {
        kind: "clear",
        line: 1101,
        month: 2,
        day: 15,
        dni: 901.0,
        dhi: 86.0,
        day_of_year: 46,
        epsilon: 6.3762,
        sun: [-0.102603, -0.818216, 0.565681],
        radiance: [
            33.3744, 22.9594, 104.736, 24.6699, 17.4909, 15.2883, 159.194, 17.2299, 11.9321,
            13.179, 91.8447, 15.0688, 10.2343, 12.7711, 35.4362, 14.3338, 13.5364, 164.336, 138.55,
        ],
    },
    // gendaylit 3 6 14.5 -a 41.98 -o 87.92 -m 90 -W 674.0 110.0 -O 1
    Golden {
        kind: "intermediate",
        line: 1559,
        month: 3,
        day: 6,
        dni: 674.0,
        dhi: 110.0,
        day_of_year: 65,
        epsilon: 3.8829,
        sun: [-0.594039, -0.615486, 0.517972],
        radiance: [
            31.4315, 31.2891, 62.4458, 59.4137, 20.0526, 20.0234, 49.2691, 46.5324, 15.2706,
            15.2988, 38.6302, 36.7883, 13.5004, 13.5575, 28.3025, 27.4897, 15.8274, 185.408,
            170.483,
        ],
    },
    // gendaylit 4 3 11.5 -a 41.98 -o 87.92 -m 90 -W 6.0 262.0 -O 1
    Golden {
        kind: "overcast",
        line: 2228,
        month: 4,
        day: 3,
        dni: 6.0,
        dhi: 262.0,
        day_of_year: 93,
        epsilon: 1.0177,
        sun: [0.108817, -0.600197, 0.792416],
        radiance: [
            53.9725, 61.2846, 70.2009, 58.7612, 66.7587, 75.635, 89.368, 72.4129, 75.8136, 85.3159,
            104.396, 81.7419, 83.1572, 92.0445, 109.053, 88.6841, 96.4616, 111.45, 109.398,
        ],
    },
    // gendaylit 4 10 14.5 -a 41.98 -o 87.92 -m 90 -W 742.0 167.0 -O 1
    Golden {
        kind: "intermediate",
        line: 2399,
        month: 4,
        day: 10,
        dni: 742.0,
        dhi: 167.0,
        day_of_year: 100,
        epsilon: 3.7029,
        sun: [-0.627100, -0.416106, 0.658484],
        radiance: [
            39.4377, 40.2218, 58.9527, 90.4473, 28.458, 28.1004, 51.946, 92.8535, 24.3393, 23.2479,
            49.9721, 91.2693, 23.8791, 22.2844, 46.3534, 69.8489, 31.6009, 235.131, 217.986,
        ],
    },
    // gendaylit 5 3 9.5 -a 41.98 -o 87.92 -m 90 -W 883.0 109.0 -O 1
    Golden {
        kind: "clear",
        line: 2946,
        month: 5,
        day: 3,
        dni: 883.0,
        dhi: 109.0,
        day_of_year: 123,
        epsilon: 7.0066,
        sun: [0.547410, -0.331526, 0.768396],
        radiance: [
            27.4369, 53.3441, 37.9977, 30.6174, 17.1142, 50.2919, 30.0181, 17.0189, 14.8823,
            60.9454, 29.44, 13.5377, 15.5527, 56.9529, 30.092, 13.8126, 22.311, 172.329, 161.677,
        ],
    },
    // gendaylit 5 21 14.5 -a 41.98 -o 87.92 -m 90 -W 680.0 155.0 -O 1
    Golden {
        kind: "intermediate",
        line: 3383,
        month: 5,
        day: 21,
        dni: 680.0,
        dhi: 155.0,
        day_of_year: 141,
        epsilon: 4.2126,
        sun: [-0.609311, -0.221818, 0.761273],
        radiance: [
            38.9233, 38.6808, 47.2033, 88.8354, 27.9252, 25.991, 38.3632, 102.229, 24.4642,
            21.2461, 37.3652, 131.011, 24.9896, 20.6252, 38.8724, 106.358, 33.9736, 191.099,
            185.691,
        ],
    },
    // gendaylit 5 29 8.5 -a 41.98 -o 87.92 -m 90 -W 0.0 308.0 -O 1
    Golden {
        kind: "overcast",
        line: 3569,
        month: 5,
        day: 29,
        dni: 0.0,
        dhi: 308.0,
        day_of_year: 149,
        epsilon: 1.0000,
        sun: [0.709392, -0.128402, 0.693020],
        radiance: [
            64.4238, 100.902, 70.2321, 56.1805, 78.3152, 135.507, 85.9977, 67.6281, 88.6477,
            159.794, 97.2297, 76.5445, 97.5464, 145.585, 105.436, 85.6678, 109.518, 166.36,
            159.722,
        ],
    },
    // gendaylit 6 10 11.5 -a 41.98 -o 87.92 -m 90 -W 3.0 380.0 -O 1
    Golden {
        kind: "overcast",
        line: 3860,
        month: 6,
        day: 10,
        dni: 3.0,
        dhi: 380.0,
        day_of_year: 161,
        epsilon: 1.0076,
        sun: [0.083584, -0.322483, 0.942878],
        radiance: [
            75.2613, 82.7837, 88.6633, 79.4697, 96.6335, 106.651, 115.942, 102.02, 111.771,
            124.071, 137.849, 118.134, 125.138, 139.27, 159.449, 132.238, 154.47, 172.274, 173.967,
        ],
    },
    // gendaylit 6 14 7.5 -a 41.98 -o 87.92 -m 90 -W 268.0 230.0 -O 1
    Golden {
        kind: "intermediate",
        line: 3952,
        month: 6,
        day: 14,
        dni: 268.0,
        dhi: 230.0,
        day_of_year: 165,
        epsilon: 1.5794,
        sun: [0.835328, 0.037946, 0.548441],
        radiance: [
            54.2773, 254.628, 52.6668, 49.2956, 49.376, 422.067, 47.4282, 41.2179, 45.4566,
            244.631, 43.4283, 35.2047, 43.6327, 114.114, 41.8575, 32.8012, 42.3736, 363.926,
            328.304,
        ],
    },
    // gendaylit 7 2 10.5 -a 41.98 -o 87.92 -m 90 -W 62.0 351.0 -O 1
    Golden {
        kind: "overcast",
        line: 4387,
        month: 7,
        day: 2,
        dni: 62.0,
        dhi: 351.0,
        day_of_year: 183,
        epsilon: 1.1610,
        sun: [0.334671, -0.282248, 0.899073],
        radiance: [
            57.6811, 93.5322, 87.4705, 56.615, 60.8943, 118.932, 108.503, 59.0848, 67.2114,
            152.929, 135.986, 64.6225, 81.1176, 193.037, 169.149, 77.7498, 144.493, 297.336,
            309.54,
        ],
    },
    // gendaylit 7 5 13.5 -a 41.98 -o 87.92 -m 90 -W 750.0 170.0 -O 1
    Golden {
        kind: "clear",
        line: 4462,
        month: 7,
        day: 5,
        dni: 750.0,
        dhi: 170.0,
        day_of_year: 186,
        epsilon: 4.9589,
        sun: [-0.368118, -0.277288, 0.887469],
        radiance: [
            38.0791, 38.0743, 52.4292, 59.588, 26.5068, 25.6168, 47.1256, 57.9602, 24.7102, 23.204,
            56.0003, 75.835, 28.444, 26.2316, 73.6896, 105.704, 58.9988, 207.86, 219.188,
        ],
    },
    // gendaylit 8 8 8.5 -a 41.98 -o 87.92 -m 90 -W 755.0 123.0 -O 1
    Golden {
        kind: "clear",
        line: 5273,
        month: 8,
        day: 8,
        dni: 755.0,
        dhi: 123.0,
        day_of_year: 220,
        epsilon: 4.5139,
        sun: [0.756174, -0.192683, 0.625359],
        radiance: [
            32.5517, 118.412, 37.6926, 37.1787, 21.8106, 140.015, 27.5456, 21.8711, 18.2237,
            122.273, 24.1498, 16.156, 17.4789, 60.0422, 22.7654, 14.4505, 19.8807, 189.447,
            173.573,
        ],
    },
    // gendaylit 8 21 13.5 -a 41.98 -o 87.92 -m 90 -W 354.0 285.0 -O 1
    Golden {
        kind: "intermediate",
        line: 5590,
        month: 8,
        day: 21,
        dni: 354.0,
        dhi: 285.0,
        day_of_year: 233,
        epsilon: 1.9766,
        sun: [-0.393785, -0.448095, 0.802586],
        radiance: [
            51.2645, 51.6644, 90.4974, 82.6416, 45.3019, 45.9533, 110.344, 96.1076, 42.0304,
            43.0174, 135.792, 114.078, 44.2203, 45.6275, 145.34, 124.331, 77.1851, 346.989,
            343.737,
        ],
    },
    // gendaylit 9 11 13.5 -a 41.98 -o 87.92 -m 90 -W 819.0 100.0 -O 1
    Golden {
        kind: "clear",
        line: 6094,
        month: 9,
        day: 11,
        dni: 819.0,
        dhi: 100.0,
        day_of_year: 254,
        epsilon: 6.5210,
        sun: [-0.427191, -0.553626, 0.714847],
        radiance: [
            29.0477, 26.8837, 48.4685, 39.2382, 16.157, 15.8915, 42.4478, 31.0905, 12.5954,
            13.0811, 44.0753, 29.8199, 12.4566, 13.197, 37.8846, 28.1201, 18.4181, 165.317,
            149.183,
        ],
    },
    // gendaylit 9 30 11.5 -a 41.98 -o 87.92 -m 90 -W 535.0 250.0 -O 1
    Golden {
        kind: "intermediate",
        line: 6548,
        month: 9,
        day: 30,
        dni: 535.0,
        dhi: 250.0,
        day_of_year: 273,
        epsilon: 2.3947,
        sun: [0.051029, -0.716013, 0.696219],
        radiance: [
            48.5566, 56.4013, 169.699, 53.9676, 40.5312, 51.6752, 267.747, 48.3855, 35.3355,
            49.7563, 391.813, 45.7721, 34.2491, 50.9188, 182.357, 46.8268, 52.6942, 340.609,
            321.314,
        ],
    },
    // gendaylit 10 27 14.5 -a 41.98 -o 87.92 -m 90 -W 800.0 50.0 -O 1
    Golden {
        kind: "clear",
        line: 7199,
        month: 10,
        day: 27,
        dni: 800.0,
        dhi: 50.0,
        day_of_year: 300,
        epsilon: 6.7256,
        sun: [-0.670031, -0.647376, 0.363267],
        radiance: [
            18.8509, 19.1904, 25.9709, 27.1313, 10.8794, 11.0214, 17.6063, 18.388, 7.97243,
            8.02188, 13.3894, 13.8137, 6.81546, 6.81635, 10.4675, 10.6441, 7.23244, 121.64,
            100.101,
        ],
    },
    // gendaylit 11 27 10.5 -a 41.98 -o 87.92 -m 90 -W 5.0 189.0 -O 1
    Golden {
        kind: "overcast",
        line: 7939,
        month: 11,
        day: 27,
        dni: 5.0,
        dhi: 189.0,
        day_of_year: 331,
        epsilon: 1.0104,
        sun: [0.276343, -0.866835, 0.415008],
        radiance: [
            38.2845, 50.0904, 83.0558, 41.7074, 42.9337, 57.232, 94.6072, 47.4535, 46.3651,
            61.1403, 88.8819, 51.5542, 50.0505, 62.7959, 78.4917, 55.0907, 60.9019, 110.506,
            101.935,
        ],
    },
    // gendaylit 12 5 13.5 -a 41.98 -o 87.92 -m 90 -W 836.0 44.0 -O 1
    Golden {
        kind: "clear",
        line: 8134,
        month: 12,
        day: 5,
        dni: 836.0,
        dhi: 44.0,
        day_of_year: 339,
        epsilon: 7.6965,
        sun: [-0.419409, -0.835747, 0.354432],
        radiance: [
            20.0778, 14.8398, 40.7833, 17.3481, 11.056, 8.91186, 26.4074, 11.5376, 7.59599,
            6.87181, 15.9619, 9.22666, 6.09643, 6.09909, 10.4112, 7.85747, 6.27677, 108.4, 89.0302,
        ],
    },
    // Three made-up hours at gendaylit's limits: Δ taken as 0.2 (1.065 < ε < 2.8), ε held
    // at 12.009, Δ held at 0.6.
    // gendaylit 6 21 12.5 -a 41.98 -o 87.92 -m 90 -W 100.0 100.0 -O 1
    Golden {
        kind: "held Δ 0.2",
        line: 0,
        month: 6,
        day: 21,
        dni: 100.0,
        dhi: 100.0,
        day_of_year: 172,
        epsilon: 1.9572,
        sun: [-0.147140, -0.309842, 0.939334],
        radiance: [
            17.998, 18.8727, 26.837, 22.3842, 15.7059, 17.194, 31.9414, 23.3484, 15.5031, 18.0076,
            45.5924, 28.6403, 18.7422, 22.8933, 74.331, 40.455, 50.8232, 110.733, 122.808,
        ],
    },
    // gendaylit 6 21 12.5 -a 41.98 -o 87.92 -m 90 -W 1000.0 20.0 -O 1
    Golden {
        kind: "held ε 12.009",
        line: 0,
        month: 6,
        day: 21,
        dni: 1000.0,
        dhi: 20.0,
        day_of_year: 172,
        epsilon: 12.0090,
        sun: [-0.147140, -0.309842, 0.939334],
        radiance: [
            5.84064, 5.89316, 7.99939, 6.88789, 3.55655, 3.90505, 6.29042, 5.07935, 3.17072,
            3.59445, 7.26603, 4.95624, 3.38566, 3.87272, 13.9276, 6.13794, 7.99562, 30.3095,
            36.7135,
        ],
    },
    // gendaylit 12 21 8.5 -a 41.98 -o 87.92 -m 90 -W 0.0 300.0 -O 1
    Golden {
        kind: "held Δ 0.6",
        line: 0,
        month: 12,
        day: 21,
        dni: 0.0,
        dhi: 300.0,
        day_of_year: 355,
        epsilon: 1.0000,
        sun: [0.700093, -0.692391, 0.174540],
        radiance: [
            81.1307, 124.923, 122.928, 81.3601, 73.0167, 110.363, 108.954, 73.1727, 68.2595,
            94.617, 93.8815, 68.3438, 65.5336, 81.3451, 81.05, 65.5579, 67.0085, 736.729, 567.942,
        ],
    },
];

/// A scene direction (north −Z, east +X, up +Y) from `east north up`.
fn scene(enu: [f64; 3]) -> Vec3 {
    Vec3::new(enu[0] as f32, enu[2] as f32, -enu[1] as f32)
}

/// The directions of a golden row, `east north up`: altitudes 15°, 30°, 45°, 60° each
/// towards north, east, south and west; the zenith; 5° above the sun; 10° round from it.
fn directions(sun: [f64; 3]) -> Vec<[f64; 3]> {
    let enu = |alt: f64, az: f64| {
        let (alt, az) = (alt.to_radians(), az.to_radians());
        [alt.cos() * az.sin(), alt.cos() * az.cos(), alt.sin()]
    };
    let mut d = Vec::new();
    for alt in [15.0, 30.0, 45.0, 60.0] {
        for az in [0.0, 90.0, 180.0, 270.0] {
            d.push(enu(alt, az));
        }
    }
    d.push([0.0, 0.0, 1.0]);
    let (alt, az) = (
        sun[2].asin().to_degrees(),
        sun[0].atan2(sun[1]).to_degrees(),
    );
    d.push(enu(alt + 5.0, az));
    d.push(enu(alt, az + 10.0));
    d
}

fn sky(g: &Golden) -> PerezSky {
    PerezSky::new(scene(g.sun), g.dni, g.dhi, g.day_of_year)
        .unwrap()
        .unwrap()
}

#[test]
fn radiance_within_3_percent_of_gendaylit() {
    let mut worst = (0.0f64, 0, [0.0; 3]);
    for g in &GOLDEN {
        let sky = sky(g);
        assert!(
            (sky.epsilon - g.epsilon).abs() < 1e-4,
            "line {}: ε {}",
            g.line,
            sky.epsilon
        );
        for (d, want) in directions(g.sun).iter().zip(g.radiance) {
            // The made-up hours' directions below 20° are left out: there gendaylit's ground
            // (A2) is up to eleven times the sky's radiance, and perezlum.cal's blend of sky
            // into ground moves 15° by up to 8 %.
            if g.line == 0 && d[2] < 20f64.to_radians().sin() {
                continue;
            }
            let got = sky.radiance(scene(*d));
            let err = (got - want).abs() / want;
            assert!(
                err < 0.03,
                "{} hour, line {} ({}/{}): {got} against gendaylit's {want} towards {d:?}",
                g.kind,
                g.line,
                g.month,
                g.day
            );
            if err > worst.0 {
                worst = (err, g.line, *d);
            }
        }
    }
    eprintln!(
        "worst relative error against gendaylit: {:.3} % (line {}, towards {:?})",
        worst.0 * 100.0,
        worst.1,
        worst.2
    );
}

#[test]
fn horizontal_irradiance_is_the_dhi() {
    let mut worst = 0.0f64;
    for g in &GOLDEN {
        // A finer grid than the normalisation's, so its own quadrature error shows.
        let e = sky(g).horizontal_irradiance(720);
        worst = worst.max((e - g.dhi).abs() / g.dhi);
    }
    eprintln!(
        "worst horizontal irradiance against the DHI: {:.4} %",
        worst * 100.0
    );
    assert!(worst < 0.02, "{worst}");
}

/// The model is negative for some rare ε and Δ (here ε 3.39, Δ 0.048, a = −1.07, at a high
/// sun): `gendaylit 6 21 12.5 -a 41.98 -o 87.92 -m 90 -W 150 60 -O 1` then prints a
/// negative normalisation (−267.6) and a sky negative towards the horizon. Here the sky is
/// dark where the model is negative, never negative, and still gives the DHI.
#[test]
fn no_negative_radiance() {
    let sun = scene([-0.147140, -0.309842, 0.939334]);
    let sky = PerezSky::new(sun, 150.0, 60.0, 172).unwrap().unwrap();
    assert!(sky.coefficients[0] < -1.0, "{:?}", sky.coefficients);
    assert_eq!(sky.radiance(Vec3::Y), 0.0);
    for g in 0..8 {
        let d = directions([0.0, 0.0, 1.0])[g * 2];
        assert!(sky.radiance(scene(d)) >= 0.0, "{d:?}");
    }
    let e = sky.horizontal_irradiance(720);
    assert!((e / 60.0 - 1.0).abs() < 1e-3, "{e}");
}

#[test]
fn dark_and_impossible_hours() {
    let below = Vec3::new(0.0, -0.1, 1.0).normalize();
    assert_eq!(PerezSky::new(below, 0.0, 20.0, 100).unwrap(), None);
    assert_eq!(PerezSky::new(Vec3::Y, 0.0, 0.0, 100).unwrap(), None);
    let e = PerezSky::new(Vec3::Y, 1500.0, 50.0, 100)
        .unwrap_err()
        .to_string();
    assert!(e.contains("1500"), "{e}");
    let e = PerezSky::new(Vec3::Y, f64::NAN, 50.0, 100)
        .unwrap_err()
        .to_string();
    assert!(e.contains("DNI"), "{e}");
}
