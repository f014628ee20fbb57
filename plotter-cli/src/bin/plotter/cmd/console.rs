//! `plotter console`: type G-code lines and see the firmware's replies (our firmware or GRBL: the real-time bytes
//! are the same). A line holding only `?`, `!` or `~` sends that real-time byte (status report, feed hold,
//! resume); `reset` sends Ctrl-X. On GRBL, `error:N` and `ALARM:N` replies are followed by their meaning; on an
//! EiBotBoard (EBB commands such as `V`, `QS`, `QG`, `SM,500,100,100`), `!N Err:` replies are. End with Ctrl-D.

use std::io::BufRead as _;
use std::sync::mpsc;
use std::time::Duration;

use plotter_host::link::Transport as _;
use plotter_host::link::connect::LinkArgs;
use plotter_host::link::console::console_bytes;
use plotter_host::link::ebb::messages::{EbbLine, describe_error as describe_ebb_error};
use plotter_host::link::grbl::messages::{GrblLine, describe_alarm, describe_error};
use plotter_host::link::machine::Connected;

/// A reply as shown: GRBL's numeric codes get their meaning.
fn shown(line: &str, grbl: bool) -> String {
    if !grbl {
        // An EiBotBoard's errors (`!N Err: …`) get theirs; our firmware's lines are shown as they are.
        if let EbbLine::Error { code, text } = EbbLine::parse(line)
            && line.starts_with('!')
        {
            return describe_ebb_error(code, &text);
        }
        return line.to_string();
    }
    match GrblLine::parse(line) {
        GrblLine::Error(c) => describe_error(c),
        GrblLine::Alarm(c) => describe_alarm(c),
        _ => line.to_string(),
    }
}

/// Run `plotter console`.
pub(crate) fn run(args: &LinkArgs) -> anyhow::Result<()> {
    let (_, mut c) = crate::cmd::home::connect(args)?;
    let grbl = matches!(c, Connected::Grbl(_));
    let ebb = matches!(c, Connected::Ebb(_));
    let session = c.transport();
    if ebb {
        eprintln!("type EBB commands (V, QS, QG, SM,<ms>,<steps1>,<steps2>, SP,0 / SP,1, ES …); Ctrl-D ends");
    } else {
        eprintln!("type G-code; ? status, ! hold, ~ resume, reset; Ctrl-D ends");
    }
    let (tx, rx) = mpsc::channel::<String>();
    std::thread::spawn(move || {
        for line in std::io::stdin().lock().lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    loop {
        match rx.try_recv() {
            Ok(line) => session.send(&console_bytes(&line))?,
            Err(mpsc::TryRecvError::Disconnected) => {
                // Show the last answers, then stop.
                while let Some(l) = session.recv_line(Duration::from_millis(300))? {
                    println!("{}", shown(&l, grbl));
                }
                return Ok(());
            }
            Err(mpsc::TryRecvError::Empty) => {}
        }
        if let Some(l) = session.recv_line(Duration::from_millis(20))? {
            println!("{}", shown(&l, grbl));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replies_shown() {
        assert_eq!(shown("error:22", true), "error:22 (no feed rate set)");
        assert_eq!(shown("error:22", false), "error:22");
        assert_eq!(
            shown("!8 Err: Unknown command 'XX:5858'", false),
            "!8 Err: Unknown command 'XX:5858' (unknown command)"
        );
    }
}
