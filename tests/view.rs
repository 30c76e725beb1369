//! `ftpd3d view`: the server as a client sees it (127.0.0.1 only, the token, the picture, the
//! state, saving, SIGTERM), and the page in a real browser (headless Chromium).

use crate::support::{exr_parts, in_ci, scene_path, skip_without, temp_dir};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A running `ftpd3d view`, killed when dropped.
pub(crate) struct View {
    child: Child,
    pub(crate) url: String,
    port: u16,
    token: String,
}

impl Drop for View {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts `ftpd3d view` with `args` in `dir` and reads the URL from the first line of its stdout
/// (within 10 s, as the issue asks).
pub(crate) fn start(dir: &Path, args: &[&str]) -> View {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ftpd3d"))
        .current_dir(dir)
        .arg("view")
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("the binary starts");
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = BufReader::new(stdout).read_line(&mut line);
        let _ = tx.send(line);
    });
    let line = rx
        .recv_timeout(Duration::from_secs(10))
        .expect("a URL on stdout within 10 s");
    let url = line.trim().to_string();
    let rest = url
        .strip_prefix("http://127.0.0.1:")
        .unwrap_or_else(|| panic!("not a 127.0.0.1 URL: {url}"));
    let port: u16 = rest.split('/').next().unwrap().parse().unwrap();
    let token = url
        .split(['?', '&'])
        .find_map(|p| p.strip_prefix("token="))
        .expect("a token in the URL")
        .to_string();
    assert!(token.len() >= 32, "a long random token: {token}");
    View {
        child,
        url,
        port,
        token,
    }
}

/// One HTTP/1.0 request to 127.0.0.1:`port`: status and body.
fn request(port: u16, method: &str, path: &str, headers: &[&str]) -> (u16, Vec<u8>) {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    let mut head = format!("{method} {path} HTTP/1.0\r\nHost: 127.0.0.1:{port}\r\n");
    for h in headers {
        head.push_str(h);
        head.push_str("\r\n");
    }
    head.push_str("Content-Length: 0\r\n\r\n");
    s.write_all(head.as_bytes()).unwrap();
    let mut buf = Vec::new();
    s.read_to_end(&mut buf).unwrap();
    let split = buf
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("an HTTP response");
    let status_line = String::from_utf8_lossy(&buf[..split]).to_string();
    let code = status_line.split(' ').nth(1).unwrap().parse().unwrap();
    (code, buf[split + 4..].to_vec())
}

impl View {
    fn get(&self, path_and_query: &str) -> (u16, Vec<u8>) {
        request(self.port, "GET", &self.with_token(path_and_query), &[])
    }

    fn post(&self, path_and_query: &str) -> (u16, String) {
        let (c, b) = request(self.port, "POST", &self.with_token(path_and_query), &[]);
        (c, String::from_utf8_lossy(&b).into_owned())
    }

    fn with_token(&self, p: &str) -> String {
        let (path, q) = p.split_once('?').unwrap_or((p, ""));
        format!("{path}?token={}&{q}", self.token)
    }

    fn status(&self) -> String {
        let (c, b) = self.get("/status");
        assert_eq!(c, 200);
        String::from_utf8(b).unwrap()
    }

    /// Waits (up to 60 s) until the current generation's run has stopped; its status.
    fn wait_stopped(&self) -> String {
        let t = Instant::now();
        loop {
            let s = self.status();
            if s.contains("\"running\":false") {
                return s;
            }
            assert!(t.elapsed() < Duration::from_secs(60), "still running: {s}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Makes the state `query` current and returns the picture of its finished run.
    fn picture_of(&self, query: &str) -> Vec<u8> {
        let (c, b) = self.post(&format!("/state?{query}"));
        assert_eq!(c, 200, "{b}");
        let g = json_number(&b, "generation");
        self.wait_stopped();
        let (c, png) = self.get(&format!("/image.png?channel=ftpd&g={g}"));
        assert_eq!(c, 200, "{}", String::from_utf8_lossy(&png));
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        png
    }
}

/// The number after `"key":` in a JSON text.
fn json_number(json: &str, key: &str) -> u64 {
    let i = json.find(&format!("\"{key}\":")).unwrap() + key.len() + 3;
    json[i..]
        .chars()
        .take_while(|c| c.is_ascii_digit())
        .collect::<String>()
        .parse()
        .unwrap()
}

/// The string after `"key":` in a JSON text (with `\"` and `\u0026` undone).
fn json_string(json: &str, key: &str) -> String {
    let i = json.find(&format!("\"{key}\":\"")).unwrap() + key.len() + 4;
    let mut out = String::new();
    let mut chars = json[i..].chars();
    while let Some(c) = chars.next() {
        match c {
            '"' => break,
            '\\' => match chars.next() {
                Some('u') => {
                    let h: String = chars.by_ref().take(4).collect();
                    out.push(char::from_u32(u32::from_str_radix(&h, 16).unwrap()).unwrap());
                }
                Some(c) => out.push(c),
                None => break,
            },
            c => out.push(c),
        }
    }
    out
}

/// Whether the kernel lists `port` as listening on 127.0.0.1 and on no other address.
fn listens_on_loopback_only(port: u16) -> bool {
    let tcp = std::fs::read_to_string("/proc/net/tcp").unwrap_or_default();
    let tcp6 = std::fs::read_to_string("/proc/net/tcp6").unwrap_or_default();
    let suffix = format!(":{port:04X}");
    let listening: Vec<String> = tcp
        .lines()
        .chain(tcp6.lines())
        .filter_map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            (f.len() > 3 && f[1].ends_with(&suffix) && f[3] == "0A").then(|| f[1].to_string())
        })
        .collect();
    !listening.is_empty() && listening.iter().all(|a| a == &format!("0100007F{suffix}"))
}

/// Runs a save's `command` again in `dir` with its output renamed `again`, and checks that it
/// writes the saved file bit for bit (every channel); returns the saved file's path.
pub(crate) fn rerun_saved(dir: &Path, command: &str, again: &str) -> std::path::PathBuf {
    let mut args = words(command);
    assert_eq!(args[0], "ftpd3d", "{command}");
    let o = args.iter().position(|a| a == "-o").unwrap();
    let saved = dir.join(&args[o + 1]);
    assert!(saved.is_file(), "{}", saved.display());
    args[o + 1] = again.into();
    let r = Command::new(env!("CARGO_BIN_EXE_ftpd3d"))
        .current_dir(dir)
        .args(&args[1..])
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_same_channels(&saved, &dir.join(again));
    saved
}

/// Every part's channels of two EXR files: the same names and bit-identical samples.
pub(crate) fn assert_same_channels(a: &Path, b: &Path) {
    let (pa, pb) = (exr_parts(a), exr_parts(b));
    assert_eq!(pa.len(), pb.len(), "parts");
    for (la, lb) in pa.iter().zip(&pb) {
        let (ca, cb) = (&la.channel_data.list, &lb.channel_data.list);
        let names = |c: &[exr::prelude::AnyChannel<exr::prelude::FlatSamples>]| {
            c.iter().map(|c| c.name.to_string()).collect::<Vec<_>>()
        };
        assert_eq!(names(ca), names(cb));
        for (x, y) in ca.iter().zip(cb.iter()) {
            use exr::prelude::FlatSamples::*;
            let same = match (&x.sample_data, &y.sample_data) {
                (F32(u), F32(v)) => u
                    .iter()
                    .map(|f| f.to_bits())
                    .eq(v.iter().map(|f| f.to_bits())),
                (U32(u), U32(v)) => u == v,
                (F16(u), F16(v)) => u
                    .iter()
                    .map(|f| f.to_bits())
                    .eq(v.iter().map(|f| f.to_bits())),
                _ => false,
            };
            assert!(same, "channel {} differs", x.name);
        }
    }
}

/// Splits a command line as the view prints it (words, single quotes) into its arguments.
pub(crate) fn words(command: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut any = false;
    for c in command.chars() {
        match c {
            '\'' => {
                quoted = !quoted;
                any = true;
            }
            ' ' if !quoted => {
                if any {
                    out.push(std::mem::take(&mut cur));
                }
                any = false;
            }
            c => {
                cur.push(c);
                any = true;
            }
        }
    }
    if any {
        out.push(cur);
    }
    out
}

fn sigterm(child: &Child) {
    let r = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(r.success());
}

/// Waits up to `limit` for the child to exit.
fn exits_within(child: &mut Child, limit: Duration) -> bool {
    let t = Instant::now();
    while t.elapsed() < limit {
        if child.try_wait().unwrap().is_some() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}

/// A doc's `ftpd3d view …` command (tests/docs_commands.rs), run as shown with a tiny budget: it
/// prints its URL, serves the token holder the page and a PNG of the field once a run has stopped,
/// and ends within 5 s of SIGTERM.
pub(crate) fn doc_command_serves_and_stops(dir: &Path, args: &[&str]) -> Result<(), String> {
    let mut v = start(dir, args);
    let (c, page) = v.get("/");
    if c != 200 || !String::from_utf8_lossy(&page).contains("<html") {
        return Err(format!("the page at {} answered {c}", v.url));
    }
    v.wait_stopped();
    let (c, png) = v.get("/image.png?channel=ftpd");
    if c != 200 || !png.starts_with(b"\x89PNG\r\n\x1a\n") {
        return Err(format!("image.png answered {c}, not a PNG"));
    }
    sigterm(&v.child);
    if !exits_within(&mut v.child, Duration::from_secs(5)) {
        return Err("still serving 5 s after SIGTERM".into());
    }
    Ok(())
}

#[test]
fn serves_token_holders_the_field_and_saves_what_the_command_line_writes() {
    let dir = temp_dir("view", "serves");
    let scene = scene_path("cornell_mirror.obj");
    let mut v = start(
        &dir,
        &[
            "--scene",
            scene.to_str().unwrap(),
            "--slice",
            "z=-0.5",
            "--res",
            "12",
            "--spp",
            "8",
            "--batches",
            "4",
            "--threads",
            "2",
        ],
    );
    assert!(v.url.contains("slice=z%3D-0.5"), "{}", v.url);
    assert!(
        listens_on_loopback_only(v.port),
        "port {} listens elsewhere",
        v.port
    );

    // Without the token, with a wrong one, or for another Host: refused.
    let no_token = request(v.port, "GET", "/image.png", &[]);
    assert_eq!(no_token.0, 403);
    assert_eq!(request(v.port, "GET", "/?token=00", &[]).0, 403);
    let wrong_host = format!("/status?token={}", v.token);
    let mut s = TcpStream::connect(("127.0.0.1", v.port)).unwrap();
    write!(
        s,
        "GET {wrong_host} HTTP/1.0\r\nHost: attacker.example:80\r\n\r\n"
    )
    .unwrap();
    let mut reply = String::new();
    s.read_to_string(&mut reply).unwrap();
    assert!(
        reply.starts_with("HTTP/1.0 403") || reply.starts_with("HTTP/1.1 403"),
        "{reply}"
    );
    // A state change from another page is refused; the page itself is served.
    let evil = request(
        v.port,
        "POST",
        &v.with_token("/state?slice=z%3D0"),
        &["Origin: http://evil.example"],
    );
    assert_eq!(evil.0, 403);
    let (c, page) = v.get("/");
    assert!(c == 200 && String::from_utf8_lossy(&page).contains("<img id=\"pic\""));

    // The picture follows the slice, and a slice shown again is the same picture, bit for bit.
    let low = v.picture_of("slice=z%3D-0.5");
    let high = v.picture_of("slice=z%3D0.5");
    assert_ne!(low, high, "two slice positions, one picture");
    assert_eq!(
        v.picture_of("slice=z%3D-0.5"),
        low,
        "same state, same picture"
    );
    let other = v.get("/image.png?channel=grad");
    assert_eq!(other.0, 200);
    assert_ne!(other.1, low, "the gradient view is another picture");

    // A bad value is the command line's error, shown in the status.
    let (c, _) = v.post("/state?res=0");
    assert_eq!(c, 200);
    let s = v.wait_stopped();
    assert!(s.contains("--res 0"), "{s}");
    assert_eq!(v.post("/state?output=%2Fetc%2Fx").0, 400);

    // Save: what the printed command writes, bit for bit.
    v.picture_of("slice=z%3D0.5&res=12");
    let (c, saved) = v.post("/save");
    assert_eq!(c, 200, "{saved}");
    assert!(saved.contains("\"exact\":true"), "{saved}");
    let command = json_string(&saved, "command");
    rerun_saved(&dir, &command, "again.exr");

    // SIGTERM ends it within 5 s.
    sigterm(&v.child);
    assert!(
        exits_within(&mut v.child, Duration::from_secs(5)),
        "still running 5 s after SIGTERM"
    );
}

/// A save in the middle of an adaptive run (the default budget) is what the command line writes
/// for the same passes.
#[test]
fn adaptive_save_at_a_pass_boundary_is_the_commands_output() {
    let dir = temp_dir("view", "adaptive");
    let scene = scene_path("cornell_mirror.obj");
    let v = start(
        &dir,
        &[
            "--scene",
            scene.to_str().unwrap(),
            "--slice",
            "z=0",
            "--res",
            "10",
            "--pass-spp",
            "2",
            "--threads",
            "2",
        ],
    );
    let t = Instant::now();
    while passes(&v.status()) < 4 {
        assert!(t.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(20));
    }
    let (c, saved) = v.post("/save");
    assert_eq!(c, 200, "{saved}");
    let command = json_string(&saved, "command");
    assert!(command.contains("--adaptive"), "{command}");
    assert!(saved.contains("\"exact\":true"), "{saved}");
    rerun_saved(&dir, &command, "again.exr");
}

/// The scene file's lights are state like any flag: the status names them, a URL switches one off
/// (`light-scale=light%3D0`), which changes the picture, and a save's command carries it and
/// writes the same file bit for bit.
#[test]
fn a_scene_light_switched_off_from_the_url_is_saved_as_its_command() {
    let dir = temp_dir("view", "lights");
    let scene = scene_path("cornell_mirror.obj");
    let v = start(
        &dir,
        &[
            "--scene",
            scene.to_str().unwrap(),
            "--slice",
            "z=0",
            "--res",
            "12",
            "--spp",
            "8",
            "--batches",
            "2",
            "--threads",
            "2",
            "--point-light",
            "0.3,0.5,0.2:3,3,3",
        ],
    );
    let both = v.picture_of("slice=z%3D0");
    let status = v.status();
    assert!(
        status.contains(r#""lights":[{"name":"light","kind":"emissive material","scale":1}]"#),
        "{status}"
    );
    let off = v.picture_of("light-scale=light%3D0");
    assert_ne!(both, off, "switching the scene's lamp off changed nothing");
    let status = v.status();
    assert!(status.contains(r#""scale":0"#), "{status}");
    assert!(status.contains("light-scale=light%3D0"), "{status}");
    let (c, saved) = v.post("/save");
    assert_eq!(c, 200, "{saved}");
    let command = json_string(&saved, "command");
    assert!(command.contains("--light-scale light=0"), "{command}");
    rerun_saved(&dir, &command, "again.exr");
    // A name the scene lacks is the command line's error, on the page.
    let (c, _) = v.post("/state?light-scale=bulb%3D0");
    assert_eq!(c, 200);
    let s = v.wait_stopped();
    assert!(s.contains("no light named") && s.contains("bulb"), "{s}");
}

/// The passes of the status's last picture (0 before the first).
fn passes(status: &str) -> u64 {
    if status.contains("\"passes\":") {
        json_number(status, "passes")
    } else {
        0
    }
}

/// The Chromium binary: `$CHROMIUM`, else `chromium` or `chromium-browser` on the PATH.
fn chromium() -> Result<String, String> {
    let names = match std::env::var("CHROMIUM") {
        Ok(c) => vec![c],
        Err(_) => vec!["chromium".into(), "chromium-browser".into()],
    };
    for n in &names {
        if Command::new(n)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
        {
            return Ok(n.clone());
        }
    }
    Err(format!("no Chromium ({}) runs here", names.join(", ")))
}

/// Headless Chromium's screenshot of `url` after 10 s of the page's time: its RGB pixels and
/// width.
fn screenshot(browser: &str, url: &str, dir: &Path, name: &str) -> (Vec<u8>, usize) {
    let path = dir.join(name);
    let profile = dir.join(format!("profile-{name}"));
    let out = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--no-first-run",
            &format!("--user-data-dir={}", profile.display()),
            &format!("--screenshot={}", path.display()),
            "--window-size=1000,760",
            "--virtual-time-budget=10000",
            url,
        ])
        .output()
        .unwrap();
    assert!(
        path.is_file(),
        "no screenshot: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let decoder = png::Decoder::new(BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    let rgb: Vec<u8> = buf[..info.buffer_size()]
        .chunks(channels)
        .flat_map(|p| p[..3].to_vec())
        .collect();
    (rgb, info.width as usize)
}

/// The picture's part of a screenshot (inside the 512-pixel image at the page's top left).
fn picture_region(rgb: &[u8], width: usize) -> Vec<[u8; 3]> {
    let mut out = Vec::new();
    for y in 40..480 {
        for x in 40..480 {
            let i = 3 * (y * width + x);
            out.push([rgb[i], rgb[i + 1], rgb[i + 2]]);
        }
    }
    out
}

/// The steering check in a real browser: the URL with a slice added shows a picture of the
/// field (not blank: many colours), and two slice positions show different pictures.
#[test]
fn headless_chromium_shows_the_field_and_follows_the_slice() {
    let browser = chromium();
    if skip_without(
        "view::headless_chromium",
        browser.as_ref().err().cloned(),
        in_ci(),
    ) {
        return;
    }
    let browser = browser.unwrap();
    let dir = temp_dir("view", "chromium");
    let scene = scene_path("cornell_mirror.obj");
    let v = start(
        &dir,
        &[
            "--scene",
            scene.to_str().unwrap(),
            "--slice",
            "z=0",
            "--res",
            "32",
            "--spp",
            "8",
            "--batches",
            "2",
            "--threads",
            "2",
        ],
    );
    let mut pictures = Vec::new();
    for (k, z) in ["-0.5", "0.5"].iter().enumerate() {
        let url = format!("{}&slice=z%3D{z}", v.url);
        let (rgb, width) = screenshot(&browser, &url, &dir, &format!("shot{k}.png"));
        let region = picture_region(&rgb, width);
        let mut colours = region.clone();
        colours.sort();
        colours.dedup();
        assert!(
            colours.len() > 20,
            "slice z={z}: the picture is blank ({} colours)",
            colours.len()
        );
        pictures.push(region);
    }
    assert_ne!(pictures[0], pictures[1], "two slice positions, one picture");
}
