//! The view's page driven in a real browser through the W3C WebDriver protocol (Debian's
//! `chromium-driver`, spoken to over HTTP by the small client below): load a view's URL, wait for
//! the picture to refine, move the slice with the page's slider and a plane with its normal and
//! offset controls, click **save**, and compare each saved EXR with what the command line the page
//! prints writes, bit for bit.

use crate::support::{in_ci, scene_path, skip_without, temp_dir};
use crate::view::{rerun_saved, start};
use serde_json::{Value, json};
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// `chromedriver` (or `$CHROMEDRIVER`) if it runs here.
fn chromedriver() -> Result<String, String> {
    let name = std::env::var("CHROMEDRIVER").unwrap_or_else(|_| "chromedriver".into());
    match Command::new(&name).arg("--version").output() {
        Ok(o) if o.status.success() => Ok(name),
        _ => Err(format!(
            "no {name} runs here (Debian: apt-get install chromium-driver)"
        )),
    }
}

/// A running chromedriver and one browser session of it, both ended when dropped.
struct Driver {
    child: Child,
    port: u16,
    session: String,
}

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = call(
            self.port,
            "DELETE",
            &format!("/session/{}", self.session),
            None,
        );
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// One WebDriver command: `method path` with a JSON body; the reply's `value`, or the
/// protocol's error as text.
fn call(port: u16, method: &str, path: &str, body: Option<&Value>) -> Result<Value, String> {
    let mut s = TcpStream::connect(("127.0.0.1", port)).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    let body = body.map(|b| b.to_string()).unwrap_or_default();
    write!(
        s,
        "{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\
         Content-Type: application/json; charset=utf-8\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    )
    .map_err(|e| e.to_string())?;
    // Read the head, then the body by its length (chromedriver keeps connections open).
    let mut buf = Vec::new();
    let mut byte = [0u8; 4096];
    let split = loop {
        if let Some(p) = buf.windows(4).position(|w| w == b"\r\n\r\n") {
            break p;
        }
        let n = s.read(&mut byte).map_err(|e| e.to_string())?;
        if n == 0 {
            return Err("no HTTP response".into());
        }
        buf.extend_from_slice(&byte[..n]);
    };
    let head = String::from_utf8_lossy(&buf[..split]).to_ascii_lowercase();
    let mut payload = buf[split + 4..].to_vec();
    let length = head
        .lines()
        .find_map(|l| l.strip_prefix("content-length:"))
        .and_then(|v| v.trim().parse::<usize>().ok());
    match length {
        Some(len) => {
            while payload.len() < len {
                let n = s.read(&mut byte).map_err(|e| e.to_string())?;
                if n == 0 {
                    break;
                }
                payload.extend_from_slice(&byte[..n]);
            }
        }
        None => {
            s.read_to_end(&mut payload).map_err(|e| e.to_string())?;
            if head.contains("transfer-encoding: chunked") {
                payload = dechunk(&payload);
            }
        }
    }
    let v: Value = serde_json::from_slice(&payload)
        .map_err(|e| format!("{e}: {}", String::from_utf8_lossy(&payload)))?;
    let value = v.get("value").cloned().unwrap_or(Value::Null);
    if let Some(err) = value.get("error") {
        return Err(format!("{method} {path}: {err}: {}", value["message"]));
    }
    Ok(value)
}

/// An HTTP/1.1 chunked body's bytes.
fn dechunk(mut b: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    while let Some(eol) = b.windows(2).position(|w| w == b"\r\n") {
        let size =
            usize::from_str_radix(String::from_utf8_lossy(&b[..eol]).trim(), 16).unwrap_or(0);
        if size == 0 {
            break;
        }
        out.extend_from_slice(&b[eol + 2..eol + 2 + size]);
        b = &b[eol + 4 + size..];
    }
    out
}

impl Driver {
    /// Starts `driver` on a free port and opens a headless Chromium session (its profile in
    /// `dir`).
    fn start(driver: &str, dir: &Path) -> Driver {
        let port = TcpListener::bind(("127.0.0.1", 0))
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let child = Command::new(driver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("chromedriver starts");
        // Owned from here: a failure below ends it.
        let mut d = Driver {
            child,
            port,
            session: String::new(),
        };
        let t = Instant::now();
        while call(port, "GET", "/status", None)
            .map(|v| v["ready"] != json!(true))
            .unwrap_or(true)
        {
            assert!(
                t.elapsed() < Duration::from_secs(20),
                "chromedriver not ready"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
        let mut chrome = json!({"args": [
            "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
            "--window-size=1100,800",
            format!("--user-data-dir={}", dir.join("profile").display()),
        ]});
        if let Ok(b) = std::env::var("CHROMIUM") {
            chrome["binary"] = json!(b);
        }
        let caps = json!({"capabilities": {"alwaysMatch": {"goog:chromeOptions": chrome}}});
        let v = call(port, "POST", "/session", Some(&caps)).expect("a browser session");
        d.session = v["sessionId"].as_str().expect("a session id").to_string();
        d
    }

    fn cmd(&self, method: &str, path: &str, body: Value) -> Value {
        let path = format!("/session/{}{path}", self.session);
        call(self.port, method, &path, Some(&body)).unwrap_or_else(|e| panic!("{e}"))
    }

    fn go(&self, url: &str) {
        self.cmd("POST", "/url", json!({ "url": url }));
    }

    /// Runs `script` in the page; its return value.
    fn js(&self, script: &str) -> Value {
        self.cmd(
            "POST",
            "/execute/sync",
            json!({ "script": script, "args": [] }),
        )
    }

    /// Clicks the element of CSS selector `css` as a user does (WebDriver's element click).
    fn click(&self, css: &str) {
        let e = self.cmd(
            "POST",
            "/element",
            json!({"using": "css selector", "value": css}),
        );
        let id = e
            .as_object()
            .and_then(|o| o.values().next())
            .and_then(Value::as_str)
            .expect("an element reference")
            .to_string();
        self.cmd("POST", &format!("/element/{id}/click"), json!({}));
    }

    /// Waits (up to 60 s) until `script` returns true; what `report` returns if it never does.
    fn wait_for(&self, what: &str, script: &str, report: &str) {
        let t = Instant::now();
        while self.js(script) != json!(true) {
            assert!(
                t.elapsed() < Duration::from_secs(60),
                "{what}: {}",
                self.js(report)
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

/// The page's status text, error and the state in its address.
const REPORT: &str = "return [document.getElementById('status').textContent, \
     document.getElementById('error').textContent, location.search].join(' | ');";

/// Waits until the page shows a finished run of the state in its address whose picture has
/// loaded.
fn wait_refined(d: &Driver, what: &str) {
    d.wait_for(
        what,
        "const p = document.getElementById('pic'); \
         return shown.startsWith(generation + '/') && p.complete && p.naturalWidth > 0 \
           && document.getElementById('status').textContent.includes('stopped');",
        REPORT,
    );
}

/// Clicks save, runs the command line the page prints (into another file) and compares the
/// two EXR files bit for bit; returns the command.
fn save_and_compare(d: &Driver, dir: &Path, again: &str) -> String {
    d.js("document.getElementById('saved').textContent = '';");
    d.click("#save");
    d.wait_for(
        "the save's report",
        "return document.getElementById('saved').textContent.includes('ftpd3d ');",
        "return document.getElementById('saved').textContent;",
    );
    let text = d.js("return document.getElementById('saved').textContent;");
    let text = text.as_str().unwrap().to_string();
    assert!(text.contains("the same, bit for bit: "), "{text}");
    let command = text
        .split("bit for bit: ")
        .nth(1)
        .unwrap()
        .trim()
        .to_string();
    rerun_saved(dir, &command, again);
    command
}

#[test]
fn webdriver_moves_the_slice_and_a_plane_and_saves_what_the_printed_command_writes() {
    let driver = chromedriver();
    if skip_without("view::webdriver", driver.as_ref().err().cloned(), in_ci()) {
        return;
    }
    let dir = temp_dir("view", "webdriver");
    let scene = scene_path("cornell_mirror.obj");
    let v = start(
        &dir,
        &[
            "--scene",
            scene.to_str().unwrap(),
            "--slice",
            "z=0",
            "--res",
            "16",
            "--spp",
            "16",
            "--batches",
            "4",
            "--threads",
            "2",
        ],
    );
    let d = Driver::start(&driver.unwrap(), &dir);
    d.go(&format!("{}&slice=z%3D-0.5", v.url));
    wait_refined(&d, "the first view");
    let first = d.js("return location.search;");
    assert!(
        first.as_str().unwrap().contains("slice=z%3D-0.5"),
        "{first}"
    );

    // Move the slice with the page's own slider (its input event, as a drag fires).
    d.js(
        "const e = document.getElementById('pos'); e.value = '0.3'; \
          e.dispatchEvent(new Event('input'));",
    );
    d.wait_for(
        "the moved slice in the address",
        "return !location.search.includes('slice=z%3D-0.5') && location.search.includes('slice=z%3D0.3');",
        REPORT,
    );
    wait_refined(&d, "the moved slice");
    let command = save_and_compare(&d, &dir, "slice_again.exr");
    assert!(command.contains("--slice z=0.3"), "{command}");

    // An arbitrary plane from its normal and offset controls: the --plane flag's syntax in the
    // address, and in the saved command.
    d.js("for (const [id, x] of [['nx', 1], ['ny', 0], ['nz', 1]]) \
            document.getElementById(id).value = x; \
          const o = document.getElementById('offset'); o.value = '0.2'; \
          o.dispatchEvent(new Event('input'));");
    d.wait_for(
        "the plane in the address",
        "return location.search.includes('plane=') && !location.search.includes('slice=');",
        REPORT,
    );
    wait_refined(&d, "the plane");
    let search = d.js("return decodeURIComponent(location.search);");
    let search = search.as_str().unwrap();
    assert!(search.contains("normal=1,0,1"), "{search}");
    let command = save_and_compare(&d, &dir, "plane_again.exr");
    assert!(command.contains("--plane 'origin="), "{command}");
    assert!(command.contains("normal=1,0,1'"), "{command}");
}
