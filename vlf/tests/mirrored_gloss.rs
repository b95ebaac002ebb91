//! A glossy surface without a tile is drawn as the mirror of what it reflects
//! (`surface::mirrored_gloss`): what a pixel shows on it is what its reflecting lobes
//! mirror and what its Lambertian base makes of the light field's light there, not a
//! diffuse drawing of its irradiance, and its punctual lights' highlights come from its
//! own BSDF.

use crate::common;

use std::sync::Arc;

use glam::Vec3;
use holocave_scene::{Material, Ray, Scene};
use holocave_tracer::bsdf::Bsdf;
use holocave_vlf::view::shade_one;
use holocave_vlf::{Settings, Visibility};

const GLOW: f32 = 3.0;
const BASE: Vec3 = Vec3::new(0.8, 0.7, 0.6);

/// A small metal square in the plane z = 0 facing +z, an eye in front of it, a wall
/// glowing `GLOW` behind the eye (z = 2, facing −z), black to light, and a point light of
/// `lamp` between them.
fn metal_before_a_glow(roughness: f32, lamp: f32) -> Arc<Scene> {
    surface_before_a_glow(1.0, roughness, lamp)
}

/// [`metal_before_a_glow`] with the square `metallic` (the rest a dielectric with its
/// specular layer over a Lambertian base).
fn surface_before_a_glow(metallic: f32, roughness: f32, lamp: f32) -> Arc<Scene> {
    let square = common::quad(Vec3::new(-0.05, -0.05, 0.0), Vec3::X * 0.1, Vec3::Y * 0.1);
    let wall = common::quad(Vec3::new(-5.0, -5.0, 2.0), Vec3::Y * 10.0, Vec3::X * 10.0);
    let glow = common::lambert("glow", 0.0, Vec3::splat(GLOW));
    glossy_square_under(
        square,
        (metallic, roughness),
        vec![(wall, glow)],
        (LAMP_AT, lamp),
    )
}

/// A square of `BASE` colour, `metallic` and `roughness` facing +z, the `above` it (quads
/// and their materials), and a point light of `lamp.1` at `lamp.0` if that is positive.
fn glossy_square_under(
    square: [[Vec3; 3]; 2],
    (metallic, roughness): (f32, f32),
    above: Vec<([[Vec3; 3]; 2], Material)>,
    lamp: (Vec3, f32),
) -> Arc<Scene> {
    let mut materials = vec![Material {
        name: "metal".into(),
        base_color: BASE.extend(1.0),
        metallic,
        roughness,
        ..Material::default()
    }];
    let mut tris: Vec<([Vec3; 3], u32)> = square.iter().map(|t| (*t, 0)).collect();
    for (quad, material) in above {
        tris.extend(quad.iter().map(|t| (*t, materials.len() as u32)));
        materials.push(material);
    }
    let lights = if lamp.1 > 0.0 {
        vec![common::point_light(lamp.0, lamp.1)]
    } else {
        Vec::new()
    };
    Arc::new(common::scene("a glossy square", &tris, materials, lights))
}

const LAMP_AT: Vec3 = Vec3::new(0.15, 0.0, 1.0);

/// A bake's settings that give no surface a tile.
fn without_tiles() -> Settings {
    Settings {
        glossy_alpha: 0.0,
        ..Settings::default()
    }
}

/// Chrome (GGX α 0.03) and black satin (α 0.17) with no tile show the glow they mirror,
/// times their Fresnel reflectance at normal incidence (the base colour), to an eye and to
/// a gather's bounce alike, and the pixel's point for the direct light is on the wall
/// mirrored; a rougher metal (α 0.36) is drawn
/// diffuse as before (here black: the light field is empty).
#[test]
fn a_glossy_metal_without_a_tile_shows_what_it_mirrors() {
    let settings = without_tiles();
    let zeros = |vis: &Visibility| vec![[0.0f32; 3]; vis.tiles().elements as usize];
    let eye = Ray::new(Vec3::new(0.01, 0.02, 1.0), -Vec3::Z);
    for alpha in [0.03f32, 0.17] {
        let metal = Visibility::of(metal_before_a_glow(alpha.sqrt(), 0.0), &settings);
        let (l, point) = metal.lookup_and_point(eye);
        let shown = shade_one(&l, &zeros(&metal));
        assert!(
            (shown - BASE * GLOW).abs().max_element() < 1e-4 * GLOW,
            "α {alpha}: the metal shows {shown}, the glow it mirrors {}",
            BASE * GLOW
        );
        // A gather's bounce onto it brings the same (what a metal shows, as what a mirror
        // shows, is no light next-event estimation at the bounce's start takes).
        let arriving = metal.arriving(eye.origin, eye.dir, &zeros(&metal)).radiance;
        assert!(
            (arriving - BASE * GLOW).abs().max_element() < 1e-4 * GLOW,
            "α {alpha}: {arriving} arrives from the metal, the glow it mirrors {}",
            BASE * GLOW
        );
        let wall = point.expect("the mirrored wall's point").triangle;
        assert!(
            wall >= 2,
            "α {alpha}: the point is on the wall, not the metal (triangle {wall})"
        );
    }
    let rough = Visibility::of(metal_before_a_glow(0.6, 0.0), &settings);
    let (l, point) = rough.lookup_and_point(eye);
    assert_eq!(shade_one(&l, &zeros(&rough)), Vec3::ZERO, "drawn diffuse");
    assert!(point.expect("a point on the metal").triangle < 2);
}

/// A punctual light's highlight on a mirrored metal is its BSDF's: `f cos I / d²` at the
/// point seen, which the mirrored ray alone would never show (a point is never seen in a
/// mirror).
#[test]
fn a_mirrored_metal_keeps_its_punctual_highlight() {
    let settings = without_tiles();
    let intensity = 2.0;
    let scene = metal_before_a_glow(0.17f32.sqrt(), intensity);
    let vis = Visibility::of(scene.clone(), &settings);
    let eye = Ray::new(Vec3::new(0.01, 0.02, 1.0), -Vec3::Z);
    let zeros = vec![[0.0f32; 3]; vis.tiles().elements as usize];
    let (l, _) = vis.lookup_and_point(eye);
    let shown = shade_one(&l, &zeros) - BASE * GLOW;

    let at = Vec3::new(0.01, 0.02, 0.0);
    assert_is_the_bsdfs_highlight(&scene, shown, at, (LAMP_AT, intensity));
}

/// `shown` at `at` on the square (material 0, facing +z, seen from straight above) is its
/// BSDF's highlight of the point light `lamp` (position, intensity), `f cos I / d²`,
/// within 0.1 %.
fn assert_is_the_bsdfs_highlight(scene: &Scene, shown: Vec3, at: Vec3, lamp: (Vec3, f32)) {
    let to = lamp.0 - at;
    let wi = to.normalize();
    let params = scene.materials[0].params(&scene.textures, glam::Vec2::ZERO);
    let (f, _) = Bsdf::new(&params).eval(Vec3::Z, wi);
    let expected = f * wi.z * lamp.1 / to.length_squared();
    assert!(
        expected.min_element() > 0.1,
        "a highlight to see: {expected}"
    );
    assert!(
        (shown - expected).abs().max_element() < 1e-3 * expected.max_element(),
        "the highlight shown {shown}, the BSDF's {expected}"
    );
}

/// A glazed surface (a third metallic, GGX α 0.04) shows the glow its reflecting lobes
/// mirror and its Lambertian base's share of the light field's irradiance there, once the
/// view has the values it draws with; without them it is drawn diffuse as before.
#[test]
fn a_glazed_surface_mirrors_its_reflection_over_its_base() {
    let settings = without_tiles();
    let scene = surface_before_a_glow(0.35, 0.2, 0.0);
    let vis = Visibility::of(scene.clone(), &settings);
    let eye = Ray::new(Vec3::new(0.01, 0.02, 1.0), -Vec3::Z);
    let (l, _) = vis.lookup_and_point(eye);
    assert_ne!(l.base, u32::MAX, "drawn diffuse until the values are given");

    let irradiance = 0.7;
    let values = Arc::new(vec![[irradiance; 3]; vis.tiles().elements as usize]);
    vis.draw_with(values.clone(), false);
    let (l, point) = vis.lookup_and_point(eye);
    let shown = shade_one(&l, &values);
    // The glow's wall is black (0 albedo): what is shown is the glow times the reflecting
    // lobes' share at normal incidence — the metal's Fresnel F0 = base, a third of it, and
    // the dielectric's layer F0 = ((1.5 − 1)/(1.5 + 1))² = 0.04, two thirds — and the
    // Lambertian base's share of the irradiance at the glazed square: two thirds of the
    // base colour through the layer out (1 − 0.04) and in (1 − (0.04 + 0.96/21)), over π.
    let (metal, f0) = (0.35, 0.04);
    let specular = BASE * metal + Vec3::splat((1.0 - metal) * f0);
    let base = BASE * (1.0 - metal) * (1.0 - f0) * (1.0 - (f0 + (1.0 - f0) / 21.0));
    let expected = specular * GLOW + base * irradiance * std::f32::consts::FRAC_1_PI;
    assert!(
        (shown - expected).abs().max_element() < 1e-4 * GLOW,
        "shown {shown}, expected {expected}"
    );
    assert!(point.expect("the mirrored wall's point").triangle >= 2);

    // The gathers kept in the field reach the base where the values change (the node's
    // `with_kept_values`): twice the irradiance, twice the base's share.
    let doubled = vec![[2.0 * irradiance; 3]; values.len()];
    let all = 0..values.len();
    vis.update_drawn(&doubled, std::slice::from_ref(&all));
    let (l, _) = vis.lookup_and_point(eye);
    let more = shade_one(&l, &values) - shown;
    let share = base * irradiance * std::f32::consts::FRAC_1_PI;
    assert!(
        (more - share).abs().max_element() < 1e-4 * GLOW,
        "the base's share grew by {more}, expected {share}"
    );
}

/// A metal square of GGX α 0.15 (8 m across, in z = 0, facing +z) under a ceiling at
/// z = 2 glowing `glow` for x < 0 and black for x > 0, and a point light of `lamp` at
/// (0.3, 0, 1).
fn under_a_half_glowing_ceiling(glow: f32, lamp: f32) -> Arc<Scene> {
    let square = common::quad(Vec3::new(-4.0, -4.0, 0.0), Vec3::X * 8.0, Vec3::Y * 8.0);
    let lit = common::quad(Vec3::new(-5.0, -5.0, 2.0), Vec3::Y * 10.0, Vec3::X * 5.0);
    let dark = common::quad(Vec3::new(0.0, -5.0, 2.0), Vec3::Y * 10.0, Vec3::X * 5.0);
    let above = vec![
        (lit, common::lambert("glow", 0.0, Vec3::splat(glow))),
        (dark, common::lambert("dark", 0.0, Vec3::ZERO)),
    ];
    glossy_square_under(square, (1.0, 0.15f32.sqrt()), above, (LAMP, lamp))
}

const LAMP: Vec3 = Vec3::new(0.3, 0.0, 1.0);

/// The metal under the half-glowing ceiling reflects what its lobe blurs. Where its
/// mirror direction meets the edge, half the lobe sees the glow (one mirrored ray would
/// show all of it or none); two metres to either side, where the lobe's half-vectors
/// would have to tilt by more than 0.4 rad (`tan² θ` 0.19 against `α²` 0.0225: under a
/// tenth of them, fewer still towards the edge), at most one of the eight directions
/// crosses it. Each direction is weighted by the Fresnel at its microfacet over the
/// normal incidence's (within 0.1 % at these angles for a base of 0.8) and by the masking
/// on the way in (Smith's G1 above 0.99 within 50° of the normal at α 0.15). Drawn under
/// the direct light per pixel, the glow (an emitter) is left to that pass, and the
/// pixel's point is the metal itself.
#[test]
fn a_rough_gloss_seen_directly_blurs_what_it_reflects() {
    let settings = without_tiles();
    let vis = Visibility::of(under_a_half_glowing_ceiling(GLOW, 0.0), &settings);
    let zeros = Arc::new(vec![[0.0f32; 3]; vis.tiles().elements as usize]);
    vis.light_objects(zeros.clone());
    vis.draw_with(zeros.clone(), false);
    // The share of the full reflection (the base colour, F0 at normal incidence, times the
    // glow) a pixel looking straight down at x shows, and the pixel's point.
    let share = |x: f32| {
        let (l, point) = vis.lookup_and_point(Ray::new(Vec3::new(x, 0.0, 1.0), -Vec3::Z));
        ((shade_one(&l, &zeros) / (BASE * GLOW)).x, point)
    };
    let (edge, point) = share(0.0);
    assert!(point.is_none(), "no point for a per-pixel pass");
    assert!(
        (0.3..=0.7).contains(&edge),
        "the edge reflected: {edge} of the glow, not half"
    );
    let (lit, dark) = (share(-2.0).0, share(2.0).0);
    let one = 1.0 / 8.0;
    assert!(
        lit >= (1.0 - one) * 0.99,
        "the glow's side reflected: {lit}"
    );
    assert!(dark <= one * 1.001, "the dark side reflected: {dark}");

    vis.draw_with(zeros.clone(), true);
    for x in [-2.0, 0.0] {
        let (shown, point) = share(x);
        assert_eq!(shown, 0.0, "x {x}: the glow is the per-pixel pass's");
        let p = point.expect("the metal's own point");
        assert!(p.triangle < 2, "x {x}: the point is on the metal");
    }
}

/// Without the direct light per pixel a punctual light's highlight on the blurred metal
/// (its BSDF's `f cos I / d²`) is drawn at the metal; with it, it is the per-pixel pass's.
#[test]
fn a_blurred_metal_keeps_its_punctual_highlight() {
    let settings = without_tiles();
    let intensity = 2.0;
    let scene = under_a_half_glowing_ceiling(0.0, intensity);
    let vis = Visibility::of(scene.clone(), &settings);
    let zeros = Arc::new(vec![[0.0f32; 3]; vis.tiles().elements as usize]);
    vis.light_objects(zeros.clone());
    let at = Vec3::new(0.6, 0.0, 0.0);
    let eye = Ray::new(at + Vec3::Z, -Vec3::Z);
    vis.draw_with(zeros.clone(), true);
    let (l, point) = vis.lookup_and_point(eye);
    assert_eq!(
        shade_one(&l, &zeros),
        Vec3::ZERO,
        "the per-pixel pass's highlight"
    );
    assert!(point.is_some_and(|p| p.triangle < 2));
    vis.draw_with(zeros.clone(), false);
    let (l, _) = vis.lookup_and_point(eye);
    assert_is_the_bsdfs_highlight(&scene, shade_one(&l, &zeros), at, (LAMP, intensity));
}

/// Gathers kept in the field (`holocave_vlf::kept_gathers`) correct a mirror-drawn
/// surface's Lambertian base too: a glazed square (a third metal, GGX α 0.04, no tile)
/// under a white ceiling that a point light between them lights, its base's elements
/// deliberately halved in the field the walls read. Gathers through the square, whose
/// bounce sees the true field, keep in those elements what the base alone reflects
/// (`ρ_d/π` of the irradiance, the glazing's own reflection left out: with it, the square
/// keeps about twice the irradiance), so their kept values take at least 70 % of
/// the halving off (what is left is the gathers' noise and the bake's own error, the field
/// being coarse); left out, they stay halved.
#[test]
fn gathers_kept_on_a_mirror_drawn_surface_correct_its_base() {
    use holocave_vlf::gather::gather_all;
    use holocave_vlf::kept_gathers::KeptGathers;
    use holocave_vlf::{CpuRays, PixelDirect};
    use rand::{Rng, SeedableRng, rngs::SmallRng};

    let square = common::quad(Vec3::new(-0.5, -0.5, 0.0), Vec3::X, Vec3::Y);
    let ceiling = common::quad(Vec3::new(-1.5, -1.5, 1.5), Vec3::Y * 3.0, Vec3::X * 3.0);
    let white = common::lambert("white", 0.8, Vec3::ZERO);
    let scene = glossy_square_under(
        square,
        (0.35, 0.2),
        vec![(ceiling, white)],
        (Vec3::new(0.0, 0.0, 0.75), 4.0),
    );
    let settings = Settings {
        directions: 92,
        resolution: 64,
        ..without_tiles()
    };
    let (state, _) = common::bake_quiet(&scene, &settings);
    let truth = Arc::new(state.indirect_values());
    let vis = Visibility::of(scene.clone(), &settings);
    vis.light_objects(Arc::new(state.values()));
    vis.draw_with(truth.clone(), true);
    let direct = PixelDirect::new(scene.clone());

    let square_elements: Vec<u32> = (0..2)
        .flat_map(|t| {
            let c = vis.elements().triangles[t];
            let n = holocave_vlf::elements::cells(c.res);
            (0..2).flat_map(move |side| c.base(side)..c.base(side) + n)
        })
        .collect();
    let mut halved = truth.to_vec();
    for &e in &square_elements {
        halved[e as usize] = (Vec3::from(halved[e as usize]) * 0.5).to_array();
    }

    let eye = Vec3::new(0.3, 0.2, 1.2);
    let mut rng = SmallRng::seed_from_u64(7);
    let rays: Vec<Ray> = (0..65_536)
        .map(|_| {
            let at = Vec3::new(rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5, 0.0);
            Ray::new(eye, (at - eye).normalize())
        })
        .collect();
    let gathered = gather_all(&vis, &direct, &truth, &rays, 11, &CpuRays(&scene));
    let mut kept = KeptGathers::new(Arc::new(halved.clone()), 16.0);
    kept.add(gathered.iter().filter_map(|g| g.kept));

    let (mut error, mut bias, mut counted) = (0.0f32, 0.0f32, 0);
    for &e in &square_elements {
        if kept.taken(e) < 64.0 {
            continue;
        }
        let t = Vec3::from(truth[e as usize]);
        error += (Vec3::from(kept.values()[e as usize]) - t)
            .abs()
            .element_sum();
        bias += (Vec3::from(halved[e as usize]) - t).abs().element_sum();
        counted += 1;
    }
    eprintln!(
        "{counted} of the base's elements took 64 gathers or more: kept {error:.3} from the \
         field's, halved {bias:.3}"
    );
    assert!(counted > 20, "only {counted} elements took gathers");
    assert!(
        error < 0.3 * bias,
        "kept {error:.3} away from the field's values, halved {bias:.3}"
    );
}
