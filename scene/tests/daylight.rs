//! Daylight TOML: good files give the sun and sky they describe; bad ones are errors
//! that name the file and the field.

use std::path::Path;

use glam::Vec3;
use holocave_scene::{Daylight, LoadOptions, Scene, SceneError, SkyModel};

const FILE: &str = "sky.daylight.toml";

fn parse(text: &str) -> Result<Daylight, SceneError> {
    Daylight::parse(text, Path::new(FILE))
}

/// Parses text that must fail; the message names the file and contains every needle.
fn parse_err(text: &str, needles: &[&str]) -> String {
    let msg = match parse(text) {
        Ok(d) => panic!("{text:?} parsed as {d:?}, but must fail"),
        Err(e) => {
            assert!(matches!(e, SceneError::Daylight { .. }), "{e:?}");
            e.to_string()
        }
    };
    assert!(msg.contains(FILE), "{msg:?} does not name the file");
    for n in needles {
        assert!(msg.contains(n), "{msg:?} does not mention {n:?}");
    }
    msg
}

const SUN: &str =
    "[sun]\nelevation_deg = 30.0\nazimuth_deg = 90.0\nirradiance = [100.0, 100.0, 100.0]\n";

#[test]
fn every_sky_model_parses() {
    let d = parse(&format!(
        "{SUN}[sky]\nmodel = \"uniform\"\nradiance = [1.0, 2.0, 3.0]\nground_albedo = 0.0\n"
    ))
    .unwrap();
    let sun = d.sun.as_ref().unwrap();
    let el = 30f32.to_radians();
    assert!((sun.direction - Vec3::new(el.cos(), el.sin(), 0.0)).length() < 1e-5);
    assert!(
        (sun.angular_radius - 0.265f32.to_radians()).abs() < 1e-7,
        "default 0.53°"
    );
    assert!((sun.radiance * sun.solid_angle() - Vec3::splat(100.0)).length() < 1e-2);
    let sky = d.sky.unwrap();
    assert_eq!(sky.model, SkyModel::Uniform(Vec3::new(1.0, 2.0, 3.0)));
    assert_eq!(sky.radiance(-Vec3::Y), Vec3::ZERO, "albedo 0: black ground");

    let d = parse("[sky]\nmodel = \"cie_overcast\"\nzenith_radiance = [3.0, 3.0, 3.0]\n").unwrap();
    assert!(d.sun.is_none());
    let sky = d.sky.unwrap();
    assert!((sky.radiance(Vec3::Y).x - 3.0).abs() < 1e-6);
    assert!(
        (sky.radiance(Vec3::X).x - 1.0).abs() < 1e-6,
        "horizon is a third"
    );
    // Ground: E = 7π/9 Lz, times the default albedo 0.2 over π.
    assert!((sky.radiance(-Vec3::Y).x - 7.0 / 9.0 * 3.0 * 0.2).abs() < 1e-3);

    let d = parse(&format!(
        "{SUN}[sky]\nmodel = \"cie_clear\"\nzenith_radiance = [1.0, 1.0, 1.0]\n"
    ))
    .unwrap();
    match d.sky.unwrap().model {
        SkyModel::CieClear { sun, .. } => {
            assert!((sun - d.sun.unwrap().direction).length() < 1e-6)
        }
        m => panic!("{m:?}"),
    }

    // A direction instead of elevation and azimuth, radiance instead of irradiance.
    let d = parse("[sun]\ndirection = [0.0, 2.0, 0.0]\nradiance = [5.0, 5.0, 5.0]\nangular_diameter_deg = 1.0\n").unwrap();
    let sun = d.sun.unwrap();
    assert_eq!(sun.direction, Vec3::Y);
    assert_eq!(sun.radiance, Vec3::splat(5.0));
    // 2π(1 − cos r) in f64, against the f32 solid angle to a few float steps.
    let exact = std::f64::consts::TAU * (1.0 - 0.5f64.to_radians().cos());
    assert!((f64::from(sun.solid_angle()) / exact - 1.0).abs() < 1e-6);

    // An empty file: no sun, no sky.
    assert_eq!(parse("").unwrap(), Daylight::default());
}

#[test]
fn bad_model_name() {
    parse_err(
        "[sky]\nmodel = \"hosek\"\nradiance = [1.0, 1.0, 1.0]\n",
        &[
            "sky.model",
            "\"hosek\"",
            "uniform",
            "cie_overcast",
            "cie_clear",
            "map",
        ],
    );
}

#[test]
fn missing_fields() {
    parse_err("[sky]\nradiance = [1.0, 1.0, 1.0]\n", &["model"]);
    parse_err("[sky]\nmodel = \"uniform\"\n", &["uniform", "radiance"]);
    parse_err("[sky]\nmodel = \"cie_overcast\"\n", &["zenith_radiance"]);
    parse_err(
        "[sky]\nmodel = \"cie_clear\"\nzenith_radiance = [1.0, 1.0, 1.0]\n",
        &["[sun]"],
    );
    parse_err("[sky]\nmodel = \"map\"\n", &["path"]);
    parse_err(
        "[sun]\nirradiance = [1.0, 1.0, 1.0]\n",
        &["direction", "elevation_deg", "azimuth_deg"],
    );
    parse_err(
        "[sun]\nelevation_deg = 10.0\nirradiance = [1.0, 1.0, 1.0]\n",
        &["azimuth_deg"],
    );
    parse_err(
        "[sun]\ndirection = [0.0, 1.0, 0.0]\n",
        &["radiance", "irradiance"],
    );
    // Both forms at once is as wrong as neither.
    parse_err(
        "[sun]\ndirection = [0.0, 1.0, 0.0]\nradiance = [1.0, 1.0, 1.0]\nirradiance = [1.0, 1.0, 1.0]\n",
        &["exactly one of radiance or irradiance"],
    );
}

#[test]
fn unknown_and_mistyped_fields() {
    parse_err(&format!("{SUN}colour = [1.0, 1.0, 1.0]\n"), &["colour"]);
    parse_err(
        "[sky]\nmodel = \"uniform\"\nradiance = 3.0\n",
        &["radiance"],
    );
    parse_err(
        "[sky]\nmodel = \"uniform\"\nradiance = [1.0, 1.0]\n",
        &["radiance"],
    );
    parse_err("[moon]\nphase = 0.5\n", &["moon"]);
    parse_err("[sun\n", &[]);
}

#[test]
fn non_finite_and_out_of_range_values() {
    // TOML has nan and inf literals.
    for (text, field) in [
        (
            "[sun]\ndirection = [0.0, 1.0, 0.0]\nirradiance = [nan, 1.0, 1.0]\n",
            "sun.irradiance",
        ),
        (
            "[sun]\ndirection = [0.0, 1.0, 0.0]\nradiance = [inf, 1.0, 1.0]\n",
            "sun.radiance",
        ),
        (
            "[sun]\ndirection = [0.0, 1.0, 0.0]\nradiance = [-1.0, 1.0, 1.0]\n",
            "sun.radiance",
        ),
        (
            "[sun]\ndirection = [nan, 1.0, 0.0]\nradiance = [1.0, 1.0, 1.0]\n",
            "sun.direction",
        ),
        (
            "[sun]\ndirection = [0.0, 0.0, 0.0]\nradiance = [1.0, 1.0, 1.0]\n",
            "sun.direction",
        ),
        (
            "[sun]\nelevation_deg = nan\nazimuth_deg = 0.0\nradiance = [1.0, 1.0, 1.0]\n",
            "sun.elevation_deg",
        ),
        (
            "[sun]\nelevation_deg = 10.0\nazimuth_deg = inf\nradiance = [1.0, 1.0, 1.0]\n",
            "sun.azimuth_deg",
        ),
        (
            "[sun]\nelevation_deg = 100.0\nazimuth_deg = 0.0\nradiance = [1.0, 1.0, 1.0]\n",
            "sun.elevation_deg",
        ),
        (
            "[sun]\ndirection = [0.0, 1.0, 0.0]\nradiance = [1.0, 1.0, 1.0]\nangular_diameter_deg = nan\n",
            "sun.angular_diameter_deg",
        ),
        (
            "[sun]\ndirection = [0.0, 1.0, 0.0]\nradiance = [1.0, 1.0, 1.0]\nangular_diameter_deg = 0.0\n",
            "sun.angular_diameter_deg",
        ),
        (
            "[sky]\nmodel = \"uniform\"\nradiance = [1.0, nan, 1.0]\n",
            "sky.radiance",
        ),
        (
            "[sky]\nmodel = \"cie_overcast\"\nzenith_radiance = [1.0, 1.0, -inf]\n",
            "sky.zenith_radiance",
        ),
        (
            "[sky]\nmodel = \"uniform\"\nradiance = [1.0, 1.0, 1.0]\nground_albedo = nan\n",
            "sky.ground_albedo",
        ),
        (
            "[sky]\nmodel = \"uniform\"\nradiance = [1.0, 1.0, 1.0]\nground_albedo = 1.5\n",
            "sky.ground_albedo",
        ),
        (
            "[sky]\nmodel = \"map\"\npath = \"m.exr\"\nscale = nan\n",
            "sky.scale",
        ),
        (
            "[sky]\nmodel = \"map\"\npath = \"m.exr\"\nscale = -1.0\n",
            "sky.scale",
        ),
    ] {
        parse_err(text, &[field]);
    }
}

#[test]
fn sky_map_from_exr() {
    let dir = tempfile::tempdir().unwrap();
    // 8 × 4: the top half (above the horizon) bright blue, the bottom half dark; one NaN
    // texel and one negative texel, which must not get through.
    let map = dir.path().join("sky.exr");
    exr::prelude::write_rgb_file(&map, 8, 4, |x, y| {
        if (x, y) == (0, 0) {
            (f32::NAN, 0.0, 0.0)
        } else if (x, y) == (1, 0) {
            (-5.0, 0.0, 0.0)
        } else if y < 2 {
            (1.0, 2.0, 4.0)
        } else {
            (0.1, 0.1, 0.1)
        }
    })
    .unwrap();
    let toml = dir.path().join(FILE);
    std::fs::write(
        &toml,
        "[sky]\nmodel = \"map\"\npath = \"sky.exr\"\nscale = 2.0\n",
    )
    .unwrap();
    let d = Daylight::load(&toml).unwrap();
    let sky = d.sky.unwrap();
    let SkyModel::Map(m) = &sky.model else {
        panic!("{:?}", sky.model)
    };
    assert_eq!((m.width, m.height), (8, 4));
    assert!(
        m.texels
            .iter()
            .all(|t| t.is_finite() && t.min_element() >= 0.0)
    );
    let up = sky.radiance(Vec3::new(0.3, 0.8, 0.2).normalize());
    assert!((up - Vec3::new(2.0, 4.0, 8.0)).length() < 1e-6, "{up}");
    let down = sky.radiance(Vec3::new(0.3, -0.8, 0.2).normalize());
    assert!((down - Vec3::splat(0.2)).length() < 1e-6, "{down}");

    // A missing map: the error names the map's path.
    std::fs::write(&toml, "[sky]\nmodel = \"map\"\npath = \"nowhere.exr\"\n").unwrap();
    let e = Daylight::load(&toml).unwrap_err().to_string();
    assert!(e.contains("nowhere.exr"), "{e}");
    // A map that is not an EXR.
    std::fs::write(dir.path().join("junk.exr"), b"junk").unwrap();
    std::fs::write(&toml, "[sky]\nmodel = \"map\"\npath = \"junk.exr\"\n").unwrap();
    let e = Daylight::load(&toml).unwrap_err().to_string();
    assert!(e.contains("junk.exr") && e.contains("sky map"), "{e}");
}

#[test]
fn daylight_files_beside_scenes_and_on_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let scene_path = dir.path().join("tri.gltf");
    let mut w = holocave_scene::generate::GltfWriter::default();
    let m = w.material(serde_json::json!({ "name": "m" }));
    let mesh = w.mesh(
        "tri",
        &[Vec3::ZERO, Vec3::X, Vec3::Y],
        &[Vec3::Z; 3],
        &[0, 1, 2],
        m,
    );
    w.node("tri", mesh, Vec3::ZERO, glam::Quat::IDENTITY, Vec3::ONE);
    std::fs::write(&scene_path, w.finish()).unwrap();

    // None beside it: no daylight.
    let s = Scene::load(&scene_path, &LoadOptions::default()).unwrap();
    assert_eq!(s.daylight, Daylight::default());
    // `<stem>.daylight.toml` beside it is picked up.
    std::fs::write(
        dir.path().join("tri.daylight.toml"),
        "[sky]\nmodel = \"uniform\"\nradiance = [1.0, 1.0, 1.0]\n",
    )
    .unwrap();
    let s = Scene::load(&scene_path, &LoadOptions::default()).unwrap();
    assert!(s.daylight.sky.is_some() && s.daylight.sun.is_none());
    // A file given explicitly wins.
    let other = dir.path().join("other.toml");
    std::fs::write(&other, SUN).unwrap();
    let opts = LoadOptions {
        daylight: Some(other.clone()),
        ..Default::default()
    };
    let s = Scene::load(&scene_path, &opts).unwrap();
    assert!(s.daylight.sun.is_some() && s.daylight.sky.is_none());
    // A bad or missing daylight file fails the load, naming the daylight file.
    std::fs::write(&other, "[sky]\nmodel = \"bogus\"\n").unwrap();
    let e = Scene::load(&scene_path, &opts).err().unwrap().to_string();
    assert!(e.contains("other.toml") && e.contains("bogus"), "{e}");
    let opts = LoadOptions {
        daylight: Some(dir.path().join("absent.toml")),
        ..Default::default()
    };
    let e = Scene::load(&scene_path, &opts).err().unwrap().to_string();
    assert!(e.contains("absent.toml"), "{e}");
}

#[test]
fn photometry_defaults_to_radiance_white_and_can_be_overridden() {
    assert_eq!(parse(SUN).unwrap().photometry.efficacy, 179.0);
    let d = parse(&format!("{SUN}[photometry]\nefficacy = 683.0\n")).unwrap();
    assert_eq!(d.photometry.efficacy, 683.0);
    for bad in ["0.0", "-1.0", "nan", "inf"] {
        parse_err(
            &format!("{SUN}[photometry]\nefficacy = {bad}\n"),
            &["photometry.efficacy", "positive"],
        );
    }
    parse_err(&format!("{SUN}[photometry]\nlumens = 3.0\n"), &["lumens"]);
}
