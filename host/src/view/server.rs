//! The view's HTTP server, on `tiny_http`: the page and its script (built into the binary),
//! the server-sent events of a [`Hub`], the finished image, and for `strahl view` the
//! Start/Stop/Resume requests handed to a [`Control`].
//!
//! `tiny_http` was chosen over axum: it is synchronous like the rest of the master (threads and
//! channels, no async runtime to add), small, and gives the raw response stream that
//! server-sent events need. Requests other than `/events` are answered on the server thread
//! (each is a copy of a few kilobytes); each page's event stream has a thread of its own, at
//! most [`super::hub::MAX_VIEWERS`].

use super::events::Settings;
use super::hub::Hub;
use super::page;
use crate::util::secret::{check_exposure, random_nonce};
use anyhow::{anyhow, Context as _};
use std::io::{Read as _, Write};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::mpsc::RecvTimeoutError;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;
use tiny_http::{Header, Method, Request, Response, Server};

/// The largest request body taken (a settings form is a few hundred bytes).
pub const MAX_BODY: usize = 64 * 1024;

/// How often an idle event stream sends a comment, so that a closed page is noticed.
pub const KEEP_ALIVE: Duration = Duration::from_secs(10);

/// What the page's buttons do (`strahl view`).
pub trait Control: Send + Sync {
    /// Starts a render with `settings`, stopping one that runs.
    ///
    /// # Errors
    /// Settings that cannot be used, in words.
    fn start(&self, settings: Settings) -> Result<(), String>;
    /// Stops the render that runs, keeping its finished lines.
    ///
    /// # Errors
    /// No render runs.
    fn stop(&self) -> Result<(), String>;
    /// Goes on with the stopped render.
    ///
    /// # Errors
    /// No stopped render to go on with.
    fn resume(&self) -> Result<(), String>;
}

/// Where `--view` serves when no address is given.
pub const DEFAULT_VIEW: &str = "127.0.0.1:7420";

/// Parses a view address as users type it: `PORT` (this machine only), `HOST:PORT` or
/// `[IPv6]:PORT`; a host name is looked up and its first address taken.
///
/// # Errors
/// Text that is none of these, with an example.
pub fn view_address(text: &str) -> anyhow::Result<SocketAddr> {
    use std::net::ToSocketAddrs as _;
    let example = "for example 7420, 127.0.0.1:7420, localhost:0 or [::1]:7420";
    if let Ok(port) = text.parse::<u16>() {
        return Ok(SocketAddr::from(([127, 0, 0, 1], port)));
    }
    let mut found = text
        .to_socket_addrs()
        .map_err(|e| anyhow!("--view {text}: expected PORT or HOST:PORT ({example}): {e}"))?;
    found
        .next()
        .ok_or_else(|| anyhow!("--view {text}: the name has no address ({example})"))
}

/// A running view server; dropping it stops the server.
pub struct ViewServer {
    server: Arc<Server>,
    thread: Option<JoinHandle<()>>,
    /// The page's address, with its key when one is needed.
    pub url: String,
}

/// Who may use the view, and what it serves.
struct Site {
    hub: Arc<Hub>,
    control: Option<Arc<dyn Control>>,
    /// The key a request must carry (`?key=` or the cookie), when the view is not on loopback.
    key: Option<String>,
}

impl ViewServer {
    /// Serves `hub` at `address` (`HOST:PORT`; port 0 picks one). Beyond loopback it needs a
    /// secret (then every request must carry a fresh random key, printed in the URL) or
    /// `insecure`.
    ///
    /// # Errors
    /// An address that cannot be parsed or bound, or a non-loopback one without a secret or
    /// `insecure`.
    pub fn start(
        address: &str,
        hub: Arc<Hub>,
        control: Option<Arc<dyn Control>>,
        secret: bool,
        insecure: bool,
    ) -> anyhow::Result<ViewServer> {
        let addr = view_address(address)?;
        check_exposure(&addr.to_string(), secret, insecure, "the view")
            .map_err(|e| anyhow!("{}", e.to_string().replacen("--listen", "--view", 1)))?;
        let server = Server::http(addr)
            .map_err(|e| anyhow!("--view {address}: cannot listen there: {e}"))?;
        let bound = server
            .server_addr()
            .to_ip()
            .context("the view's server has no IP address")?;
        let key = (secret && !addr.ip().is_loopback()).then(|| {
            random_nonce()[..16]
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect::<String>()
        });
        let url = match &key {
            Some(k) => format!("http://{bound}/?key={k}"),
            None => format!("http://{bound}/"),
        };
        let server = Arc::new(server);
        let site = Arc::new(Site { hub, control, key });
        let s = Arc::clone(&server);
        let thread = std::thread::Builder::new()
            .name("view".into())
            .spawn(move || serve(&s, &site))
            .context("cannot start the view's server thread")?;
        Ok(ViewServer {
            server,
            thread: Some(thread),
            url,
        })
    }
}

impl Drop for ViewServer {
    fn drop(&mut self) {
        self.server.unblock();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Answers requests until the server is unblocked.
fn serve(server: &Server, site: &Arc<Site>) {
    while let Ok(request) = server.recv() {
        let (path, query) = match request.url().split_once('?') {
            Some((p, q)) => (p.to_string(), q.to_string()),
            None => (request.url().to_string(), String::new()),
        };
        if !site.allows(&request, &query) {
            respond_text(
                request,
                403,
                "this view needs its key: open the URL strahl printed",
            );
            continue;
        }
        if path == "/events" && *request.method() == Method::Get {
            let site = Arc::clone(site);
            let spawned = std::thread::Builder::new()
                .name("view-events".into())
                .spawn(move || stream_events(request, &site.hub));
            // (No thread: the request is dropped, and the page retries.)
            drop(spawned);
            continue;
        }
        route(request, &path, site);
    }
}

impl Site {
    /// Whether `request` carries the key (in `query` or its cookie), when one is needed.
    fn allows(&self, request: &Request, query: &str) -> bool {
        let Some(key) = &self.key else {
            return true;
        };
        let in_query = query
            .split('&')
            .filter_map(|kv| kv.strip_prefix("key="))
            .any(|k| same(k, key));
        let in_cookie = request
            .headers()
            .iter()
            .filter(|h| h.field.equiv("Cookie"))
            .flat_map(|h| h.value.as_str().split(';'))
            .filter_map(|c| c.trim().strip_prefix("strahl_view="))
            .any(|k| same(k, key));
        in_query || in_cookie
    }
}

/// Compares two keys in time that does not depend on where they differ.
fn same(a: &str, b: &str) -> bool {
    a.len() == b.len()
        && a.bytes()
            .zip(b.bytes())
            .fold(0u8, |acc, (x, y)| acc | (x ^ y))
            == 0
}

/// Answers every request but the event stream.
fn route(mut request: Request, path: &str, site: &Site) {
    let method = request.method().clone();
    match (path, &method) {
        ("/", Method::Get) => respond_page(request, site),
        ("/view.js", Method::Get) => {
            respond_bytes(request, 200, "text/javascript", page::SCRIPT.as_bytes())
        }
        ("/view.css", Method::Get) => {
            respond_bytes(request, 200, "text/css", page::STYLE.as_bytes())
        }
        ("/image", Method::Get) => respond_image(request, site),
        ("/api/start" | "/api/stop" | "/api/resume", Method::Post) => {
            let body = match read_body(&mut request) {
                Ok(b) => b,
                Err((code, msg)) => return respond_text(request, code, &msg),
            };
            let (code, msg) = control(site, path, &body);
            respond_text(request, code, &msg);
        }
        ("/" | "/view.js" | "/view.css" | "/image" | "/events", _) => {
            respond_text(request, 405, &format!("{path} takes GET only"));
        }
        ("/api/start" | "/api/stop" | "/api/resume", _) => {
            respond_text(request, 405, &format!("{path} takes POST only"));
        }
        _ => respond_text(
            request,
            404,
            &format!("{path}: no such page; the view is at /"),
        ),
    }
}

/// The page; with a key in the URL, also the cookie that carries it to the page's requests.
fn respond_page(request: Request, site: &Site) {
    let mut response = Response::from_data(page::HTML.as_bytes().to_vec())
        .with_header(header("Content-Type", "text/html; charset=utf-8"))
        .with_header(header("Cache-Control", "no-store"));
    if let Some(key) = &site.key {
        response = response.with_header(header(
            "Set-Cookie",
            &format!("strahl_view={key}; HttpOnly; SameSite=Strict; Path=/"),
        ));
    }
    let _ = request.respond(response);
}

/// The finished image file, for download.
fn respond_image(request: Request, site: &Site) {
    let super::events::Status::Done { output } = site.hub.status() else {
        return respond_text(request, 409, "the image is not finished yet");
    };
    let path = PathBuf::from(&output);
    match std::fs::read(&path) {
        Ok(bytes) => {
            let name: String = path
                .file_name()
                .map_or("image".into(), |n| n.to_string_lossy().into_owned())
                .chars()
                .map(|c| {
                    if c.is_ascii_graphic() && c != '"' && c != '\\' {
                        c
                    } else {
                        '_'
                    }
                })
                .collect();
            let kind = match path.extension().and_then(|e| e.to_str()) {
                Some(e) if e.eq_ignore_ascii_case("png") => "image/png",
                _ => "image/bmp",
            };
            let response = Response::from_data(bytes)
                .with_header(header("Content-Type", kind))
                .with_header(header(
                    "Content-Disposition",
                    &format!("attachment; filename=\"{name}\""),
                ));
            let _ = request.respond(response);
        }
        Err(e) => respond_text(
            request,
            500,
            &format!("{output}: cannot read the image: {e}"),
        ),
    }
}

/// Hands a button's request to the control; the HTTP status and message to answer.
fn control(site: &Site, path: &str, body: &[u8]) -> (u16, String) {
    let Some(control) = &site.control else {
        return (
            409,
            "this render was started from the command line; start renders from the page with `strahl view`"
                .into(),
        );
    };
    let (done, refused) = match path {
        "/api/start" => match serde_json::from_slice::<Settings>(body) {
            // Settings that cannot be used are the request's fault.
            Ok(settings) => (control.start(settings), 400),
            Err(e) => return (400, format!("the settings are not valid: {e}")),
        },
        "/api/stop" => (control.stop(), 409),
        _ => (control.resume(), 409),
    };
    match done {
        Ok(()) => (200, "ok".into()),
        Err(e) => (refused, e),
    }
}

/// The request's body, at most [`MAX_BODY`] bytes; else the status and message to answer.
fn read_body(request: &mut Request) -> Result<Vec<u8>, (u16, String)> {
    if request.body_length().is_some_and(|n| n > MAX_BODY) {
        return Err((413, format!("a request body is at most {MAX_BODY} bytes")));
    }
    let mut body = Vec::new();
    request
        .as_reader()
        .take(MAX_BODY as u64 + 1)
        .read_to_end(&mut body)
        .map_err(|e| (400, format!("cannot read the request body: {e}")))?;
    if body.len() > MAX_BODY {
        return Err((413, format!("a request body is at most {MAX_BODY} bytes")));
    }
    Ok(body)
}

/// A page's event stream: the state now, then every change, until the page goes or falls
/// behind.
fn stream_events(request: Request, hub: &Hub) {
    let Some((snapshot, changes)) = hub.subscribe() else {
        return respond_text(request, 503, "too many pages watch this render; close one");
    };
    let mut out = request.into_writer();
    let head = "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\n\
                Connection: close\r\n\r\nretry: 1000\n\n";
    if out.write_all(head.as_bytes()).is_err() {
        return;
    }
    if snapshot
        .iter()
        .any(|e| out.write_all(e.as_bytes()).is_err())
        || out.flush().is_err()
    {
        return;
    }
    loop {
        let event = match changes.recv_timeout(KEEP_ALIVE) {
            Ok(e) => e,
            Err(RecvTimeoutError::Timeout) => Arc::from(": keep-alive\n\n"),
            // Dropped by the hub (fell behind): the page reconnects and starts afresh.
            Err(RecvTimeoutError::Disconnected) => return,
        };
        if out.write_all(event.as_bytes()).is_err() {
            return;
        }
        // Whatever else is queued goes out with it.
        while let Ok(more) = changes.try_recv() {
            if out.write_all(more.as_bytes()).is_err() {
                return;
            }
        }
        if out.flush().is_err() {
            return;
        }
    }
}

fn header(name: &str, value: &str) -> Header {
    // Names and values here are ASCII without line breaks.
    Header::from_bytes(name.as_bytes(), value.as_bytes())
        .unwrap_or_else(|()| unreachable!("a plain ASCII header"))
}

fn respond_bytes(request: Request, code: u16, kind: &str, body: &[u8]) {
    let response = Response::from_data(body.to_vec())
        .with_status_code(code)
        .with_header(header("Content-Type", kind));
    let _ = request.respond(response);
}

fn respond_text(request: Request, code: u16, text: &str) {
    respond_bytes(
        request,
        code,
        "text/plain; charset=utf-8",
        format!("{text}\n").as_bytes(),
    );
}
