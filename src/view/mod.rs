//! `ftpd3d view`: a live view of a scene's field in a web page. A small synchronous HTTP server
//! (tiny_http) on 127.0.0.1 serves a static page (`page.html`), the picture of the current slice
//! as the PNG previews draw it, and the run's status; a worker computes the field of the current
//! state with the command line's own driver, pass by pass, and starts again on a fresh field when
//! the state changes. The state is the run's flags, as the page's URL carries them
//! ([`crate::cli::view`]). Saving writes what the command line would write for the samples taken
//! so far and gives the command line that takes them.
//!
//! The rooms: the run ([`session`]), what the page is shown and saving ([`picture`]), the requests
//! and their checks ([`http`]).

pub mod http;
pub mod picture;
pub mod session;

use crate::cli::view::{ViewArgs, base_state, state_query};
use anyhow::Context;
use http::Gate;
use session::Shared;
use std::io::{Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Set by SIGINT/SIGTERM/SIGHUP: the server stops within a tenth of a second.
static QUIT: AtomicBool = AtomicBool::new(false);

/// Serves the view of `args` until SIGINT/SIGTERM. `raw` is the command line after `view`, as
/// the shell gave it (the state the page starts with). The page's URL, with its token, is the
/// first line of stdout.
pub fn serve(args: &ViewArgs, raw: &[String]) -> anyhow::Result<()> {
    args.run.scene()?;
    let (base, fixed) = base_state(raw).map_err(anyhow::Error::msg)?;
    let server = tiny_http::Server::http(("127.0.0.1", args.port.unwrap_or(0)))
        .map_err(|e| anyhow::anyhow!("--port: cannot listen on 127.0.0.1: {e}"))?;
    let port = server
        .server_addr()
        .to_ip()
        .map(|a| a.port())
        .context("the server has no port")?;
    let token = random_token()?;
    let query = state_query(&base);
    let url = format!(
        "http://127.0.0.1:{port}/?token={token}{}{query}",
        if query.is_empty() { "" } else { "&" }
    );
    let mut out = std::io::stdout().lock();
    writeln!(out, "{url}")?;
    out.flush()?;
    drop(out);
    eprintln!("serving the view on 127.0.0.1:{port} (Ctrl-C stops it)");
    if args.open {
        open_browser(&url);
    }
    if let Err(e) = ctrlc::set_handler(|| QUIT.store(true, Ordering::SeqCst)) {
        eprintln!("warning: no signal handler ({e}): stop the view with SIGKILL");
    }
    let shared = Arc::new(Shared::new(fixed, base.clone()));
    let worker = {
        let s = shared.clone();
        std::thread::spawn(move || session::worker(s))
    };
    let gate = Arc::new(Gate { token, port, base });
    while !QUIT.load(Ordering::SeqCst) {
        match server.recv_timeout(Duration::from_millis(100)) {
            Ok(Some(req)) => {
                let (s, g) = (shared.clone(), gate.clone());
                std::thread::spawn(move || http::handle(req, &s, &g));
            }
            Ok(None) => {}
            Err(e) => eprintln!("warning: {e}"),
        }
    }
    shared.quit();
    // The run in flight stops between chunks; a long one is not waited for.
    for _ in 0..5 {
        if worker.is_finished() {
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    eprintln!("view stopped");
    Ok(())
}

/// 128 random bits from the system, as hex.
fn random_token() -> anyhow::Result<String> {
    let mut b = [0u8; 16];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut b))
        .context("/dev/urandom: no random token for the view")?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

/// Opens `url` in the desktop's browser (`xdg-open`, `open` on macOS); says so when it cannot.
fn open_browser(url: &str) {
    let opener = if cfg!(target_os = "macos") {
        "open"
    } else {
        "xdg-open"
    };
    let spawned = std::process::Command::new(opener)
        .arg(url)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn();
    if let Err(e) = spawned {
        eprintln!("warning: --open: {opener}: {e}; open the URL above by hand");
    }
}
