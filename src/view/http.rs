//! The view's HTTP requests: every one must carry the token and name this server as its Host
//! (another local user, or a web page in the same browser, can neither drive the tool nor read
//! the scene); a state-changing one (POST) from a browser must also come from the page's own
//! Origin.
//!
//! - `GET /?token=T&…`: the page (a static file); it reads its state from its own URL.
//! - `GET /status?token=T`: the run's status (JSON).
//! - `GET /image.png?token=T&channel=C&g=N`: the picture of the last complete pass, waiting (up to
//!   10 s) for one of generation `N` or later.
//! - `POST /state?token=T&<run flags>`: makes the URL's state current (JSON: its generation).
//! - `POST /save?token=T`: writes the last complete pass as the command line would (JSON: files
//!   and the command line).

use super::picture::{self, json_str};
use super::session::Shared;
use crate::cli::view::{Pair, merge_state, state_query};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tiny_http::{Header, Method, Request, Response};

/// What every request is checked against.
pub struct Gate {
    pub token: String,
    pub port: u16,
    /// The run flags the view started with, which a URL's are laid over.
    pub base: Vec<Pair>,
}

/// A response: status, content type, body.
type Reply = (u16, &'static str, Vec<u8>);

/// Answers `req`.
pub fn handle(req: Request, shared: &Arc<Shared>, gate: &Gate) {
    let reply = answer(&req, shared, gate);
    let (code, kind, body) = reply;
    let mut resp = Response::from_data(body).with_status_code(code);
    for (k, v) in [
        ("Content-Type", kind),
        ("Cache-Control", "no-store"),
        ("X-Content-Type-Options", "nosniff"),
        ("Referrer-Policy", "no-referrer"),
    ] {
        if let Ok(h) = Header::from_bytes(k.as_bytes(), v.as_bytes()) {
            resp.add_header(h);
        }
    }
    let _ = req.respond(resp);
}

fn text(code: u16, s: impl Into<String>) -> Reply {
    (code, "text/plain; charset=utf-8", s.into().into_bytes())
}

fn json(code: u16, s: String) -> Reply {
    (code, "application/json", s.into_bytes())
}

fn header<'a>(req: &'a Request, name: &'static str) -> Option<&'a str> {
    req.headers()
        .iter()
        .find(|h| h.field.equiv(name))
        .map(|h| h.value.as_str())
}

/// Why `req` is refused, if it is: no or a wrong token, another Host, or (state-changing
/// requests) another Origin or a cross-site fetch.
fn refused(req: &Request, pairs: &[Pair], gate: &Gate) -> Option<Reply> {
    let hosts = [
        format!("127.0.0.1:{}", gate.port),
        format!("localhost:{}", gate.port),
    ];
    if !header(req, "Host").is_some_and(|h| hosts.iter().any(|o| o == h)) {
        return Some(text(403, "this server answers to 127.0.0.1 only"));
    }
    let token = pairs.iter().find(|(k, _)| k == "token").map(|(_, v)| v);
    if token.is_none_or(|t| !same(t.as_bytes(), gate.token.as_bytes())) {
        return Some(text(
            403,
            "a token is required: use the URL the view printed",
        ));
    }
    if *req.method() != Method::Get {
        let origin_ok =
            header(req, "Origin").is_none_or(|o| hosts.iter().any(|h| o == format!("http://{h}")));
        let site_ok = header(req, "Sec-Fetch-Site").is_none_or(|s| s == "same-origin");
        if !(origin_ok && site_ok) {
            return Some(text(
                403,
                "state changes are accepted from the view's page only",
            ));
        }
    }
    None
}

/// Byte strings compared in time independent of where they differ.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |d, (x, y)| d | (x ^ y)) == 0
}

fn answer(req: &Request, shared: &Arc<Shared>, gate: &Gate) -> Reply {
    let (path, query) = req.url().split_once('?').unwrap_or((req.url(), ""));
    let pairs = parse_query(query);
    if let Some(r) = refused(req, &pairs, gate) {
        return r;
    }
    let value = |k: &str| {
        pairs
            .iter()
            .rev()
            .find(|(p, _)| p == k)
            .map(|(_, v)| v.as_str())
    };
    match (req.method(), path) {
        (Method::Get, "/") => (
            200,
            "text/html; charset=utf-8",
            include_str!("page.html").as_bytes().to_vec(),
        ),
        (Method::Get, "/status") => {
            let g = shared.lock();
            json(200, picture::status(shared, &g))
        }
        (Method::Get, "/image.png") => {
            let channel = value("channel").unwrap_or("ftpd");
            let want = value("g").and_then(|g| g.parse().ok()).unwrap_or(0);
            image(shared, channel, want)
        }
        (Method::Post, "/state") => {
            let url: Vec<Pair> = pairs
                .iter()
                .filter(|(k, _)| k != "token" && k != "channel")
                .cloned()
                .collect();
            match merge_state(&gate.base, &url) {
                Ok(state) => {
                    let query = state_query(&state);
                    let generation = shared.set_state(state);
                    json(
                        200,
                        format!(
                            "{{\"generation\":{generation},\"state\":{}}}",
                            json_str(&query)
                        ),
                    )
                }
                Err(e) => text(400, e),
            }
        }
        (Method::Post, "/save") => save(shared),
        _ => text(404, "no such page"),
    }
}

/// The picture of the last complete pass of generation `want` or later, waiting up to 10 s for
/// one (a page's first picture, and a headless browser's, come as soon as the first pass ends).
fn image(shared: &Shared, channel: &str, want: u64) -> Reply {
    let t = Instant::now();
    loop {
        let snap = {
            let g = shared.lock();
            match &g.snapshot {
                Some(s) if s.generation >= want => Some(s.clone()),
                _ if g.error.is_some() => return text(409, g.error.clone().unwrap_or_default()),
                _ => None,
            }
        };
        if let Some(s) = snap {
            return match picture::picture(&s, channel) {
                Ok(png) => (200, "image/png", png),
                Err(e) => text(400, format!("{e:#}")),
            };
        }
        if t.elapsed() > Duration::from_secs(10) {
            return text(503, "no complete pass yet");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Saves the last complete pass of the current state.
fn save(shared: &Shared) -> Reply {
    let snap = {
        let g = shared.lock();
        match &g.snapshot {
            Some(s) if s.generation == g.generation => s.clone(),
            _ => {
                return text(
                    409,
                    "no complete pass of this view yet: save after the first",
                );
            }
        }
    };
    match picture::save(shared, &snap) {
        Ok(saved) => {
            let files: Vec<String> = saved.files.iter().map(|f| json_str(f)).collect();
            json(
                200,
                format!(
                    "{{\"files\":[{}],\"command\":{},\"exact\":{},\"passes\":{}}}",
                    files.join(","),
                    json_str(&saved.command),
                    saved.exact,
                    snap.progress.passes
                ),
            )
        }
        Err(e) => text(500, format!("{e:#}")),
    }
}

/// `a=1&b=x%3D2+y` as pairs, percent-decoded (`+` is a space, as forms and URLSearchParams write
/// it); a key without `=` has an empty value.
pub fn parse_query(q: &str) -> Vec<Pair> {
    q.split('&')
        .filter(|p| !p.is_empty())
        .map(|p| {
            let (k, v) = p.split_once('=').unwrap_or((p, ""));
            (decode(k), decode(v))
        })
        .collect()
}

fn decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        match b[i] {
            b'+' => out.push(b' '),
            b'%' if i + 2 < b.len() => match (hex(b[i + 1]), hex(b[i + 2])) {
                (Some(h), Some(l)) => {
                    out.push((h * 16 + l) as u8);
                    i += 2;
                }
                _ => out.push(b'%'),
            },
            c => out.push(c),
        }
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn queries_decode() {
        let q = parse_query(
            "token=ab&slice=z%3D-0.5&plane=origin%3D0,0,0+normal%3D1,0,0&uniform&x=%zz%4",
        );
        assert_eq!(q[1], ("slice".into(), "z=-0.5".into()));
        assert_eq!(q[2].1, "origin=0,0,0 normal=1,0,0");
        assert_eq!(q[3], ("uniform".into(), String::new()));
        assert_eq!(q[4].1, "%zz%4");
    }
}
