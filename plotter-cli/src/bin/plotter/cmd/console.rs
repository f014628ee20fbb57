//! `plotter console`: type G-code lines and see the firmware's replies (our firmware or GRBL: the real-time bytes
//! are the same). A line holding only `?`, `!` or `~` sends that real-time byte (status report, feed hold,
//! resume); `reset` sends Ctrl-X. On GRBL, `error:N` and `ALARM:N` replies are followed by their meaning; on an
//! EiBotBoard (EBB commands such as `V`, `QS`, `QG`, `SM,500,100,100`), `!N Err:` replies are. End with Ctrl-D.

use std::io::BufRead as _;
use std::sync::mpsc;
use std::time::Duration;

use plotter_host::link::Transport as _;
use plotter_host::link::connect::LinkArgs;
use plotter_host::link::console::{console_bytes, shown_reply};
use plotter_host::link::machine::Connected;

/// Run `plotter console`.
pub(crate) fn run(args: &LinkArgs) -> anyhow::Result<()> {
    let (_, mut c) = crate::cmd::home::connect(args)?;
    let firmware = c.machine().firmware();
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
                    println!("{}", shown_reply(&l, firmware));
                }
                return Ok(());
            }
            Err(mpsc::TryRecvError::Empty) => {}
        }
        if let Some(l) = session.recv_line(Duration::from_millis(20))? {
            println!("{}", shown_reply(&l, firmware));
        }
    }
}
