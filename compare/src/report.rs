//! What a comparison measured, and its files: `error_time.csv` (a row per method and
//! measured frame), `views.csv` (every measured view, so another renderer can check it),
//! `summary.md` (a table per method) and `error_time.svg` (relative MSE, log scale,
//! against seconds and against frame number, one curve per method).

use std::fmt::Write as _;
use std::path::Path;
use std::time::Duration;

use holocave_cave::WallView;
use plotters::prelude::*;

/// One method's error at one measured frame.
#[derive(Clone, Debug)]
pub struct Row {
    pub method: &'static str,
    pub frame: u64,
    /// The method's own time so far (its frames only).
    pub seconds: f64,
    /// Rays traced for it so far.
    pub rays: u64,
    /// Relative MSE (mean of the eyes), `mean((x − ref)² / (ref² + 0.01))`.
    pub rel_mse: f64,
    /// Root mean squared error of the radiance (mean of the eyes).
    pub rmse: f64,
    /// This frame's time.
    pub frame_time: Duration,
    /// The head's speed at this frame (m/s).
    pub head_speed: f64,
}

/// Head speeds above this count as fast motion (m/s): a brisk step or a quick lean.
pub const FAST_HEAD: f64 = 0.3;

/// Writes the rows as CSV.
pub fn write_csv(path: &Path, rows: &[Row]) -> std::io::Result<()> {
    let mut s = String::from("method,frame,seconds,rays,rel_mse,rmse,frame_ms\n");
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{:.4},{},{:.6e},{:.6e},{:.3}",
            r.method,
            r.frame,
            r.seconds,
            r.rays,
            r.rel_mse,
            r.rmse,
            r.frame_time.as_secs_f64() * 1e3
        );
    }
    std::fs::write(path, s)
}

/// The columns of `views.csv`: one number per field, so any CSV reader (Python's `csv`,
/// pandas, a spreadsheet) reads each coordinate as a column of its own.
pub const VIEW_COLUMNS: [&str; 16] = [
    "frame", "eye", "eye_x", "eye_y", "eye_z", "pa_x", "pa_y", "pa_z", "pb_x", "pb_y", "pb_z",
    "pc_x", "pc_y", "pc_z", "width", "height",
];

/// Writes every measured view: frame, eye, eye position and wall corners (scene
/// coordinates, `pa` lower-left, `pb` lower-right, `pc` upper-left), image size; the
/// columns of [`VIEW_COLUMNS`]. Coordinates are written in Rust's shortest round-trip form,
/// so a reader parsing them as `f32` gets the values exactly.
pub fn write_views(path: &Path, views: &[(u64, usize, WallView)]) -> std::io::Result<()> {
    let mut s = VIEW_COLUMNS.join(",");
    s.push('\n');
    for (frame, eye, w) in views {
        let mut fields = vec![frame.to_string(), eye.to_string()];
        for v in [w.eye, w.pa, w.pb, w.pc] {
            fields.extend(v.to_array().map(|c| c.to_string()));
        }
        fields.extend([w.size.width.to_string(), w.size.height.to_string()]);
        let _ = writeln!(s, "{}", fields.join(","));
    }
    std::fs::write(path, s)
}

/// The `q` quantile (0..1) of `v` ([`holocave_protocol::stats::quantile`]; 0 for none).
fn quantile(v: &[f64], q: f64) -> f64 {
    holocave_protocol::stats::quantile(v, q).unwrap_or(0.0)
}

/// One method's line of the summary.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    pub method: &'static str,
    /// Relative MSE averaged over the method's time (each measured frame weighted by the
    /// time until the next one).
    pub time_averaged: f64,
    pub at_end: f64,
    /// The 95th percentile of the relative MSE over frames with fast head motion (`None`
    /// when the head never moved fast).
    pub fast_p95: Option<f64>,
    pub frame_p50: Duration,
    pub frame_p99: Duration,
    pub seconds: f64,
    pub rays: u64,
}

/// Each method's summary, in the order the rows first name them; `frame_times` holds
/// every frame's time per method (not only the measured ones).
pub fn summarize(rows: &[Row], frame_times: &[(&'static str, Vec<Duration>)]) -> Vec<Summary> {
    let mut out = Vec::new();
    for (method, times) in frame_times {
        let mine: Vec<&Row> = rows.iter().filter(|r| r.method == *method).collect();
        let Some(last) = mine.last() else { continue };
        // Each error holds from its frame until the next measured one.
        let mut weighted = 0.0;
        let mut total = 0.0;
        let mut prev = 0.0;
        for r in &mine {
            let dt = (r.seconds - prev).max(1e-9);
            weighted += r.rel_mse * dt;
            total += dt;
            prev = r.seconds;
        }
        let fast: Vec<f64> = mine
            .iter()
            .filter(|r| r.head_speed > FAST_HEAD)
            .map(|r| r.rel_mse)
            .collect();
        let secs: Vec<f64> = times.iter().map(Duration::as_secs_f64).collect();
        out.push(Summary {
            method,
            time_averaged: weighted / total,
            at_end: last.rel_mse,
            fast_p95: (!fast.is_empty()).then(|| quantile(&fast, 0.95)),
            frame_p50: Duration::from_secs_f64(quantile(&secs, 0.5)),
            frame_p99: Duration::from_secs_f64(quantile(&secs, 0.99)),
            seconds: last.seconds,
            rays: last.rays,
        });
    }
    out
}

/// The summary as a Markdown table, with the references' own noise.
pub fn summary_markdown(summaries: &[Summary], reference_noise: f64, heading: &str) -> String {
    let mut s = format!(
        "# {heading}\n\nReferences' own relative MSE (two seeds): {reference_noise:.2e}; an \
         error near it is no measurable difference.\n\n| method | time-averaged rel. MSE | \
         at the end | p95 in fast motion | frame p50 | frame p99 | seconds | rays |\n|---|---|---|---|---|---|---|---|\n"
    );
    for m in summaries {
        let _ = writeln!(
            s,
            "| {} | {:.3e} | {:.3e} | {} | {:.1} ms | {:.1} ms | {:.1} | {} |",
            m.method,
            m.time_averaged,
            m.at_end,
            m.fast_p95
                .map_or("no fast motion".to_owned(), |v| format!("{v:.3e}")),
            m.frame_p50.as_secs_f64() * 1e3,
            m.frame_p99.as_secs_f64() * 1e3,
            m.seconds,
            m.rays
        );
    }
    s
}

/// A line per method that left some of its budget unspent (frames with nothing left to
/// trace), for the summary; empty when none did.
pub fn unspent_markdown(frame_rays: &[(&'static str, Vec<(u64, u64)>)]) -> String {
    let mut s = String::new();
    for (method, frames) in frame_rays {
        let short = frames.iter().filter(|f| f.1 > 0).count();
        let unspent: u64 = frames.iter().map(|f| f.1).sum();
        if short > 0 {
            let _ = writeln!(
                s,
                "\n{method}: {short} of {} frames had less to trace than the budget \
                 ({unspent} rays of it unspent).",
                frames.len()
            );
        }
    }
    s
}

/// The plot: relative MSE (log scale) against each method's seconds, and against frame.
pub fn plot(path: &Path, rows: &[Row], methods: &[&'static str]) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let root = SVGBackend::new(path, (1000, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let (left, right) = root.split_horizontally(500);
    let (lo, hi) = rows
        .iter()
        .map(|r| r.rel_mse.max(1e-6))
        .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    let (lo, hi) = if lo.is_finite() {
        (lo / 2.0, hi * 2.0)
    } else {
        (1e-4, 1.0)
    };
    let max_s = rows.iter().map(|r| r.seconds).fold(1e-3, f64::max);
    let max_f = rows.iter().map(|r| r.frame as f64).fold(1.0, f64::max);
    for (area, by_frame) in [(left, false), (right, true)] {
        let x_max = if by_frame { max_f } else { max_s };
        let mut chart = ChartBuilder::on(&area)
            .caption(
                if by_frame {
                    "relative MSE against frame"
                } else {
                    "relative MSE against seconds"
                },
                ("sans-serif", 18),
            )
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..x_max, (lo..hi).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc(if by_frame { "frame" } else { "seconds" })
            .y_desc("relative MSE")
            .draw()
            .map_err(|e| err(&e))?;
        for (i, m) in methods.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let points = rows.iter().filter(|r| r.method == *m).map(|r| {
                let x = if by_frame { r.frame as f64 } else { r.seconds };
                (x, r.rel_mse.max(1e-6))
            });
            chart
                .draw_series(LineSeries::new(points, color.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(*m)
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], color));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use holocave_cave::Size;

    fn row(method: &'static str, frame: u64, seconds: f64, rel_mse: f64, speed: f64) -> Row {
        Row {
            method,
            frame,
            seconds,
            rays: frame * 10,
            rel_mse,
            rmse: rel_mse.sqrt(),
            frame_time: Duration::from_millis(10),
            head_speed: speed,
        }
    }

    #[test]
    fn the_time_average_weights_each_error_by_how_long_it_held() {
        // 0.4 for the first second, 0.1 for the next three: (0.4 + 0.3) / 4.
        let rows = [row("a", 0, 1.0, 0.4, 0.0), row("a", 30, 4.0, 0.1, 1.0)];
        let times = [("a", vec![Duration::from_millis(10); 4])];
        let s = &summarize(&rows, &times)[0];
        assert!(
            (s.time_averaged - 0.175).abs() < 1e-12,
            "{}",
            s.time_averaged
        );
        assert_eq!(s.at_end, 0.1);
        assert_eq!(s.fast_p95, Some(0.1));
        assert_eq!(s.rays, 300);
    }

    #[test]
    fn views_csv_reads_back_as_written_with_a_csv_parser() {
        // Negative, fractional and long coordinates: each must come back in its own column.
        let views = [
            (
                0u64,
                0usize,
                WallView {
                    eye: glam::Vec3::new(-0.032, 1.45, 0.1),
                    pa: glam::Vec3::new(-1.5, -1.0, 0.2),
                    pb: glam::Vec3::new(1.5, -1.0, 0.2),
                    pc: glam::Vec3::new(-1.5, 2.0, 0.2),
                    size: Size::new(256, 192),
                },
            ),
            (
                15,
                1,
                WallView {
                    eye: glam::Vec3::new(0.1 / 3.0, 1e-7, -3.4e5),
                    pa: glam::Vec3::new(-1.5, 0.0, -1.5),
                    pb: glam::Vec3::new(1.5, 0.0, -1.5),
                    pc: glam::Vec3::new(-1.5, 3.0, -1.5),
                    size: Size::new(1024, 768),
                },
            ),
        ];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("views.csv");
        write_views(&path, &views).unwrap();
        let mut reader = csv::Reader::from_path(&path).unwrap();
        let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
        assert_eq!(header, VIEW_COLUMNS);
        let records: Vec<csv::StringRecord> = reader.records().map(Result::unwrap).collect();
        assert_eq!(records.len(), views.len());
        for (r, (frame, eye, w)) in records.iter().zip(&views) {
            assert_eq!(r.len(), VIEW_COLUMNS.len(), "{r:?}");
            let field = |name: &str| &r[VIEW_COLUMNS.iter().position(|c| *c == name).unwrap()];
            let f32_of = |name: &str| field(name).parse::<f32>().unwrap();
            let v3 = |p: &str| {
                glam::Vec3::new(
                    f32_of(&format!("{p}_x")),
                    f32_of(&format!("{p}_y")),
                    f32_of(&format!("{p}_z")),
                )
            };
            assert_eq!(field("frame").parse::<u64>().unwrap(), *frame);
            assert_eq!(field("eye").parse::<usize>().unwrap(), *eye);
            assert_eq!(v3("eye"), w.eye);
            assert_eq!(v3("pa"), w.pa);
            assert_eq!(v3("pb"), w.pb);
            assert_eq!(v3("pc"), w.pc);
            assert_eq!(field("width").parse::<u32>().unwrap(), w.size.width);
            assert_eq!(field("height").parse::<u32>().unwrap(), w.size.height);
        }
    }

    #[test]
    fn files_are_written() {
        let dir = tempfile::tempdir().unwrap();
        let rows = [
            row("trace", 0, 0.5, 0.9, 0.0),
            row("trace", 30, 1.0, 0.8, 0.5),
            row("cache", 0, 0.2, 0.9, 0.0),
            row("cache", 30, 0.4, 0.05, 0.5),
        ];
        write_csv(&dir.path().join("e.csv"), &rows).unwrap();
        let csv = std::fs::read_to_string(dir.path().join("e.csv")).unwrap();
        assert_eq!(csv.lines().count(), 5);
        assert!(
            csv.lines()
                .nth(4)
                .unwrap()
                .starts_with("cache,30,0.4000,300,5.0")
        );
        plot(&dir.path().join("p.svg"), &rows, &["trace", "cache"]).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("p.svg")).unwrap();
        assert!(svg.contains("<svg") && svg.contains("trace") && svg.contains("cache"));
    }
}
