//! A year's glare: an hour's row from the daylight coefficients against the same hour
//! drawn alone, path-traced, as `holocave glare --when` draws it; the summary's counts; a
//! weather file's row that the year asked for does not have.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use chrono::NaiveDate;
use glam::Vec3;
use holocave_glare::annual::table::{Occupied, Summary};
use holocave_glare::annual::{self, HourOfYear, Row};
use holocave_glare::draw::Drawing;
use holocave_glare::figures::Figures;
use holocave_glare::{Fisheye, LuminanceMap, Rules, evaluate};
use holocave_scene::daylight::{Moment, Weather, When};
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::{TraceSettings, Tracer};

/// The generated room (its window in the wall x = −2.5) turned so that the window faces
/// azimuth 240° (north along (0.5, 0, −0.866)) in Chicago: a December afternoon's low
/// sun shines in through it, and into the eye.
const DAYLIGHT: &str = "[site]\nlatitude = 41.98\nlongitude = -87.92\nelevation = 201.0\n\
                        time_zone = -6.0\nnorth = [0.5, 0.0, -0.8660254]\n";

fn weather(rows: &[(u32, u32, u32, f64, f64)]) -> Arc<Weather> {
    let mut s = String::from("LOCATION,Here,,,,0,41.98,-87.92,-6.0,201.0\n");
    s += &"HEADER,x\n".repeat(6);
    s += "DATA PERIODS,1,1,Data,Sunday, 1/ 1,12/31\n";
    for (m, d, h, dni, dhi) in rows {
        s += &format!("1999,{m},{d},{h},0,f,20,10,50,99000,1300,1360,350,800,{dni},{dhi}\n");
    }
    Arc::new(Weather::parse(&s, Path::new("test.epw")).unwrap())
}

fn room(dir: &Path) -> (PathBuf, PathBuf) {
    let scene = dir.join("room.gltf");
    let (_, gltf) = (holocave_scene::generate::all().into_iter())
        .find(|(name, _)| *name == "room.gltf")
        .unwrap();
    std::fs::write(&scene, with_point_light(&gltf)).unwrap();
    let daylight = dir.join("room.daylight.toml");
    std::fs::write(&daylight, DAYLIGHT).unwrap();
    (scene, daylight)
}

/// The room with a point light of intensity 50 (scene units) 2.5 m above the floor's
/// middle: about 1,000 lx of the eye's Ev, which a row without the lamps would lack.
fn with_point_light(gltf: &str) -> String {
    let mut doc: serde_json::Value = serde_json::from_str(gltf).unwrap();
    doc["extensionsUsed"] = serde_json::json!(["KHR_lights_punctual"]);
    doc["extensions"] = serde_json::json!({ "KHR_lights_punctual": { "lights": [
        { "type": "point", "color": [1.0, 1.0, 1.0], "intensity": 50.0 }
    ] } });
    let nodes = doc["nodes"].as_array_mut().unwrap();
    nodes.push(
        serde_json::json!({ "name": "bulb", "translation": [0.0, 2.5, 0.0],
        "extensions": { "KHR_lights_punctual": { "light": 0 } } }),
    );
    let bulb = nodes.len() - 1;
    doc["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(bulb.into());
    doc.to_string()
}

fn load_at(scene: &Path, daylight: &Path, weather: &Arc<Weather>, h: &HourOfYear) -> Scene {
    let opts = LoadOptions {
        daylight: Some(daylight.into()),
        moment: Some(Moment {
            when: When::Local(h.when),
            weather: Some(weather.clone()),
        }),
        ..LoadOptions::default()
    };
    Scene::load(scene, &opts).unwrap()
}

/// The hour drawn alone, path-traced at `spp` paths a pixel.
fn drawn_alone(scene: Scene, fisheye: &Fisheye, spp: u32) -> Figures {
    let photometry = scene.daylight.photometry;
    let drawing = Drawing::PathTraced {
        tracer: Box::new(Tracer::new(Arc::new(scene), TraceSettings::default())),
        spp,
        seed: 7,
    };
    let image = drawing.draw(fisheye);
    let map = LuminanceMap::from_radiance(fisheye.clone(), &image, &photometry).unwrap();
    evaluate(&map, &Rules::default()).unwrap()
}

/// Each daylit hour's row (the coefficients at 64 paths a pixel, the sky in 145 patches,
/// the sun after the first bounce at its patch's centre) against the hour drawn alone at
/// 256 paths a pixel: Ev within 5 % and DGP within 0.03, the goal the annual figures are
/// held to. The hours include the sun in view through the window (a source of 10⁶ cd/m²
/// and more), an overcast hour (no sun), and the lamps' constant light: the ceiling's
/// emitting square and a point light.
#[test]
fn an_hours_row_is_the_glare_of_that_hour_drawn_alone() {
    let dir = tempfile::tempdir().unwrap();
    let (scene_path, daylight) = room(dir.path());
    let w = weather(&[
        (12, 21, 11, 450.0, 90.0),
        (12, 21, 14, 0.0, 140.0),
        (12, 21, 15, 400.0, 80.0),
        (12, 21, 16, 300.0, 60.0),
        (12, 21, 18, 0.0, 0.0),
    ]);
    let hours = annual::hours_of(&w, 2026).unwrap();
    let first = load_at(&scene_path, &daylight, &w, &hours[0]);
    let site = first.daylight.site.clone();
    let lit =
        annual::light_of_hours(&scene_path, (Some(&daylight), site.as_ref()), &w, &hours).unwrap();
    assert_eq!(
        lit.iter().filter(|h| h.daylit()).count(),
        4,
        "18:00 is night"
    );
    let fisheye = Fisheye::new(48, Vec3::new(0.0, 1.5, 0.0), Vec3::NEG_X, Vec3::Y).unwrap();
    let coefficients = annual::trace_view(&first, &fisheye, &lit, 64, 1);
    let photometry = first.daylight.photometry;
    let rows = annual::rows(
        &first,
        &coefficients,
        &lit,
        (&Rules::default(), &photometry),
        &|_| {},
    )
    .unwrap();
    let mut sun_seen = false;
    for (row, h) in rows.iter().zip(lit.iter().filter(|h| h.daylit())) {
        let alone = drawn_alone(load_at(&scene_path, &daylight, &w, &h.hour), &fisheye, 256);
        let (a, b) = (&row.figures, &alone);
        eprintln!(
            "{}: Ev {:.1} / {:.1} lx, DGP {:.4} / {:.4}, sources {} / {}",
            h.hour.when,
            a.ev_lux,
            b.ev_lux,
            a.dgp,
            b.dgp,
            a.sources.len(),
            b.sources.len()
        );
        assert!(
            (a.ev_lux - b.ev_lux).abs() <= 0.05 * b.ev_lux,
            "{}: Ev {} against {} drawn alone",
            h.hour.when,
            a.ev_lux,
            b.ev_lux
        );
        assert!(
            (a.dgp - b.dgp).abs() <= 0.03,
            "{}: DGP {} against {} drawn alone",
            h.hour.when,
            a.dgp,
            b.dgp
        );
        sun_seen |= b.sources.iter().any(|s| s.luminance_cd_m2 > 1e6);
    }
    assert!(sun_seen, "no hour saw the sun through the window");
}

fn row(month: u32, day: u32, hour: u32, dgp: f64) -> Row {
    Row {
        hour: stamp(month, day, hour),
        altitude_deg: 10.0,
        dni: 0.0,
        dhi: 0.0,
        figures: Figures {
            ev_lux: 1000.0,
            dgp,
            ugr: None,
            background_cd_m2: 0.0,
            average_cd_m2: 0.0,
            threshold_cd_m2: 2000.0,
            sources: Vec::new(),
        },
    }
}

fn stamp(month: u32, day: u32, hour: u32) -> HourOfYear {
    HourOfYear {
        month,
        day,
        hour,
        when: NaiveDate::from_ymd_opt(2026, month, day)
            .unwrap()
            .and_hms_opt(hour - 1, 30, 0)
            .unwrap(),
    }
}

/// Two days of 24 hours, occupied 8–18: 20 occupied hours. Daylit rows at 7:30 (not
/// occupied), 8:30, 12:30 and 17:30 (occupied), 18:30 (not); their DGPs fall in each
/// class. An occupied hour at night counts as free of glare.
#[test]
fn the_summary_counts_occupied_hours_by_class_and_glare_autonomy() {
    let all: Vec<HourOfYear> = (1..=2)
        .flat_map(|d| (1..=24).map(move |h| stamp(1, d, h)))
        .collect();
    let rows = vec![
        row(1, 1, 8, 0.9),
        row(1, 1, 9, 0.36),
        row(1, 1, 13, 0.41),
        row(1, 1, 18, 0.46),
        row(1, 1, 19, 0.9),
        row(1, 2, 13, 0.30),
    ];
    let s = Summary::of(&rows, &all, Occupied::default(), 0.40);
    assert_eq!(s.occupied_hours, 20);
    assert_eq!(s.daylit_hours, 6);
    assert_eq!(s.above, [3, 2, 1]);
    assert!((s.glare_autonomy - 18.0 / 20.0).abs() < 1e-12, "{s:?}");
}

/// A leap day in a year without one is an error naming the file, the row and the year.
#[test]
fn a_row_the_year_does_not_have_is_an_error() {
    let w = weather(&[(2, 29, 12, 100.0, 50.0)]);
    let e = annual::hours_of(&w, 2026).unwrap_err();
    assert!(
        e.contains("test.epw") && e.contains("02-29") && e.contains("2026"),
        "{e}"
    );
    assert_eq!(annual::hours_of(&w, 2024).unwrap().len(), 1);
}
