//! `holocave tracking`: record a tracker source to CSV, evaluate and tune the predictors
//! on recorded traces.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use holocave_tracking::TrackingParams;
use holocave_tracking::csv_log::TimeUnit;
use holocave_tracking::eval::{self, CSV_HEADER};
use holocave_tracking::input_source::{open_input, open_wand};
use holocave_tracking::pose::Sample;
use holocave_tracking::record::{SessionSources, record, record_session};
use holocave_tracking::source::{Next, Pacing, SourceSpec, TrackerSource, open};
use holocave_tracking::vrpn_input::InputKind;

#[derive(Subcommand)]
pub enum TrackingCommand {
    /// Record a source to CSV (timestamp in ns, x, y, z, qx, qy, qz, qw); with --wand,
    /// --buttons or --axes, a session log of every device.
    Record(RecordArgs),
    /// Write a scripted session log: a user standing still, the wand held ahead, the
    /// joystick following --step SECONDS:FORWARD:TURN steps.
    Script(ScriptArgs),
    /// Evaluate prediction on recorded traces (resampled to 200 Hz).
    Eval(EvalArgs),
    /// Grid-search the predictors' smoothing time constants on recorded traces.
    Tune(TuneArgs),
}

#[derive(Args)]
pub struct RecordArgs {
    /// vrpn://DEVICE@HOST[:PORT][#SENSOR], file:PATH (CSV or .vrpn[#DEVICE[:SENSOR]]) or synthetic:NAME
    #[arg(long)]
    source: String,
    /// Output CSV file.
    #[arg(long)]
    out: PathBuf,
    /// Seconds to record (required for VRPN and synthetic sources).
    #[arg(long)]
    seconds: Option<f64>,
    /// Play recorded and synthetic sources in real time instead of as fast as possible.
    #[arg(long)]
    realtime: bool,
    /// Time unit of a CSV source: ns, us, ms, s or ticks (default: detected).
    #[arg(long)]
    time_unit: Option<TimeUnit>,
    /// Also record a wand: vrpn://Wand0@HOST#1, a session log (file:PATH) or synthetic:NAME.
    #[arg(long)]
    wand: Option<String>,
    /// Also record buttons: vrpn://Buttons0@HOST or file:PATH (a session log).
    #[arg(long)]
    buttons: Option<String>,
    /// Also record joystick axes: vrpn://Joystick0@HOST or file:PATH (a session log).
    #[arg(long)]
    axes: Option<String>,
}

#[derive(Args)]
pub struct ScriptArgs {
    /// Output session log (CSV).
    #[arg(long)]
    out: PathBuf,
    /// A step of the joystick: SECONDS:FORWARD:TURN (deflections in −1..1; turn +1: to the
    /// right); repeat for each step, in order.
    #[arg(long = "step", required = true)]
    steps: Vec<holocave_tracking::scripted::Step>,
    /// Head and wand rows per second.
    #[arg(long, default_value_t = 2.0)]
    pose_rate: f64,
}

#[derive(Args)]
pub struct LogArgs {
    /// A recorded trace (CSV, or .vrpn[#DEVICE[:SENSOR]]); repeat for several.
    #[arg(long = "log", required = true)]
    logs: Vec<String>,
    /// Look-ahead times, multiples of 5 ms: e.g. 20,40,60,80,100ms.
    #[arg(long, default_value = "20,40,60,80,100ms")]
    lookahead: String,
    /// Take filter and predictor parameters from this CAVE config's [tracking] section.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Time unit of CSV logs (default: detected).
    #[arg(long)]
    time_unit: Option<TimeUnit>,
}

#[derive(Args)]
pub struct EvalArgs {
    #[command(flatten)]
    logs: LogArgs,
    /// Print CSV instead of tables.
    #[arg(long)]
    csv: bool,
}

#[derive(Args)]
pub struct TuneArgs {
    #[command(flatten)]
    logs: LogArgs,
}

pub fn run(cmd: TrackingCommand) -> Result<()> {
    match cmd {
        TrackingCommand::Record(a) => run_record(a),
        TrackingCommand::Script(a) => run_script(a),
        TrackingCommand::Eval(a) => run_eval(a),
        TrackingCommand::Tune(a) => run_tune(a),
    }
}

fn run_record(a: RecordArgs) -> Result<()> {
    let spec: SourceSpec = a
        .source
        .parse()
        .map_err(anyhow::Error::msg)
        .context("--source")?;
    let pacing = if a.realtime {
        Pacing::RealTime
    } else {
        Pacing::AsFastAsPossible
    };
    let mut source = open(&spec, pacing, a.time_unit)?;
    if a.wand.is_some() || a.buttons.is_some() || a.axes.is_some() {
        return record_devices(&a, source.as_mut(), pacing);
    }
    let report = record(source.as_mut(), &a.out, a.seconds)?;
    println!(
        "{}: {} samples written; guard: {}",
        a.out.display(),
        report.written,
        report.guard
    );
    Ok(())
}

/// Records the head and the other devices into one session log.
fn record_devices(a: &RecordArgs, head: &mut dyn TrackerSource, pacing: Pacing) -> Result<()> {
    let mut wand = a
        .wand
        .as_deref()
        .map(|w| open_wand(w, pacing))
        .transpose()?;
    let mut buttons = (a.buttons.as_deref())
        .map(|b| open_input(b, InputKind::Buttons))
        .transpose()?;
    let mut axes = (a.axes.as_deref())
        .map(|x| open_input(x, InputKind::Analog))
        .transpose()?;
    let report = record_session(
        SessionSources {
            head,
            wand: wand.as_mut().map(|w| w.as_mut() as &mut dyn TrackerSource),
            buttons: buttons.as_mut(),
            axes: axes.as_mut(),
        },
        &a.out,
        a.seconds,
    )?;
    println!(
        "{}: session log of {} head samples (guard: {}), {} wand samples (guard: {}), {} button and axis events",
        a.out.display(),
        report.head.written,
        report.head.guard,
        report.wand.written,
        report.wand.guard,
        report.inputs
    );
    Ok(())
}

fn run_script(a: ScriptArgs) -> Result<()> {
    if !(a.pose_rate > 0.0 && a.pose_rate <= 1000.0) {
        bail!(
            "--pose-rate {}: expected 0 to 1000 rows a second",
            a.pose_rate
        );
    }
    let file =
        std::fs::File::create(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let rows = holocave_tracking::scripted::write_script(
        std::io::BufWriter::new(file),
        &a.steps,
        a.pose_rate,
    )
    .with_context(|| format!("writing {}", a.out.display()))?;
    let seconds: f64 = a.steps.iter().map(|s| s.seconds).sum();
    println!(
        "{}: scripted session of {seconds} s, {rows} rows",
        a.out.display()
    );
    Ok(())
}

/// Parses `20,40,60ms` (or `20ms,40ms`) into milliseconds, each a multiple of 5.
fn lookaheads(text: &str) -> Result<Vec<u32>> {
    let out = text
        .split(',')
        .map(|t| {
            let t = t.trim().trim_end_matches("ms");
            let v: u32 = t
                .parse()
                .with_context(|| format!("--lookahead: `{t}` is not a whole number of ms"))?;
            if v == 0 || !v.is_multiple_of(5) {
                bail!("--lookahead: {v} ms is not a positive multiple of the 5 ms resampling step");
            }
            Ok(v)
        })
        .collect::<Result<Vec<u32>>>()?;
    Ok(out)
}

/// Loads a trace as fast as possible, whatever its format.
fn load(log: &str, unit: Option<TimeUnit>) -> Result<Vec<Sample>> {
    let spec: SourceSpec = format!("file:{log}").parse().map_err(anyhow::Error::msg)?;
    let mut source = open(&spec, Pacing::AsFastAsPossible, unit)?;
    let mut out = Vec::new();
    let far = Instant::now() + Duration::from_secs(3600);
    while let Next::Sample(s, _) = source.next(far) {
        out.push(s);
    }
    if out.len() < 2 {
        bail!("{log}: fewer than two samples");
    }
    Ok(out)
}

fn params(config: &Option<PathBuf>) -> Result<TrackingParams> {
    Ok(match config {
        Some(path) => holocave_cave::load_cave(path)?.tracking,
        None => TrackingParams::default(),
    })
}

/// Each log cleaned and resampled, with a one-line summary.
fn prepare(a: &LogArgs) -> Result<Vec<(String, Vec<Sample>, String)>> {
    a.logs
        .iter()
        .map(|log| {
            let raw = load(log, a.time_unit)?;
            let (clean, report) = eval::clean(&raw);
            let span = (raw.last().map_or(0, |s| s.t_ns) - raw[0].t_ns) as f64 * 1e-9;
            let summary = format!(
                "{log}: {} samples over {span:.1} s; guard: {report}",
                raw.len()
            );
            Ok((log.clone(), eval::resample(&clean), summary))
        })
        .collect()
}

fn run_eval(a: EvalArgs) -> Result<()> {
    let las = lookaheads(&a.logs.lookahead)?;
    let params = params(&a.logs.config)?;
    if a.csv {
        println!("{CSV_HEADER}");
    }
    let mut all_fail = Vec::new();
    for (log, samples, summary) in prepare(&a.logs)? {
        let rows = eval::evaluate(&samples, &las, &params);
        let name = std::path::Path::new(&log)
            .file_name()
            .map_or(log.clone(), |n| n.to_string_lossy().into_owned());
        if a.csv {
            for r in &rows {
                println!("{}", eval::csv_line(&name, r));
            }
        } else {
            println!("{summary}\n{}", eval::table(&rows));
        }
        all_fail.extend(
            eval::failures(&rows)
                .into_iter()
                .map(|f| format!("{name}: {f}")),
        );
    }
    if all_fail.is_empty() {
        eprintln!("both predictors beat no prediction at every look-ahead, on position and angle");
    } else {
        eprintln!(
            "predictors that do not beat no prediction:\n  {}",
            all_fail.join("\n  ")
        );
    }
    Ok(())
}

fn run_tune(a: TuneArgs) -> Result<()> {
    let las = lookaheads(&a.logs.lookahead)?;
    let base = params(&a.logs.config)?;
    let traces: Vec<Vec<Sample>> = prepare(&a.logs)?.into_iter().map(|t| t.1).collect();
    let (best, grid) = eval::tune(&traces, &las, &base);
    println!("error relative to no prediction (mean absolute, averaged over logs and look-aheads)");
    println!("time constant   cv pos  cv ang  desp pos  desp ang");
    for (g, e) in grid {
        println!(
            "{g:>10} ms  {:>7.3} {:>7.3} {:>9.3} {:>9.3}",
            e[1].0, e[1].1, e[2].0, e[2].1
        );
    }
    let (cv, desp) = (best.prediction.constant_velocity, best.prediction.desp);
    println!("\n[tracking.prediction]");
    println!(
        "constant_velocity = {{ position_time_constant_ms = {:?}, orientation_time_constant_ms = {:?} }}",
        cv.position_time_constant_ms, cv.orientation_time_constant_ms
    );
    println!(
        "desp = {{ position_time_constant_ms = {:?}, orientation_time_constant_ms = {:?} }}",
        desp.position_time_constant_ms, desp.orientation_time_constant_ms
    );
    Ok(())
}
