//! `holocave glare --annual`: a year's glare at one seat, from a weather file (the
//! `holocave_glare::annual` crate module does the work).

use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::Vec3;
use holocave_glare::annual::table::{Occupied, Summary, write_csv};
use holocave_glare::annual::{self, map::write_temporal_map};
use holocave_glare::{Fisheye, Rules};
use holocave_scene::daylight::{Weather, When};
use indicatif::{ProgressBar, ProgressStyle};

use super::daylight_flags::DaylightFlags;
use super::render::load_scene;

#[derive(Args, Clone, Debug)]
pub struct AnnualFlags {
    /// A year's glare: every daylit hour of --weather's file (Ev, DGP, the sources' count)
    /// into --out (a CSV), its temporal map beside it (PNG), and the year's summary.
    #[arg(long, requires = "weather", conflicts_with_all = ["when", "vlf", "hdr"])]
    pub annual: bool,
    /// With --annual: the year the weather file's hours are dated in (the sun's position).
    #[arg(long, default_value_t = 2026, requires = "annual")]
    pub year: i32,
    /// With --annual: the occupied hours, START-END in local standard time.
    #[arg(long, default_value = "8-18", value_parser = parse_occupied, requires = "annual")]
    pub occupied: Occupied,
    /// With --annual: glare autonomy counts the occupied hours with DGP below this.
    #[arg(long, default_value_t = 0.40, requires = "annual")]
    pub glare_limit: f64,
}

fn parse_occupied(s: &str) -> Result<Occupied, String> {
    let bad = || format!("{s:?}: give START-END, whole hours from 0 to 24 (for example 8-18)");
    let (a, b) = s.split_once('-').ok_or_else(bad)?;
    let (start, end) = (a.trim().parse::<u32>(), b.trim().parse::<u32>());
    match (start, end) {
        (Ok(start), Ok(end)) if start < end && end <= 24 => Ok(Occupied { start, end }),
        _ => Err(bad()),
    }
}

/// What an annual run measures, from `glare`'s flags.
pub struct AnnualRun<'a> {
    pub scene: &'a Path,
    pub daylight: &'a DaylightFlags,
    /// Eye, look and up.
    pub view: [Vec3; 3],
    pub size: Option<u32>,
    pub spp: Option<u32>,
    pub seed: u64,
    pub out: &'a Path,
    pub json: bool,
}

pub fn run(a: &AnnualRun, f: &AnnualFlags, rules: &Rules) -> Result<()> {
    if !(f.glare_limit > 0.0 && f.glare_limit <= 1.0) {
        bail!("--glare-limit {}: give a DGP in (0, 1]", f.glare_limit);
    }
    if a.out.extension().and_then(|e| e.to_str()) != Some("csv") {
        bail!(
            "--out {}: with --annual give a .csv file (the temporal map is written beside it)",
            a.out.display()
        );
    }
    let (size, spp) = (a.size.unwrap_or(256), a.spp.unwrap_or(16));
    let [eye, look, up] = a.view;
    let fisheye = Fisheye::new(size, eye, look, up).context("--eye, --look and --up")?;
    let epw = a
        .daylight
        .weather
        .as_deref()
        .context("--annual needs --weather")?;
    let weather = Arc::new(Weather::load(epw)?);
    let hours = annual::hours_of(&weather, f.year).map_err(anyhow::Error::msg)?;
    // The scene's geometry and photometry; each hour's light comes from `light_of_hours`.
    let mut flags = a.daylight.clone();
    flags.when = hours.first().map(|h| When::Local(h.when));
    let scene = load_scene(a.scene, flags, false)?;
    let photometry = scene.daylight.photometry;
    let nothing = format!(
        "nothing written ({} is written once every hour is measured)",
        a.out.display()
    );
    let start = std::time::Instant::now();
    let (rows, sun_patches, [lighting, traced]) =
        super::interrupt::ending_at_once(nothing, || {
            let file = (a.daylight.daylight.as_deref(), scene.daylight.site.as_ref());
            let lit = annual::light_of_hours(a.scene, file, &weather, &hours)?;
            let lighting = start.elapsed().as_secs_f64();
            eprintln!(
                "tracing the {size}x{size} fisheye's daylight coefficients at {spp} paths a pixel"
            );
            let coefficients = annual::trace_view(&scene, &fisheye, &lit, spp, a.seed);
            let traced = start.elapsed().as_secs_f64() - lighting;
            let daylit = lit.iter().filter(|h| h.daylit()).count();
            let bar = ProgressBar::new(daylit as u64).with_style(
                ProgressStyle::with_template("{bar:40} {pos}/{len} daylit hours, {eta} left")
                    .expect("a fixed template"),
            );
            let rows = annual::rows(&scene, &coefficients, &lit, (rules, &photometry), &|_| {
                bar.inc(1)
            })?;
            bar.finish_and_clear();
            anyhow::Ok((
                rows,
                coefficients.columns.sun_patches.len(),
                [lighting, traced],
            ))
        })?;
    let secs = start.elapsed().as_secs_f64();
    write_csv(a.out, &rows)?;
    let png = a.out.with_extension("png");
    write_temporal_map(&png, &rows)?;
    let summary = Summary::of(&rows, &hours, f.occupied, f.glare_limit);
    if a.json {
        println!("{}", summary.to_json());
        return Ok(());
    }
    println!(
        "wrote {} and {} ({} daylit hours of {} at a {size}x{size} fisheye, {sun_patches} sun \
         patches; {lighting:.1} s for the hours' light, {traced:.1} s tracing, {secs:.1} s in all)",
        a.out.display(),
        png.display(),
        rows.len(),
        epw.display(),
    );
    print!("{}", summary.report(f.occupied));
    Ok(())
}
