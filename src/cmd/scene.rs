//! `holocave scene`: inspect a scene, or (re)generate the project's own scenes.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Subcommand;
use holocave_scene::generate;

use super::render::load_scene;

#[derive(Subcommand)]
pub enum SceneCommand {
    /// Triangles, materials by kind, emitters, lights, bounds, BVH build time.
    Info {
        scene: PathBuf,
        #[command(flatten)]
        daylight: super::daylight_flags::DaylightFlags,
        #[arg(long)]
        strict: bool,
    },
    /// Write the project's generated scenes (Cornell box, room) into a directory.
    Generate {
        #[arg(long, default_value = "scenes")]
        out: PathBuf,
    },
}

pub fn run(cmd: SceneCommand) -> Result<()> {
    match cmd {
        SceneCommand::Info {
            scene: path,
            daylight,
            strict,
        } => {
            let scene = load_scene(&path, daylight, strict)?;
            let (lo, hi) = scene.bounds();
            println!("{}", path.display());
            println!("  triangles     {}", scene.triangle_count());
            for o in scene.objects() {
                println!(
                    "  object        {:?}: {} triangles, moving (never in the caches)",
                    o.name,
                    o.triangle_count()
                );
            }
            let mut kinds = BTreeMap::new();
            for m in &scene.materials {
                *kinds
                    .entry(format!("{:?}", m.kind()).to_lowercase())
                    .or_insert(0) += 1;
            }
            println!("  materials     {} ({kinds:?})", scene.materials.len());
            let emissive = (0..scene.triangle_count() as u32)
                .filter(|&t| {
                    scene.materials[scene.triangle_shading(t).material as usize].is_emissive()
                })
                .count();
            println!(
                "  emitters      {emissive} emissive triangles, {} punctual lights",
                scene.lights.len()
            );
            println!(
                "  daylight      sun: {}, sky: {}",
                scene
                    .daylight
                    .sun
                    .as_ref()
                    .map_or("none".into(), |s| format!("towards {:.3}", s.direction)),
                scene
                    .daylight
                    .sky
                    .as_ref()
                    .map_or("none".into(), |s| sky_name(&s.model).to_owned())
            );
            println!("  textures      {}", scene.textures.len());
            let cams: Vec<_> = scene.cameras.iter().map(|c| c.name.as_str()).collect();
            println!("  cameras       {cams:?}");
            println!("  bounds        {lo:.3} .. {hi:.3}");
            println!(
                "  bvh build     {:.1} ms",
                scene.bvh_build_time().as_secs_f64() * 1e3
            );
            println!("  warnings      {}", scene.warnings.len());
        }
        SceneCommand::Generate { out } => {
            std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
            for (name, text) in generate::all() {
                let p = out.join(name);
                std::fs::write(&p, text).with_context(|| format!("writing {}", p.display()))?;
                println!("wrote {}", p.display());
            }
            for (name, text) in generate::daylight_files() {
                let p = out.join(name);
                std::fs::write(&p, text).with_context(|| format!("writing {}", p.display()))?;
                println!("wrote {}", p.display());
            }
        }
    }
    Ok(())
}

/// The sky model's name, as the daylight file spells it.
fn sky_name(model: &holocave_scene::daylight::SkyModel) -> &'static str {
    use holocave_scene::daylight::SkyModel;
    match model {
        SkyModel::Uniform(_) => "uniform",
        SkyModel::CieOvercast { .. } => "cie_overcast",
        SkyModel::CieClear { .. } => "cie_clear",
        SkyModel::Map(_) => "map",
        SkyModel::Perez(_) => "perez",
    }
}
