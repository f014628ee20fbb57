//! `plotter queue`: the studio's job queue from the command line, for scripts — add a drawing, list the queue,
//! cancel a job, wait for one to end — talking to a running `plotter serve --machine …` over its HTTP API.
//!
//! `queue add FILE [--machine NAME] [plot flags]` sends the drawing's bytes and the plot flags as given (input,
//! layout and path-order flags, exactly as `plotter plot` takes them); the server checks them with the same
//! definitions and the machine plots the job as `plotter plot FILE <flags>` would.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{Context as _, bail};
use clap::{CommandFactory as _, FromArgMatches as _};
use plotter_host::studio::job_args::JobArgs;
use serde_json::Value;

/// The header that carries `--token`.
pub(crate) const TOKEN_HEADER: &str = "authorization";

/// Arguments of `plotter queue`.
#[derive(clap::Args, Debug)]
pub(crate) struct QueueArgs {
    #[command(subcommand)]
    pub(crate) action: QueueAction,
}

/// Where the studio is and who asks.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct ServerArgs {
    /// The studio's address, as `plotter serve` printed it.
    #[arg(long, default_value = "http://127.0.0.1:8040/")]
    pub(crate) server: String,
    /// The token, for a studio that asks for one (sent in the Authorization header): the operator's to queue and
    /// cancel, a viewer's to list and wait. Others on this computer can see a command line: prefer --token-file.
    #[arg(long, conflicts_with = "token_file")]
    pub(crate) token: Option<String>,
    /// File whose first line is the token (the file given to `plotter serve --token-file`).
    #[arg(long, value_name = "FILE")]
    pub(crate) token_file: Option<PathBuf>,
}

/// What to do to the queue.
#[derive(clap::Subcommand, Debug)]
pub(crate) enum QueueAction {
    /// Queue a drawing (with the plot flags it is to be plotted with); prints the job's number
    Add(Box<AddArgs>),
    /// List the jobs: waiting, plotting and ended, with how each ended
    List(ListArgs),
    /// Cancel a job: a waiting one at once, a plotting one is stopped with the pen up
    Cancel(IdArgs),
    /// Wait for a job to end; exits 0 only when it finished
    Wait(WaitArgs),
}

/// Arguments of `plotter queue add`.
#[derive(clap::Parser, Debug)]
pub(crate) struct AddArgs {
    /// The drawing: any file `plotter plot` takes.
    pub(crate) file: PathBuf,
    /// The machine that must plot it [default: the first idle machine whose paper fits].
    #[arg(long)]
    pub(crate) machine: Option<String>,
    #[command(flatten)]
    pub(crate) server: ServerArgs,
    /// The plot flags.
    #[command(flatten)]
    pub(crate) job: JobArgs,
}

/// Arguments of `plotter queue list`.
#[derive(clap::Args, Debug)]
pub(crate) struct ListArgs {
    /// Print the jobs as JSON (with their whole history).
    #[arg(long)]
    pub(crate) json: bool,
    #[command(flatten)]
    pub(crate) server: ServerArgs,
}

/// A job's number.
#[derive(clap::Args, Debug)]
pub(crate) struct IdArgs {
    /// The job's number (`plotter queue list` shows them).
    pub(crate) id: i64,
    #[command(flatten)]
    pub(crate) server: ServerArgs,
}

/// Arguments of `plotter queue wait`.
#[derive(clap::Args, Debug)]
pub(crate) struct WaitArgs {
    /// The job's number.
    pub(crate) id: i64,
    /// Give up after this many seconds [default: wait as long as it takes].
    #[arg(long)]
    pub(crate) timeout: Option<f64>,
    #[command(flatten)]
    pub(crate) server: ServerArgs,
}

/// The studio's HTTP client.
struct Client {
    agent: ureq::Agent,
    base: String,
    token: Option<String>,
}

impl Client {
    fn new(s: &ServerArgs) -> anyhow::Result<Client> {
        let base = s.server.trim_end_matches('/').to_string();
        if !base.starts_with("http://") {
            bail!("--server {}: give the studio's http:// address, as `plotter serve` printed it", s.server);
        }
        let agent: ureq::Agent = ureq::Agent::config_builder()
            .http_status_as_error(false)
            .timeout_global(Some(Duration::from_secs(60)))
            .build()
            .into();
        let token = match &s.token_file {
            Some(file) => {
                let text = std::fs::read_to_string(file)
                    .with_context(|| format!("--token-file {}: cannot read it", file.display()))?;
                let token = text.lines().next().unwrap_or("").trim().to_string();
                if token.is_empty() {
                    bail!("--token-file {}: its first line is empty; it should hold the token", file.display());
                }
                Some(token)
            }
            None => s.token.clone(),
        };
        Ok(Client { agent, base, token })
    }

    /// The answer's JSON, or an error with the server's message.
    fn answer(&self, what: &str, r: Result<ureq::http::Response<ureq::Body>, ureq::Error>) -> anyhow::Result<Value> {
        let mut r = r.with_context(|| format!("cannot reach the studio at {} ({what})", self.base))?;
        let status = r.status();
        let text = r.body_mut().read_to_string().with_context(|| format!("{what}: unreadable answer"))?;
        let v: Value = serde_json::from_str(&text).unwrap_or(Value::String(text));
        if !status.is_success() {
            let message = v.get("error").and_then(Value::as_str).map_or_else(|| v.to_string(), str::to_string);
            if status.as_u16() == 401 {
                let hint = if self.token.is_some() {
                    "the token given is not one it accepts; check --token/--token-file against the file given to \
                     plotter serve --token-file"
                } else {
                    "it asks for a token: pass --token-file FILE (or --token TOKEN) with the operator's token"
                };
                bail!("{what}: the studio at {} refused: {hint} ({message})", self.base);
            }
            bail!("{what}: the studio said {}: {message}", status.as_u16());
        }
        Ok(v)
    }

    fn get(&self, path: &str, what: &str) -> anyhow::Result<Value> {
        let mut req = self.agent.get(format!("{}{path}", self.base));
        if let Some(t) = &self.token {
            req = req.header(TOKEN_HEADER, format!("Bearer {t}"));
        }
        self.answer(what, req.call())
    }

    fn post(&self, path: &str, query: &[(&str, &str)], body: &[u8], what: &str) -> anyhow::Result<Value> {
        let mut req = self.agent.post(format!("{}{path}", self.base)).query_pairs(query.iter().copied());
        if let Some(t) = &self.token {
            req = req.header(TOKEN_HEADER, format!("Bearer {t}"));
        }
        self.answer(what, req.header("content-type", "application/octet-stream").send(body))
    }
}

/// The plot flags given on the command line, as words: every flag of [`JobArgs`] the user set, with its values
/// as typed, in the order of the flag definitions.
pub(crate) fn job_words(matches: &clap::ArgMatches) -> Vec<String> {
    let mut words = Vec::new();
    for arg in JobArgs::command().get_arguments() {
        let id = arg.get_id().as_str();
        if matches.value_source(id) != Some(clap::parser::ValueSource::CommandLine) {
            continue;
        }
        let Some(long) = arg.get_long() else { continue };
        if arg.get_action().takes_values() {
            if let Ok(Some(occurrences)) = matches.try_get_raw_occurrences(id) {
                for values in occurrences {
                    words.push(format!("--{long}"));
                    words.extend(values.map(|v| v.to_string_lossy().into_owned()));
                }
            }
        } else {
            let times = match arg.get_action() {
                clap::ArgAction::Count => usize::from(matches.get_count(id)),
                _ => 1,
            };
            words.extend(std::iter::repeat_n(format!("--{long}"), times));
        }
    }
    words
}

/// The command line's words after `queue add`.
fn add_words() -> Vec<String> {
    let all: Vec<String> = std::env::args().collect();
    let queue = all.iter().position(|a| a == "queue").unwrap_or(0);
    let add = all.iter().skip(queue).position(|a| a == "add").map_or(all.len(), |i| queue + i + 1);
    all[add.min(all.len())..].to_vec()
}

/// Run `plotter queue`.
pub(crate) fn run(args: &QueueArgs) -> anyhow::Result<()> {
    match &args.action {
        QueueAction::Add(a) => {
            let matches = AddArgs::command()
                .try_get_matches_from(std::iter::once("add".to_string()).chain(add_words()))
                .context("cannot read the plot flags")?;
            let words = job_words(&matches);
            // The same flags read back give the same job (what the server will read).
            AddArgs::from_arg_matches(&matches).context("cannot read the plot flags")?;
            add(a, &words)
        }
        QueueAction::List(l) => list(l),
        QueueAction::Cancel(c) => {
            let client = Client::new(&c.server)?;
            let v = client.post(&format!("/api/queue/{}/cancel", c.id), &[], &[], &format!("cancel job {}", c.id))?;
            match v.get("state").and_then(Value::as_str) {
                Some("stopping") => println!("job {}: stopping its machine (pen up); it ends cancelled", c.id),
                _ => println!("job {}: cancelled", c.id),
            }
            Ok(())
        }
        QueueAction::Wait(w) => wait(w),
    }
}

fn add(a: &AddArgs, words: &[String]) -> anyhow::Result<()> {
    let bytes = std::fs::read(&a.file).with_context(|| format!("cannot read {}", a.file.display()))?;
    let name = a.file.file_name().and_then(|n| n.to_str()).unwrap_or("drawing").to_string();
    let flags = serde_json::to_string(words)?;
    let mut query = vec![("name", name.as_str()), ("args", flags.as_str())];
    if let Some(m) = &a.machine {
        query.push(("machine", m.as_str()));
    }
    let client = Client::new(&a.server)?;
    let v = client.post("/api/queue", &query, &bytes, &format!("queue {}", a.file.display()))?;
    let id = v.get("id").and_then(Value::as_i64).context("the studio did not say the job's number")?;
    println!("{id}");
    Ok(())
}

fn last_outcome(job: &Value) -> String {
    job["history"].as_array().and_then(|h| h.last()).and_then(|a| a["outcome"].as_str()).unwrap_or("").to_string()
}

fn list(l: &ListArgs) -> anyhow::Result<()> {
    let client = Client::new(&l.server)?;
    let jobs = client.get("/api/queue", "list the queue")?;
    if l.json {
        println!("{}", serde_json::to_string_pretty(&jobs)?);
        return Ok(());
    }
    let jobs = jobs.as_array().context("the studio's queue is not a list")?;
    if jobs.is_empty() {
        println!("the queue is empty");
        return Ok(());
    }
    println!("{:>5}  {:<11}  {:<10}  {:<10}  {:<24}  outcome", "job", "state", "for", "machine", "drawing");
    for j in jobs {
        println!("{}", list_row(j));
    }
    Ok(())
}

/// A job's line of `plotter queue list`, in the columns of its heading.
fn list_row(j: &Value) -> String {
    // A JSON number ignores the column's width: its text is padded.
    let id = j["id"].as_i64().map_or_else(|| "?".to_string(), |i| i.to_string());
    format!(
        "{id:>5}  {:<11}  {:<10}  {:<10}  {:<24}  {}",
        j["state"].as_str().unwrap_or("?"),
        j["machine"].as_str().unwrap_or("any"),
        j["claimed_by"].as_str().unwrap_or("-"),
        j["drawing"].as_str().unwrap_or("?"),
        last_outcome(j)
    )
}

fn wait(w: &WaitArgs) -> anyhow::Result<()> {
    if let Some(t) = w.timeout
        && !(t.is_finite() && t > 0.0)
    {
        bail!("--timeout must be a positive number of seconds, got {t}");
    }
    let client = Client::new(&w.server)?;
    let start = Instant::now();
    let mut shown = String::new();
    loop {
        let job = client.get(&format!("/api/queue/{}", w.id), &format!("wait for job {}", w.id))?;
        let state = job["state"].as_str().unwrap_or("?").to_string();
        if state != shown {
            eprintln!("job {}: {state}", w.id);
            shown.clone_from(&state);
        }
        if plotter_host::studio::running::ended(&state) {
            let outcome = last_outcome(&job);
            if state == "done" {
                println!("job {}: done ({outcome})", w.id);
                return Ok(());
            }
            bail!("job {} ended {state}: {outcome}", w.id);
        }
        if let Some(t) = w.timeout
            && start.elapsed().as_secs_f64() > t
        {
            bail!("job {} is still {state} after {t} s", w.id);
        }
        std::thread::sleep(Duration::from_millis(250));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words_of(line: &[&str]) -> Vec<String> {
        let m = AddArgs::command().try_get_matches_from(std::iter::once("add").chain(line.iter().copied())).unwrap();
        job_words(&m)
    }

    #[test]
    fn the_plot_flags_are_sent_as_typed_and_the_queue_flags_are_not() {
        let w = words_of(&[
            "duck.svg",
            "--machine",
            "left",
            "--paper",
            "a5",
            "--server",
            "http://127.0.0.1:9/",
            "--fit",
            "--rotate",
            "-30",
            "--token",
            "t",
            "--no-optimize",
        ]);
        assert_eq!(w, ["--paper", "a5", "--fit", "--rotate", "-30", "--no-optimize"]);
        // Read back as the server reads them: the same layout.
        let back = JobArgs::from_options(&serde_json::json!({ "args": w })).unwrap();
        assert_eq!(back.layout.paper.as_deref(), Some("a5"));
        assert!(back.layout.fit && back.optimize.no_optimize);
        assert!((back.layout.rotate + 30.0).abs() < 1e-12);
        assert!(words_of(&["duck.svg"]).is_empty());
        // The workflow flags go too: copies with a page delay.
        let w = words_of(&["duck.svg", "--copies", "0", "--page-delay", "2", "--no-paper-pause"]);
        assert_eq!(w, ["--copies", "0", "--page-delay", "2", "--no-paper-pause"]);
        let back = JobArgs::from_options(&serde_json::json!({ "args": w })).unwrap();
        assert_eq!((back.workflow.copies, back.workflow.page_delay), (0, 2.0));
    }

    #[test]
    fn a_listed_job_lines_up_under_the_heading() {
        let j = serde_json::json!({"id": 12, "state": "done", "machine": null, "claimed_by": "big",
            "drawing": "duck.svg", "history": [{"outcome": "done"}]});
        assert_eq!(list_row(&j), "   12  done         any         big         duck.svg                  done");
    }
}
