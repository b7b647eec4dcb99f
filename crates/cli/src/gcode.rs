//! `s2g gcode check|stats|motions FILE`: parse a G-code program and report on it.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use serde_json::json;
use shape2gcode::gcode::{
    ArcDirection, Marker, Motion, MotionSink, ParseDialect, ParseOptions, ParseSummary, Stats, StatsOptions,
    parse_file,
};
use shape2gcode::geom::Point3;

/// Arguments of `s2g gcode`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: Sub,
}

#[derive(Debug, clap::Subcommand)]
enum Sub {
    /// Print every error as `file:line:col: message`; exit code 1 if there is any.
    Check {
        /// The G-code program.
        file: PathBuf,
        #[command(flatten)]
        common: Common,
        /// Also print warnings (accepted deviations from strict LinuxCNC).
        #[arg(long)]
        warnings: bool,
    },
    /// Motion counts, bounding box, feed and rapid length, estimated time, layers, tools.
    Stats {
        /// The G-code program.
        file: PathBuf,
        #[command(flatten)]
        common: Common,
        /// Rapid traverse rate for the time estimate, mm/min.
        #[arg(long, default_value_t = 5000.0)]
        rapid: f64,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// One JSON object per motion and line: {"line":N,"kind":"rapid"|"feed"|"arc","to":[x,y,z],...}, in mm.
    Motions {
        /// The G-code program.
        file: PathBuf,
        #[command(flatten)]
        common: Common,
    },
}

#[derive(Debug, clap::Args)]
struct Common {
    /// Dialect: auto (lenient CNC, FDM when FDM codes appear), cnc (strict LinuxCNC) or fdm.
    #[arg(long, default_value = "auto", value_parser = ["auto", "cnc", "fdm"])]
    dialect: String,
}

impl Common {
    fn options(&self) -> ParseOptions {
        let dialect = match self.dialect.as_str() {
            "cnc" => ParseDialect::Cnc,
            "fdm" => ParseDialect::Fdm,
            _ => ParseDialect::Auto,
        };
        ParseOptions { dialect, ..ParseOptions::default() }
    }
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    match args.command {
        Sub::Check { file, common, warnings } => check(&file, &common, warnings),
        Sub::Stats { file, common, rapid, json } => stats(&file, &common, rapid, json),
        Sub::Motions { file, common } => motions(&file, &common),
    }
}

fn parse_into<S: MotionSink>(file: &Path, opts: &ParseOptions, sink: &mut S) -> anyhow::Result<ParseSummary>
where
    S::Error: std::fmt::Display,
{
    parse_file(file, opts, sink).map_err(|e| match e.into_sink() {
        Ok(e) => anyhow::anyhow!("{}: {e}", file.display()),
        Err(other) => anyhow::Error::new(other),
    })
}

fn check(file: &Path, common: &Common, warnings: bool) -> anyhow::Result<ExitCode> {
    let mut sink = Stats::default();
    let s = parse_into(file, &common.options(), &mut sink)?;
    let stdout = std::io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    for e in &s.errors {
        writeln!(out, "{e}")?;
    }
    if warnings {
        for w in &s.warnings {
            writeln!(out, "{w} (warning)")?;
        }
    }
    if s.dropped > 0 {
        writeln!(out, "{}: {} more errors or warnings not shown", file.display(), s.dropped)?;
    }
    out.flush()?;
    Ok(if s.errors.is_empty() { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

fn stats(file: &Path, common: &Common, rapid: f64, as_json: bool) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(rapid > 0.0 && rapid.is_finite(), "--rapid must be a positive number of mm/min");
    let mut st = Stats::new(StatsOptions { rapid_mm_per_min: rapid, ..StatsOptions::default() });
    let s = parse_into(file, &common.options(), &mut st).context("cannot parse the program")?;
    let bbox = st.bbox.map(|(lo, hi)| json!({"min": [lo.x, lo.y, lo.z], "max": [hi.x, hi.y, hi.z]}));
    let v = json!({
        "file": file.display().to_string(),
        "lines": s.lines,
        "bytes": s.bytes,
        "errors": s.errors.len(),
        "warnings": s.warnings.len(),
        "motions": s.motions,
        "rapids": st.rapids,
        "linears": st.linears,
        "arcs": st.arcs,
        "tool_changes": st.tool_changes,
        "tools": st.tools.iter().collect::<Vec<_>>(),
        "dwells": st.dwells,
        "comments": st.comments,
        "layers": st.layers,
        "bbox_mm": bbox,
        "feed_length_mm": st.feed_length_mm,
        "rapid_length_mm": st.rapid_length_mm,
        "untimed_feed_length_mm": st.untimed_length_mm,
        "extruded_mm": st.extruded_mm,
        "estimated_time_s": st.time_s,
        "rapid_mm_per_min": rapid,
    });
    if as_json {
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!("file:            {}", file.display());
        println!("lines:           {} ({} errors, {} warnings)", s.lines, s.errors.len(), s.warnings.len());
        println!("moves:           {} rapid, {} feed, {} arc", st.rapids, st.linears, st.arcs);
        println!("tools:           {:?} ({} changes)", st.tools, st.tool_changes);
        println!("layers:          {}", st.layers);
        if let Some((lo, hi)) = st.bbox {
            println!(
                "bounding box:    [{:.3}, {:.3}, {:.3}] .. [{:.3}, {:.3}, {:.3}] mm",
                lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
            );
        }
        println!("feed length:     {:.3} mm", st.feed_length_mm);
        println!("rapid length:    {:.3} mm", st.rapid_length_mm);
        if st.extruded_mm != 0.0 {
            println!("extruded:        {:.3} mm of filament", st.extruded_mm);
        }
        println!("estimated time:  {:.1} s (rapids at {rapid} mm/min)", st.time_s);
    }
    Ok(ExitCode::SUCCESS)
}

/// Writes one JSON line per motion.
struct JsonLines<W: Write> {
    out: W,
    line: u64,
}

impl<W: Write> MotionSink for JsonLines<W> {
    type Error = std::io::Error;

    fn source_line(&mut self, line: u64) -> Result<(), Self::Error> {
        self.line = line;
        Ok(())
    }

    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Self::Error> {
        let p = |q: &Point3| [q.x, q.y, q.z];
        let v = match m {
            Motion::Rapid { to } => json!({"line": self.line, "kind": "rapid", "to": p(to)}),
            Motion::Linear { to, feed, extrude } => {
                let mut v = json!({"line": self.line, "kind": "feed", "to": p(to), "feed": feed});
                if let Some(e) = extrude {
                    v["extrude"] = json!(e);
                }
                v
            }
            Motion::Arc { to, center, plane, direction, turns, feed, extrude } => {
                let mut v = json!({
                    "line": self.line,
                    "kind": "arc",
                    "to": p(to),
                    "center": p(center),
                    "direction": if *direction == ArcDirection::Clockwise { "cw" } else { "ccw" },
                    "plane": format!("{plane:?}").to_lowercase(),
                    "turns": turns,
                    "feed": feed,
                });
                if let Some(e) = extrude {
                    v["extrude"] = json!(e);
                }
                v
            }
            Motion::ToolChange { tool } => json!({"line": self.line, "kind": "tool", "tool": tool}),
            Motion::Spindle { rpm, direction } => {
                json!({"line": self.line, "kind": "spindle", "rpm": rpm, "direction": format!("{direction:?}").to_lowercase()})
            }
            Motion::Coolant(c) => {
                json!({"line": self.line, "kind": "coolant", "state": format!("{c:?}").to_lowercase()})
            }
            Motion::Dwell { seconds } => json!({"line": self.line, "kind": "dwell", "seconds": seconds}),
            Motion::Comment(c) => json!({"line": self.line, "kind": "comment", "text": c}),
            Motion::Marker(Marker::Layer { index, z }) => {
                json!({"line": self.line, "kind": "layer", "index": index, "z": z})
            }
            Motion::Marker(Marker::Type(t)) => json!({"line": self.line, "kind": "type", "type": t}),
            Motion::End => json!({"line": self.line, "kind": "end"}),
            other => json!({"line": self.line, "kind": "other", "debug": format!("{other:?}")}),
        };
        serde_json::to_writer(&mut self.out, &v)?;
        self.out.write_all(b"\n")
    }
}

fn motions(file: &Path, common: &Common) -> anyhow::Result<ExitCode> {
    let stdout = std::io::stdout();
    let mut sink = JsonLines { out: BufWriter::new(stdout.lock()), line: 0 };
    let s = parse_into(file, &common.options(), &mut sink)?;
    sink.out.flush()?;
    for e in &s.errors {
        eprintln!("{e}");
    }
    Ok(if s.errors.is_empty() { ExitCode::SUCCESS } else { ExitCode::from(1) })
}
