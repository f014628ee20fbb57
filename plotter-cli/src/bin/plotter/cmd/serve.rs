//! `plotter serve`: the local web app — drop a drawing on the page, adjust it, plot it on the simulator or a
//! serial plotter (our firmware, GRBL or an EiBotBoard) and watch it. Listens on loopback; another address needs `--allow-remote`, since the app has no
//! authentication.

use std::io::Write as _;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context as _;
use plotter_path::MachineProfile;

use crate::serve;

/// Arguments of `plotter serve`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct ServeArgs {
    /// Address to listen on. Anything but loopback needs --allow-remote.
    #[arg(long, default_value = "127.0.0.1:8040")]
    pub(crate) listen: SocketAddr,
    /// Allow a --listen address other machines can reach. The app has no authentication: anyone who can reach
    /// the address can drive the plotter (one page at a time) and see the drawing.
    #[arg(long)]
    pub(crate) allow_remote: bool,
    /// Open the page in the default browser.
    #[arg(long)]
    pub(crate) open: bool,
    /// Machine profiles (TOML) to offer besides the built-in models (repeat the flag).
    #[arg(long)]
    pub(crate) profile: Vec<PathBuf>,
    /// Serial devices to offer besides those the system lists (e.g. the path printed by `plotter sim --pty`).
    #[arg(long)]
    pub(crate) port: Vec<String>,
    /// Largest upload (drawing or profile), MB.
    #[arg(long, default_value_t = 16.0)]
    pub(crate) max_upload_mb: f64,
    /// Pace of the simulated plotter, × real time.
    #[arg(long, default_value_t = 1.0)]
    pub(crate) sim_speed: f64,
    /// Most connections open at once (a page uses one for its events and a few for requests); more are refused.
    #[arg(long, default_value_t = 64)]
    pub(crate) max_connections: usize,
    /// Seconds a connection may take to send a request's head (and stay idle between requests).
    #[arg(long, default_value_t = 10.0)]
    pub(crate) header_timeout_s: f64,
    /// Seconds a request's body (an upload) may take to arrive.
    #[arg(long, default_value_t = 60.0)]
    pub(crate) body_timeout_s: f64,
    /// Seconds a page that took control has to open its event stream before control lapses.
    #[arg(long, default_value_t = 15.0)]
    pub(crate) claim_grace_s: f64,
    /// Folder for the resume journals of plots on a serial port [default: the journals folder of the user's
    /// state directory, where `plotter resume --list` looks].
    #[arg(long)]
    pub(crate) journal_dir: Option<PathBuf>,
    /// Run a studio: a plotter as NAME=DEVICE[,firmware=ours|grbl|ebb|auto][,profile=FILE or model][,paper=PAPER]
    /// (repeat for each plotter; DEVICE `sim` is a simulated plotter). The page then shows every machine side by
    /// side, fed from one job queue (`plotter queue add`).
    #[arg(long = "machine", value_name = "NAME=DEVICE[,KEY=VALUE]")]
    pub(crate) machines: Vec<String>,
    /// Run a studio with the machines of this TOML file: `[[machines]]` tables with name, device, firmware,
    /// profile and paper.
    #[arg(long)]
    pub(crate) studio: Option<PathBuf>,
    /// The studio's folder, for its job queue (a database), the queued drawings and the plots' journals
    /// [default: the studio folder of the user's state directory].
    #[arg(long)]
    pub(crate) state: Option<PathBuf>,
}

/// The studio the flags ask for (`None`: the single-machine app), opened in its folder.
fn open_studio(args: &ServeArgs) -> anyhow::Result<Option<std::sync::Arc<plotter_host::studio::running::Studio>>> {
    use plotter_host::studio::{machines, running};
    if args.machines.is_empty() && args.studio.is_none() {
        if args.state.is_some() {
            anyhow::bail!("--state is the studio's folder: give the studio's machines with --machine or --studio");
        }
        return Ok(None);
    }
    let mut specs = match &args.studio {
        Some(file) => machines::read_studio_file(file)?,
        None => Vec::new(),
    };
    for m in &args.machines {
        specs.push(machines::parse_machine(m)?);
    }
    let dir = match &args.state {
        Some(dir) => dir.clone(),
        None => plotter_host::state_dir::state_dir()?.join("studio"),
    };
    let options = running::StudioOptions { sim_speed: args.sim_speed, ..running::StudioOptions::default() };
    Ok(Some(running::Studio::open(&dir, specs, options)?))
}

/// A duration flag's value, in (0, 3600] s.
fn seconds(flag: &str, value: f64) -> anyhow::Result<Duration> {
    if !(value.is_finite() && value > 0.0 && value <= 3600.0) {
        anyhow::bail!("--{flag} must be in (0, 3600] seconds, got {value}");
    }
    Ok(Duration::from_secs_f64(value))
}

/// Refuse an address other machines can reach unless `allow_remote` says so: the app has no authentication.
fn check_listen(listen: SocketAddr, allow_remote: bool) -> anyhow::Result<()> {
    if listen.ip().to_canonical().is_loopback() || allow_remote {
        return Ok(());
    }
    anyhow::bail!(
        "refusing to listen on {listen}: the web app has no authentication, so anyone who can reach that address \
         could drive the plotter and see the drawing. Use a loopback address (the default is 127.0.0.1:8040), or \
         pass --allow-remote if you mean it"
    )
}

/// Run `plotter serve`.
pub(crate) fn run(args: &ServeArgs) -> anyhow::Result<()> {
    if !(args.sim_speed.is_finite() && args.sim_speed > 0.0 && args.sim_speed <= 1000.0) {
        anyhow::bail!("--sim-speed must be in (0, 1000], got {}", args.sim_speed);
    }
    if !(args.max_upload_mb.is_finite() && args.max_upload_mb > 0.0 && args.max_upload_mb <= 1024.0) {
        anyhow::bail!("--max-upload-mb must be in (0, 1024], got {}", args.max_upload_mb);
    }
    if !(1..=10_000).contains(&args.max_connections) {
        anyhow::bail!("--max-connections must be in 1..=10000, got {}", args.max_connections);
    }
    let limits = serve::state::Limits {
        header_timeout: seconds("header-timeout-s", args.header_timeout_s)?,
        body_timeout: seconds("body-timeout-s", args.body_timeout_s)?,
        max_connections: args.max_connections,
        claim_grace: seconds("claim-grace-s", args.claim_grace_s)?,
        ..serve::state::Limits::default()
    };
    check_listen(args.listen, args.allow_remote)?;
    // The built-in kit first (the page starts with it), then every built-in model, then the files named.
    let mut profiles = vec![MachineProfile::default_plotter()];
    for model in plotter_path::config::models::names().filter_map(plotter_path::config::models::find) {
        let profile = model.profile();
        if !profiles.iter().any(|p| p.name == profile.name) {
            profiles.push(profile);
        }
    }
    for p in &args.profile {
        profiles.push(MachineProfile::load(p)?);
    }
    let journals = match &args.journal_dir {
        Some(dir) => {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create the journal folder {}", dir.display()))?;
            Some(dir.clone())
        }
        None => plotter_host::state_dir::journals_dir()
            .map_err(|e| eprintln!("warning: plots will keep no resume journal: {e}"))
            .ok(),
    };
    // In (0, 1024] MB: far inside usize.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let max_upload = (args.max_upload_mb * 1_048_576.0) as usize;
    let studio = open_studio(args)?;
    // Before the runtime's threads: a signal stops the plot with the pen up, then the server (see serve::shutdown).
    plotter_host::stop::Stop::install_signals().context("cannot take the termination signals")?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind(args.listen)
            .await
            .with_context(|| format!("cannot listen on {}", args.listen))?;
        let local = listener.local_addr()?;
        if !local.ip().to_canonical().is_loopback() {
            eprintln!(
                "warning: listening on {local} (--allow-remote): the web app has no authentication; anyone who can \
                 reach this address can drive the plotter (one page at a time) and see the drawing"
            );
        }
        let host = if local.ip().is_unspecified() { format!("127.0.0.1:{}", local.port()) } else { local.to_string() };
        let url = format!("http://{host}/");
        println!("plotter serve: {url}");
        let _ = std::io::stdout().flush();
        if args.open {
            open_browser(&url);
        }
        if let Some(studio) = studio {
            return match serve::studio_app::serve(listener, studio, limits).await {
                Some(ended) if ended.interrupted => {
                    Err(plotter_host::stop::Stopped { cause: ended.cause, doing: "the studio's plots".into() }.into())
                }
                Some(ended) => {
                    println!("plotter serve: ended on {}", ended.cause);
                    Ok(())
                }
                None => Ok(()),
            };
        }
        let config = serve::state::Config {
            local,
            max_upload,
            sim_speed: args.sim_speed,
            extra_ports: args.port.clone(),
            profiles,
            limits,
            journals,
        };
        match serve::serve(listener, config).await {
            // A plot cut short is a stopped plot (exit 5); an idle server asked to end has done its job.
            Some(ended) if ended.interrupted => {
                Err(plotter_host::stop::Stopped { cause: ended.cause, doing: "a plot".into() }.into())
            }
            Some(ended) => {
                println!("plotter serve: ended on {}", ended.cause);
                Ok(())
            }
            None => Ok(()),
        }
    })
}

/// Ask the desktop to open `url`; say so if it cannot.
fn open_browser(url: &str) {
    let opener = if cfg!(target_os = "macos") {
        ("open", vec![url])
    } else if cfg!(windows) {
        ("cmd", vec!["/C", "start", "", url])
    } else {
        ("xdg-open", vec![url])
    };
    if let Err(e) = std::process::Command::new(opener.0).args(&opener.1).spawn() {
        eprintln!("warning: cannot open a browser ({}: {e}); open {url} yourself", opener.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_loopback_listens_without_the_opt_in() {
        for local in ["127.0.0.1:8040", "127.8.9.10:0", "[::1]:8040", "[::ffff:127.0.0.1]:8040"] {
            assert!(check_listen(local.parse().unwrap(), false).is_ok(), "{local}");
        }
        for remote in ["0.0.0.0:8040", "192.168.1.5:8040", "[::]:8040", "[2001:db8::1]:80"] {
            let addr: SocketAddr = remote.parse().unwrap();
            let e = check_listen(addr, false).unwrap_err().to_string();
            assert!(e.contains(&format!("refusing to listen on {addr}")) && e.contains("--allow-remote"), "{e}");
            assert!(e.contains("no authentication"), "{e}");
            assert!(check_listen(addr, true).is_ok(), "{remote}");
        }
    }

    #[test]
    fn durations_are_checked() {
        assert_eq!(seconds("x", 0.25).unwrap(), Duration::from_millis(250));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 3601.0] {
            assert!(seconds("header-timeout-s", bad).unwrap_err().to_string().contains("--header-timeout-s"), "{bad}");
        }
    }
}
