//! `plotter models`: the machine models built into the program, with their firmware, work area, pen lift and
//! speeds (`--json` for scripts).

use plotter_host::options::machine::top_speed_mm_s;
use plotter_path::config::models::{MODELS, Model, ModelFirmware};

/// Arguments of `plotter models`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct ModelsArgs {
    /// Print the list as JSON (one object per model) instead of a table.
    #[arg(long)]
    pub(crate) json: bool,
}

/// How a model lifts its pen, for people.
fn pen_kind(m: &Model) -> &'static str {
    let p = m.profile();
    match (m.firmware, p.pen.uses_servo()) {
        (ModelFirmware::Hpgl, _) => "solenoid",
        (_, true) => "servo",
        (_, false) => "Z",
    }
}

/// Run `plotter models`.
pub(crate) fn run(args: &ModelsArgs) -> anyhow::Result<()> {
    if args.json {
        let list: Vec<serde_json::Value> = MODELS
            .iter()
            .map(|m| {
                let p = m.profile();
                serde_json::json!({
                    "name": m.name,
                    "firmware": m.firmware.name(),
                    "description": m.description,
                    "profile_name": p.name,
                    "work_area_mm": [p.axes.x.travel_mm, p.axes.y.travel_mm],
                    "pen": pen_kind(m),
                    "top_speed_mm_s": round3(top_speed_mm_s(&p)),
                    "draw_speed_mm_s": p.pen.draw_feed_mm_s,
                    "travel_speed_mm_s": p.pen.travel_feed_mm_s,
                    "acceleration_mm_s2": p.axes.x.max_accel_mm_s2.min(p.axes.y.max_accel_mm_s2),
                    "sample": format!("samples/{}", m.sample),
                })
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&list)?);
        return Ok(());
    }
    println!(
        "{:<16} {:<8} {:>15}  {:<8} {:>9} {:>13}  DESCRIPTION",
        "MODEL", "FIRMWARE", "WORK AREA", "PEN", "TOP SPEED", "DRAW/TRAVEL"
    );
    for m in MODELS {
        let p = m.profile();
        let area = format!("{} × {} mm", p.axes.x.travel_mm, p.axes.y.travel_mm);
        let feeds = format!("{:.0}/{:.0} mm/s", p.pen.draw_feed_mm_s, p.pen.travel_feed_mm_s);
        println!(
            "{:<16} {:<8} {:>15}  {:<8} {:>4.0} mm/s {:>13}  {}",
            m.name,
            m.firmware.name(),
            area,
            pen_kind(m),
            top_speed_mm_s(&p),
            feeds,
            m.description
        );
    }
    println!(
        "\nUse one with --model NAME; --profile FILE.toml lays your own keys over it (a file may also say \
         model = \"NAME\"). --speed-pendown/--speed-penup in percent are of the top speed."
    );
    Ok(())
}

/// A figure to three decimals, for JSON.
fn round3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}
