//! `plotter serve`: the local web app — drop a drawing on the page, adjust it, plot it on the simulator or a
//! serial plotter and watch it. Listens on loopback unless `--listen` says otherwise.

use std::io::Write as _;
use std::net::SocketAddr;
use std::path::PathBuf;

use anyhow::Context as _;
use plotter_path::MachineProfile;

use crate::serve;

/// Arguments of `plotter serve`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct ServeArgs {
    /// Address to listen on. Anything but loopback lets other machines on the network drive the plotter.
    #[arg(long, default_value = "127.0.0.1:8040")]
    pub(crate) listen: SocketAddr,
    /// Open the page in the default browser.
    #[arg(long)]
    pub(crate) open: bool,
    /// Machine profiles (TOML) to offer besides the built-in XY plotter kit (repeat the flag).
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
}

/// Run `plotter serve`.
pub(crate) fn run(args: &ServeArgs) -> anyhow::Result<()> {
    if !(args.sim_speed.is_finite() && args.sim_speed > 0.0 && args.sim_speed <= 1000.0) {
        anyhow::bail!("--sim-speed must be in (0, 1000], got {}", args.sim_speed);
    }
    if !(args.max_upload_mb.is_finite() && args.max_upload_mb > 0.0 && args.max_upload_mb <= 1024.0) {
        anyhow::bail!("--max-upload-mb must be in (0, 1024], got {}", args.max_upload_mb);
    }
    let mut profiles = vec![MachineProfile::default_plotter()];
    for p in &args.profile {
        profiles.push(MachineProfile::load(p)?);
    }
    // In (0, 1024] MB: far inside usize.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let max_upload = (args.max_upload_mb * 1_048_576.0) as usize;
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
        if !local.ip().is_loopback() {
            eprintln!(
                "warning: listening on {local}: anyone who can reach this address can drive the plotter (one page \
                 at a time); use the default 127.0.0.1 unless you mean it"
            );
        }
        let host = if local.ip().is_unspecified() { format!("127.0.0.1:{}", local.port()) } else { local.to_string() };
        let url = format!("http://{host}/");
        println!("plotter serve: {url}");
        let _ = std::io::stdout().flush();
        if args.open {
            open_browser(&url);
        }
        let config = serve::state::Config {
            local,
            max_upload,
            sim_speed: args.sim_speed,
            extra_ports: args.port.clone(),
            profiles,
        };
        serve::serve(listener, config).await.context("the server stopped")
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
