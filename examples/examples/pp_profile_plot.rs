//! One profile-position move with a jerk-limited (S-curve) profile and a re-plan in mid-move,
//! written as an SVG plot of position, velocity and acceleration over time.
//!
//! `cargo run -p canopen-drive-examples --example pp_profile_plot -- [out.svg]`
//! (default `target/pp_profile.svg`).

use std::fmt::Write as _;

use canopen_drive::motion::{Limits, MotionState, PositionPlanner, ProfileType, TickRate};

const HZ: u32 = 4000;
const WIDTH: f64 = 900.0;
const PANEL: f64 = 200.0;
const MARGIN: f64 = 60.0;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).unwrap_or_else(|| "target/pp_profile.svg".into());
    let limits = Limits::new(40_000, 200_000, 300_000).with_jerk(ProfileType::JerkLimited, 4_000_000);
    let mut planner = PositionPlanner::new(TickRate::new(HZ)?, 0);
    let mut samples = vec![planner.state()];

    // First set-point: 60 000 increments forward.
    planner.plan(60_000, 0, &limits)?;
    for _ in 0..(HZ / 5) {
        samples.push(planner.step());
    }
    // Change set immediately: a nearer target, re-planned while accelerating at full rate.
    let replan_at = samples.len();
    let ticks = planner.plan(15_000, 0, &limits)?;
    for _ in 0..ticks + HZ / 10 {
        samples.push(planner.step());
    }
    let last = samples.last().copied().unwrap_or_default();
    assert_eq!(last.position, 15_000, "the move ends exactly on the target");
    // The re-plan at full acceleration near the velocity limit stays within every limit.
    let fastest = samples.iter().map(|s| s.velocity.unsigned_abs()).max().unwrap_or(0);
    let hardest = samples.iter().map(|s| s.acceleration.unsigned_abs()).max().unwrap_or(0);
    assert!(fastest <= u64::from(limits.velocity), "velocity {fastest} over the limit");
    assert!(
        hardest <= u64::from(limits.deceleration.max(limits.acceleration)),
        "acceleration {hardest} over the limit"
    );

    let svg = plot(&samples, replan_at)?;
    if let Some(parent) = std::path::Path::new(&path).parent() {
        std::fs::create_dir_all(parent)?;
    }
    std::fs::write(&path, svg)?;
    println!(
        "{} samples, re-planned at tick {replan_at}, peak velocity {fastest} (limit {}), written to {path}",
        samples.len(),
        limits.velocity
    );
    Ok(())
}

/// A plotted quantity: label, colour, and how to read it from a sample.
type Series = (&'static str, &'static str, fn(&MotionState) -> f64);

/// Three stacked panels, each scaled to its own range.
fn plot(samples: &[MotionState], replan_at: usize) -> Result<String, std::fmt::Error> {
    let height = 3.0 * (PANEL + MARGIN) + MARGIN;
    let mut svg = String::new();
    writeln!(
        svg,
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" font-family="sans-serif" font-size="12">"##
    )?;
    writeln!(svg, r##"<rect width="100%" height="100%" fill="white"/>"##)?;
    let series: [Series; 3] = [
        ("position [inc]", "#1f77b4", |s| s.position as f64),
        ("velocity [inc/s]", "#2ca02c", |s| s.velocity as f64),
        ("acceleration [inc/s²]", "#d62728", |s| s.acceleration as f64),
    ];
    let n = samples.len().max(2) as f64;
    let plot_width = WIDTH - 2.0 * MARGIN;
    for (index, (label, colour, value)) in series.iter().enumerate() {
        let top = MARGIN + index as f64 * (PANEL + MARGIN);
        let values: Vec<f64> = samples.iter().map(value).collect();
        let lo = values.iter().copied().fold(f64::INFINITY, f64::min).min(0.0);
        let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max).max(0.0);
        let span = if hi > lo { hi - lo } else { 1.0 };
        let y = |v: f64| top + PANEL - (v - lo) / span * PANEL;
        let x = |i: f64| MARGIN + i / (n - 1.0) * plot_width;
        writeln!(
            svg,
            r##"<rect x="{MARGIN}" y="{top}" width="{plot_width}" height="{PANEL}" fill="none" stroke="#999"/>"##
        )?;
        writeln!(
            svg,
            r##"<line x1="{MARGIN}" y1="{z}" x2="{x2}" y2="{z}" stroke="#ccc"/>"##,
            z = y(0.0),
            x2 = MARGIN + plot_width
        )?;
        let rx = x(replan_at as f64);
        writeln!(
            svg,
            r##"<line x1="{rx}" y1="{top}" x2="{rx}" y2="{b}" stroke="#ff7f0e" stroke-dasharray="4 3"/>"##,
            b = top + PANEL
        )?;
        writeln!(svg, r##"<text x="{MARGIN}" y="{t}">{label}</text>"##, t = top - 8.0)?;
        writeln!(
            svg,
            r##"<text x="{l}" y="{t}" text-anchor="end">{hi:.0}</text>"##,
            l = MARGIN - 4.0,
            t = top + 10.0
        )?;
        writeln!(
            svg,
            r##"<text x="{l}" y="{t}" text-anchor="end">{lo:.0}</text>"##,
            l = MARGIN - 4.0,
            t = top + PANEL
        )?;
        let mut points = String::new();
        // At most one point per horizontal pixel pair keeps the file small.
        let stride = (samples.len() / 1600).max(1);
        for (i, v) in values.iter().enumerate().step_by(stride) {
            write!(points, "{:.1},{:.1} ", x(i as f64), y(*v))?;
        }
        writeln!(svg, r##"<polyline fill="none" stroke="{colour}" stroke-width="1.5" points="{points}"/>"##)?;
    }
    let bottom = height - MARGIN / 2.0;
    writeln!(
        svg,
        r##"<text x="{MARGIN}" y="{bottom}">time: {:.3} s at {HZ} Hz; dashed: re-plan to a nearer target while accelerating</text>"##,
        (n - 1.0) / f64::from(HZ)
    )?;
    writeln!(svg, "</svg>")?;
    Ok(svg)
}
