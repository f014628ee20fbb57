//! `cargo xtask` — build tasks for the firmware images (the cargo-xtask convention: a plain binary in the
//! workspace, run through the `xtask` alias in `.cargo/config.toml`).
//!
//! ```text
//! cargo xtask firmware --board nucleo-l476rg   # target/firmware/nucleo-l476rg.{elf,bin} + size report
//! cargo xtask firmware --board qemu-lm3s6965   # the emulated CI board (plotter sim --qemu runs it)
//! cargo xtask firmware --all                   # both
//! cargo xtask firmware --board nucleo-l476rg --features servo-pen   # pen lift by a hobby servo
//! cargo xtask tick-cost                        # cycles of the stepper interrupt on a Cortex-M4F (QEMU)
//! cargo xtask boards                           # list the boards
//! ```
//!
//! The board crates live in their own workspace (`plotter-fw/boards`), outside the host workspace, so that
//! `cargo test --workspace` stays host-only; they build into `target/boards`.

mod boards;
mod elf;
mod tick_cost;

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context as _, bail};

use boards::Board;

fn root() -> PathBuf {
    // plotter-fw/xtask → the repository root.
    Path::new(env!("CARGO_MANIFEST_DIR")).ancestors().nth(2).map(Path::to_path_buf).unwrap_or_default()
}

fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root().join("target"), PathBuf::from)
}

const USAGE: &str = "usage: cargo xtask firmware (--board NAME | --all) [--features F]\n       cargo xtask tick-cost\n       cargo xtask boards";

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("firmware") => {
            let mut rest: Vec<String> = args[1..].to_vec();
            let features = match rest.iter().position(|a| a == "--features") {
                Some(i) if i + 1 < rest.len() => {
                    let f = rest.remove(i + 1);
                    rest.remove(i);
                    Some(f)
                }
                Some(_) => bail!("--features needs a value, e.g. --features servo-pen"),
                None => None,
            };
            let chosen: Vec<Board> = match rest.as_slice() {
                [flag, name] if flag == "--board" => vec![boards::find(name).with_context(|| {
                    let names: Vec<&str> = boards::BOARDS.iter().map(|b| b.name).collect();
                    format!("unknown board {name:?}; boards: {}", names.join(", "))
                })?],
                [flag] if flag == "--all" => boards::BOARDS.to_vec(),
                _ => bail!("{USAGE}"),
            };
            for b in chosen {
                firmware(&b, features.as_deref())?;
            }
            Ok(())
        }
        Some("tick-cost") => {
            let elf = build(BENCH, None)?;
            tick_cost::run(&elf)
        }
        Some("boards") => {
            for b in boards::BOARDS {
                println!("{:<16} {:<24} {}", b.name, b.target, b.about);
            }
            Ok(())
        }
        _ => bail!("{USAGE}"),
    }
}

/// The tick bench image (see `tick_cost`).
const BENCH: (&str, &str) = ("tick-bench", "thumbv7em-none-eabihf");

/// Build a crate of the boards workspace for `target`; returns the ELF's path.
fn build((name, target): (&str, &str), features: Option<&str>) -> anyhow::Result<PathBuf> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let boards_dir = root().join("plotter-fw").join("boards");
    let build_dir = target_dir().join("boards");
    let mut cmd = Command::new(&cargo);
    cmd.args(["build", "--release", "-p", name, "--target", target]);
    if let Some(f) = features {
        cmd.args(["--features", f]);
    }
    let status = cmd
        .arg("--manifest-path")
        .arg(boards_dir.join("Cargo.toml"))
        .arg("--target-dir")
        .arg(&build_dir)
        .current_dir(&boards_dir)
        .status()
        .with_context(|| format!("cannot run {cargo}"))?;
    if !status.success() {
        bail!("building {name} failed (is the target installed? `rustup target add {target}`)");
    }
    Ok(build_dir.join(target).join("release").join(name))
}

/// Build one board image, write `.elf` and `.bin` under `target/firmware/`, print the size report.
fn firmware(b: &Board, features: Option<&str>) -> anyhow::Result<()> {
    let built = build((b.name, b.target), features)?;
    let out_dir = target_dir().join("firmware");
    std::fs::create_dir_all(&out_dir).with_context(|| format!("cannot create {}", out_dir.display()))?;
    let elf_path = out_dir.join(format!("{}.elf", b.name));
    let bin_path = out_dir.join(format!("{}.bin", b.name));
    let data = std::fs::read(&built).with_context(|| format!("cannot read {}", built.display()))?;
    let elf = elf::Elf::parse(&data).with_context(|| built.display().to_string())?;
    let bin = elf.flat_binary(b.flash_base, b.ram_base)?;
    std::fs::write(&elf_path, &data).with_context(|| format!("cannot write {}", elf_path.display()))?;
    std::fs::write(&bin_path, &bin).with_context(|| format!("cannot write {}", bin_path.display()))?;
    let (flash, ram) = (elf.flash_bytes(), elf.ram_bytes(b.ram_base));
    let kib = |v: u64| v as f64 / 1024.0;
    println!("{} ({})", b.name, b.about);
    println!("  {}", elf_path.display());
    println!("  {} ({} bytes)", bin_path.display(), bin.len());
    let (bf, br) = b.budget.unwrap_or(boards::BUDGET);
    let verdict = |used: u64, budget: u64| if used <= budget { "within" } else { "OVER" };
    println!(
        "  flash {flash:>6} bytes ({:5.1} KiB of {:.0} KiB on chip; {} the {:.0} KiB budget)",
        kib(flash),
        kib(b.flash_size),
        verdict(flash, bf),
        kib(bf)
    );
    println!(
        "  RAM   {ram:>6} bytes static ({:5.1} KiB of {:.0} KiB on chip; {} the {:.0} KiB budget; the stack takes the rest)",
        kib(ram),
        kib(b.ram_size),
        verdict(ram, br),
        kib(br)
    );
    for s in &elf.sections {
        println!("    {:<14} {:#010x} {:>6} bytes", s.name, s.addr, s.size);
    }
    if let Some((bf, br)) = b.budget
        && (flash > bf || ram > br)
    {
        bail!("{} is over its budget ({} KiB flash, {} KiB RAM)", b.name, bf / 1024, br / 1024);
    }
    Ok(())
}
