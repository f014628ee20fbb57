//! `plotter serve`: the local web app — drop a drawing on the page, adjust it, plot it on the simulator or a
//! serial plotter (our firmware, GRBL or an EiBotBoard) and watch it. Listens on loopback; another address needs
//! `--allow-remote` and a token to sign in with (`--token-file` or `--generate-token`; see `serve::auth`).

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
    /// Allow a --listen address other machines can reach. Everyone must then sign in: give the operator's token
    /// with --token-file, or --generate-token. A token is never made up silently, because one generated at every
    /// start would change whenever the server restarts and is easily lost in a log.
    #[arg(long)]
    pub(crate) allow_remote: bool,
    /// With --allow-remote: a name people reach this server by (such as plotter.local or studio.example.org),
    /// accepted besides its IP addresses, this computer's host name and that name under .local. Repeat it for
    /// several. Names not given are refused, so that no other site can pose as this server.
    #[arg(long, value_name = "NAME", requires = "allow_remote")]
    pub(crate) host_name: Vec<String>,
    /// File whose first line is the operator's token (at least 16 characters): who has it may queue drawings and
    /// control the machines. Pages sign in with it once; `plotter queue` sends it with --token-file. Given on
    /// loopback too, the server asks for it there as well.
    #[arg(long, value_name = "FILE")]
    pub(crate) token_file: Option<PathBuf>,
    /// File whose first line is the viewers' token: who has it may watch the machines and the queue and press an
    /// emergency stop, nothing more. Without it (and without --generate-token) only the operator signs in.
    #[arg(long, value_name = "FILE")]
    pub(crate) viewer_token_file: Option<PathBuf>,
    /// Make random tokens for the operator and the viewers (those not given by a file) and print them once, now,
    /// on the error output; they last until the server stops.
    #[arg(long)]
    pub(crate) generate_token: bool,
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

/// Refuse an address other machines can reach unless `allow_remote` says so and a token (`signs_in`) will be asked
/// of everyone who connects.
fn check_listen(listen: SocketAddr, allow_remote: bool, signs_in: bool) -> anyhow::Result<()> {
    if listen.ip().to_canonical().is_loopback() {
        return Ok(());
    }
    if !allow_remote {
        anyhow::bail!(
            "refusing to listen on {listen}: anyone who can reach that address could drive the plotter and see the \
             drawing. Use a loopback address (the default is 127.0.0.1:8040), or pass --allow-remote with \
             --token-file FILE (or --generate-token) so that everyone must sign in"
        );
    }
    if !signs_in {
        anyhow::bail!(
            "refusing to listen on {listen} with no token: off loopback everyone must sign in. Give the operator's \
             token with --token-file FILE (its first line, at least 16 characters, e.g. from `openssl rand -hex 16`), \
             or --generate-token to have one made and printed now"
        );
    }
    Ok(())
}

/// The tokens made at start, each with what it is for, to print once.
type Made = Vec<(&'static str, String)>;

/// The tokens the flags give (`None`: no sign-in), and those generated, to print once.
fn tokens(args: &ServeArgs) -> anyhow::Result<(Option<serve::auth::Tokens>, Made)> {
    use serve::auth;
    let mut made = Vec::new();
    let operator = match (&args.token_file, args.generate_token) {
        (Some(file), _) => Some(auth::read_token_file(file, "--token-file")?),
        (None, true) => {
            let t = auth::random_token();
            made.push(("operator token (queue and control)", t.clone()));
            Some(t)
        }
        (None, false) => None,
    };
    let viewer = match (&args.viewer_token_file, args.generate_token) {
        (Some(file), _) => Some(auth::read_token_file(file, "--viewer-token-file")?),
        (None, true) => {
            let t = auth::random_token();
            made.push(("viewer token (watch and emergency stop)", t.clone()));
            Some(t)
        }
        (None, false) => None,
    };
    let Some(operator) = operator else {
        if viewer.is_some() {
            anyhow::bail!(
                "--viewer-token-file needs the operator's token too: add --token-file FILE or --generate-token"
            );
        }
        return Ok((None, made));
    };
    if viewer.as_deref() == Some(operator.as_str()) {
        anyhow::bail!("--viewer-token-file holds the operator's token: give the viewers a token of their own");
    }
    Ok((Some(auth::Tokens { operator, viewer }), made))
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
    let (tokens, made) = tokens(args)?;
    check_listen(args.listen, args.allow_remote, tokens.is_some())?;
    if args.allow_remote {
        let names = serve::safety::host_names(serve::safety::system_host_name().as_deref(), &args.host_name)?;
        serve::safety::accept_names(names);
    }
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
            eprintln!("plotter serve: listening on {local} (--allow-remote): everyone must sign in with a token");
        }
        for (what, token) in &made {
            eprintln!("plotter serve: {what}: {token}");
        }
        let host = if local.ip().is_unspecified() { format!("127.0.0.1:{}", local.port()) } else { local.to_string() };
        let url = format!("http://{host}/");
        println!("plotter serve: {url}");
        let _ = std::io::stdout().flush();
        if args.open {
            open_browser(&url);
        }
        if let Some(studio) = studio {
            return match serve::studio_app::serve(listener, studio, limits, tokens).await {
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
        match serve::serve(listener, config, tokens).await {
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
    fn only_loopback_listens_without_the_opt_in_and_a_token() {
        for local in ["127.0.0.1:8040", "127.8.9.10:0", "[::1]:8040", "[::ffff:127.0.0.1]:8040"] {
            assert!(check_listen(local.parse().unwrap(), false, false).is_ok(), "{local}");
        }
        for remote in ["0.0.0.0:8040", "192.168.1.5:8040", "[::]:8040", "[2001:db8::1]:80"] {
            let addr: SocketAddr = remote.parse().unwrap();
            let e = check_listen(addr, false, true).unwrap_err().to_string();
            assert!(e.contains(&format!("refusing to listen on {addr}")) && e.contains("--allow-remote"), "{e}");
            let e = check_listen(addr, true, false).unwrap_err().to_string();
            assert!(e.contains("with no token") && e.contains("--token-file") && e.contains("--generate-token"), "{e}");
            assert!(check_listen(addr, true, true).is_ok(), "{remote}");
        }
    }

    fn args(extra: &[&str]) -> ServeArgs {
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            serve: ServeArgs,
        }
        <Cli as clap::Parser>::parse_from(std::iter::once("serve").chain(extra.iter().copied())).serve
    }

    #[test]
    fn tokens_come_from_files_or_are_generated_on_request() {
        let dir = std::env::temp_dir().join(format!("plotter-serve-tokens-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (op, view) = (dir.join("op"), dir.join("view"));
        std::fs::write(&op, "operator-token-0123456789\n").unwrap();
        std::fs::write(&view, "viewer-token-0123456789\n").unwrap();
        let (op_s, view_s) = (op.to_str().unwrap(), view.to_str().unwrap());
        // Nothing asked: no sign-in.
        let (t, made) = tokens(&args(&[])).unwrap();
        assert!(t.is_none() && made.is_empty());
        // Files: read, nothing printed.
        let (t, made) = tokens(&args(&["--token-file", op_s, "--viewer-token-file", view_s])).unwrap();
        let t = t.unwrap();
        assert_eq!(
            (t.operator.as_str(), t.viewer.as_deref()),
            ("operator-token-0123456789", Some("viewer-token-0123456789"))
        );
        assert!(made.is_empty());
        let (t, _) = tokens(&args(&["--token-file", op_s])).unwrap();
        assert!(t.unwrap().viewer.is_none(), "no viewer token unless one is given or generated");
        // Generated: both, distinct, printed.
        let (t, made) = tokens(&args(&["--generate-token"])).unwrap();
        let t = t.unwrap();
        assert_eq!(made.len(), 2);
        assert_eq!(made[0].1, t.operator);
        assert_eq!(Some(&made[1].1), t.viewer.as_ref());
        assert_ne!(Some(&t.operator), t.viewer.as_ref());
        // A file and a generated viewer token.
        let (t, made) = tokens(&args(&["--token-file", op_s, "--generate-token"])).unwrap();
        assert_eq!(t.unwrap().operator, "operator-token-0123456789");
        assert_eq!(made.len(), 1);
        assert!(made[0].0.starts_with("viewer"));
        // A viewer's token alone, or the operator's given to viewers: refused.
        let e = tokens(&args(&["--viewer-token-file", view_s])).unwrap_err().to_string();
        assert!(e.contains("--token-file"), "{e}");
        let e = tokens(&args(&["--token-file", op_s, "--viewer-token-file", op_s])).unwrap_err().to_string();
        assert!(e.contains("operator's token"), "{e}");
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn durations_are_checked() {
        assert_eq!(seconds("x", 0.25).unwrap(), Duration::from_millis(250));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 3601.0] {
            assert!(seconds("header-timeout-s", bad).unwrap_err().to_string().contains("--header-timeout-s"), "{bad}");
        }
    }
}
