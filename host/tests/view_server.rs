//! The view's server and hub without a browser: what a page is sent (the state first, then
//! every change, nothing missed), the limits on pages, the key beyond loopback, and a clear
//! HTTP error for every bad request, with the render going on.

use base64::Engine as _;
use std::io::{BufRead as _, BufReader, Read as _, Write as _};
use std::net::TcpStream;
use std::sync::Arc;
use std::time::Duration;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;
use strahl_host::cluster::master::FinalLine;
use strahl_host::cluster::region::Region;
use strahl_host::view::events::{Settings, Status};
use strahl_host::view::hub::{Hub, Shown, MAX_VIEWERS, VIEWER_QUEUE};
use strahl_host::view::server::{view_address, Control, ViewServer};

type TestResult = Result<(), Box<dyn std::error::Error>>;

fn line(hub: &Hub, y: u32, width: usize, worker: Option<usize>) {
    let pixels = vec![Pixel::default(); width];
    hub.line(&FinalLine {
        y,
        rays: RayCounts {
            primary: width as u64,
            ..RayCounts::default()
        },
        pixels: &pixels,
        worker,
    });
}

/// The event names in `events`, in order.
fn names(events: &[Arc<str>]) -> Vec<String> {
    events
        .iter()
        .filter_map(|e| e.strip_prefix("event: "))
        .map(|e| e.lines().next().unwrap_or("").to_string())
        .collect()
}

#[test]
fn a_new_page_gets_the_state_then_every_change_once() {
    let hub = Hub::new();
    hub.begin(Shown::whole(4, 3));
    line(&hub, 0, 4, Some(1));
    line(&hub, 2, 4, None);
    let (snapshot, changes) = hub.subscribe().expect("room for a page");
    assert_eq!(
        names(&snapshot),
        ["begin", "line", "line", "workers", "progress", "status"]
    );
    assert!(snapshot[1].contains("\"y\":0") && snapshot[1].contains("\"worker\":1"));
    assert!(snapshot[4].contains("\"done\":2") && snapshot[4].contains("\"total\":3"));
    line(&hub, 1, 4, Some(0));
    hub.end(Status::Done {
        output: "x.bmp".into(),
    });
    let later: Vec<Arc<str>> = changes.try_iter().collect();
    let later: Vec<Arc<str>> = later.into_iter().filter(|e| !e.starts_with(':')).collect();
    assert_eq!(names(&later), ["line", "progress", "status"]);
    assert!(later[0].contains("\"y\":1"));
    assert!(later[1].contains("\"done\":3"));
    assert!(later[2].contains("\"state\":\"done\""));
    // A line outside the image is not taken.
    line(&hub, 3, 4, None);
    line(&hub, 0, 5, None);
    assert_eq!(
        changes.try_iter().filter(|e| !e.starts_with(':')).count(),
        0
    );
}

/// The JSON data of a server-sent event.
fn data(event: &str) -> serde_json::Value {
    let json = event.lines().find_map(|l| l.strip_prefix("data: "));
    serde_json::from_str(json.unwrap_or("null")).unwrap_or_default()
}

/// A line of `width` pixels whose red channel is the column, in the 8-bit value it becomes.
fn columns_line(hub: &Hub, y: u32, width: u32) {
    let pixels: Vec<Pixel> = (0..width).map(|x| Pixel([x as u16 * 257, 0, 0])).collect();
    hub.line(&FinalLine {
        y,
        rays: RayCounts::default(),
        pixels: &pixels,
        worker: Some(0),
    });
}

#[test]
fn with_a_region_the_pages_get_its_rectangle_and_progress_counts_the_lines_delivered() {
    // Columns 2..5 and lines 3..6 of a 8-wide image; the render delivers lines 0..10 (as with
    // adaptive multisampling).
    let rect = Region {
        x0: 2,
        y0: 3,
        x1: 5,
        y1: 6,
    };
    let hub = Hub::new();
    hub.begin(Shown::part(8, rect, 0..10));
    let (snapshot, changes) = hub.subscribe().expect("room for a page");
    assert_eq!(
        data(&snapshot[0]),
        serde_json::json!({"run": 1, "width": 3, "height": 3, "left": 2, "top": 3})
    );
    for y in [0, 4, 9, 5] {
        columns_line(&hub, y, 8);
    }
    // Lines outside the rectangle are counted, not sent; those inside carry its columns.
    let sent: Vec<serde_json::Value> = changes.try_iter().map(|e| data(&e)).collect();
    let ys: Vec<_> = sent.iter().map(|d| d["y"].clone()).collect();
    assert_eq!(ys, [4, 5], "{sent:?}");
    let rgb = base64::engine::general_purpose::STANDARD
        .decode(sent[0]["rgb"].as_str().unwrap_or_default())
        .unwrap_or_default();
    assert_eq!(rgb, [2, 0, 0, 3, 0, 0, 4, 0, 0]);
    // A new page is drawn the rectangle's lines alone, and the progress of all four.
    let (snapshot, _) = hub.subscribe().expect("room for a page");
    assert_eq!(
        names(&snapshot),
        ["begin", "line", "line", "workers", "progress", "status"]
    );
    let progress = data(&snapshot[4]);
    assert_eq!(
        (progress["done"].clone(), progress["total"].clone()),
        (4.into(), 10.into())
    );
    // Lines the render does not deliver, or of another width, are not taken.
    columns_line(&hub, 10, 8);
    columns_line(&hub, 4, 7);
    let (snapshot, _) = hub.subscribe().expect("room for a page");
    assert_eq!(data(&snapshot[4])["done"], 4);
}

#[test]
fn a_region_beyond_the_lines_delivered_is_cut_to_them() {
    let rect = Region {
        x0: 6,
        y0: 2,
        x1: 12,
        y1: 9,
    };
    let shown = Shown::part(8, rect, 4..6);
    assert_eq!(
        shown.rect,
        Region {
            x0: 6,
            y0: 4,
            x1: 8,
            y1: 6
        }
    );
    let hub = Hub::new();
    hub.begin(shown);
    columns_line(&hub, 5, 8);
    let (snapshot, _) = hub.subscribe().expect("room for a page");
    assert_eq!(names(&snapshot)[..2], ["begin", "line"]);
}

#[test]
fn a_page_that_falls_behind_is_dropped_and_the_others_stay() {
    let hub = Hub::new();
    hub.begin(Shown::whole(2, 1));
    let (_, slow) = hub.subscribe().expect("room");
    let (_, fast) = hub.subscribe().expect("room");
    // (Subscribing the second page sent the first a keep-alive.)
    for i in 0..VIEWER_QUEUE - 1 {
        line(&hub, 0, 2, Some(i % 3));
        // The fast page reads as it goes.
        let _ = fast.try_iter().count();
    }
    assert_eq!(hub.viewers(), 2);
    line(&hub, 0, 2, None);
    assert_eq!(hub.viewers(), 1, "the page with a full queue is dropped");
    drop(slow);
}

#[test]
fn pages_beyond_the_limit_are_refused() {
    let hub = Hub::new();
    let held: Vec<_> = (0..MAX_VIEWERS).map(|_| hub.subscribe()).collect();
    assert!(held.iter().all(Option::is_some));
    assert!(hub.subscribe().is_none());
    drop(held);
    assert!(hub.subscribe().is_some(), "closed pages free their places");
}

#[test]
fn view_addresses_as_users_type_them() -> TestResult {
    assert_eq!(view_address("7420")?.to_string(), "127.0.0.1:7420");
    assert_eq!(view_address("127.0.0.1:0")?.to_string(), "127.0.0.1:0");
    assert_eq!(view_address("[::1]:7420")?.to_string(), "[::1]:7420");
    assert!(view_address("localhost:7420")?.ip().is_loopback());
    let e = view_address("scene.nff").expect_err("not an address");
    assert!(e.to_string().contains("for example 7420"), "{e}");
    Ok(())
}

/// A plain HTTP request; the status code and body.
fn http(addr: &str, request: &str) -> Result<(u16, String), Box<dyn std::error::Error>> {
    let mut s = TcpStream::connect(addr)?;
    s.set_read_timeout(Some(Duration::from_secs(10)))?;
    s.write_all(request.as_bytes())?;
    let mut text = String::new();
    s.read_to_string(&mut text)?;
    let code = text.split_whitespace().nth(1).ok_or("no status")?.parse()?;
    let body = text
        .split_once("\r\n\r\n")
        .map_or("", |(_, b)| b)
        .to_string();
    Ok((code, body))
}

fn get(addr: &str, path: &str) -> Result<(u16, String), Box<dyn std::error::Error>> {
    http(
        addr,
        &format!("GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n"),
    )
}

fn post(addr: &str, path: &str, body: &str) -> Result<(u16, String), Box<dyn std::error::Error>> {
    http(
        addr,
        &format!(
            "POST {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
            body.len()
        ),
    )
}

fn host_of(url: &str) -> String {
    url.trim_start_matches("http://")
        .split('/')
        .next()
        .unwrap_or("")
        .to_string()
}

/// A control that takes every request and remembers the settings.
#[derive(Default)]
struct Recorder(std::sync::Mutex<Vec<Settings>>);

impl Control for Recorder {
    fn start(&self, settings: Settings) -> Result<(), String> {
        strahl_host::view::control::check(&settings)?;
        self.0.lock().map_err(|e| e.to_string())?.push(settings);
        Ok(())
    }
    fn stop(&self) -> Result<(), String> {
        Err("no render is running".into())
    }
    fn resume(&self) -> Result<(), String> {
        Err("there is no stopped render to resume".into())
    }
}

const GOOD: &str = r#"{"width":64,"height":48,"shadows":false,"reflections":true,"multisample":2,"aa_threshold":null,"max_depth":5,"ambient_occlusion":0,"workers":2,"tcp_workers":[]}"#;

#[test]
fn bad_requests_get_clear_http_errors() -> TestResult {
    let hub = Hub::new();
    let recorder = Arc::new(Recorder::default());
    let control: Arc<dyn Control> = recorder.clone();
    let server = ViewServer::start("127.0.0.1:0", hub.clone(), Some(control), false, false)?;
    let addr = host_of(&server.url);
    assert_eq!(get(&addr, "/")?.0, 200);
    assert_eq!(get(&addr, "/view.js")?.0, 200);
    let (code, body) = get(&addr, "/nothing")?;
    assert_eq!(
        (code, body.trim()),
        (404, "/nothing: no such page; the view is at /")
    );
    let (code, body) = post(&addr, "/", "")?;
    assert_eq!((code, body.trim()), (405, "/ takes GET only"));
    assert_eq!(get(&addr, "/api/start")?.0, 405);
    let (code, body) = get(&addr, "/image")?;
    assert_eq!((code, body.trim()), (409, "the image is not finished yet"));
    let (code, body) = post(&addr, "/api/start", "{not json")?;
    assert_eq!(code, 400);
    assert!(body.starts_with("the settings are not valid:"), "{body}");
    let (code, body) = post(
        &addr,
        "/api/start",
        &GOOD.replace("\"width\":64", "\"width\":0"),
    )?;
    assert_eq!((code, body.trim()), (400, "width must be 1 to 32768"));
    let (code, body) = post(
        &addr,
        "/api/start",
        &GOOD.replace("\"workers\":2", "\"workers\":0"),
    )?;
    assert_eq!(code, 400);
    assert!(body.contains("no workers"), "{body}");
    let (code, _) = post(&addr, "/api/start", &GOOD.replace("}", ",\"extra\":1}"))?;
    assert_eq!(code, 400, "unknown fields are refused");
    let big = format!("{}{}", GOOD, " ".repeat(70_000));
    let (code, _) = post(&addr, "/api/start", &big)?;
    assert_eq!(code, 413);
    let (code, body) = post(&addr, "/api/stop", "")?;
    assert_eq!((code, body.trim()), (409, "no render is running"));
    // Garbage on the socket does not stop the server.
    let _ = http(&addr, "\x00\x01garbage\r\n\r\n");
    assert_eq!(post(&addr, "/api/start", GOOD)?.0, 200);
    let taken = recorder.0.lock().map_err(|e| e.to_string())?.clone();
    assert_eq!(taken.len(), 1);
    assert!(!taken[0].shadows && taken[0].multisample == 2);
    Ok(())
}

#[test]
fn a_render_started_elsewhere_cannot_be_steered() -> TestResult {
    let server = ViewServer::start("127.0.0.1:0", Hub::new(), None, false, false)?;
    let (code, body) = post(&host_of(&server.url), "/api/start", GOOD)?;
    assert_eq!(code, 409);
    assert!(body.contains("strahl view"), "{body}");
    Ok(())
}

#[test]
fn beyond_loopback_the_view_needs_a_secret_and_then_its_key() -> TestResult {
    let refused = ViewServer::start("0.0.0.0:0", Hub::new(), None, false, false);
    let e = refused
        .err()
        .ok_or("served beyond loopback without a secret")?;
    assert!(e.to_string().contains("--view 0.0.0.0:0"), "{e}");
    let server = ViewServer::start("0.0.0.0:0", Hub::new(), None, true, false)?;
    let (_, key) = server.url.split_once("?key=").ok_or("no key in the URL")?;
    assert_eq!(key.len(), 32);
    let port = host_of(&server.url)
        .rsplit_once(':')
        .ok_or("no port")?
        .1
        .to_string();
    let addr = format!("127.0.0.1:{port}");
    let (code, body) = get(&addr, "/")?;
    assert_eq!(code, 403);
    assert!(body.contains("needs its key"), "{body}");
    assert_eq!(get(&addr, &format!("/?key={}", "0".repeat(32)))?.0, 403);
    assert_eq!(get(&addr, &format!("/?key={key}"))?.0, 200);
    let (code, _) = http(
        &addr,
        &format!("GET /events HTTP/1.1\r\nHost: x\r\nCookie: strahl_view={key}\r\nConnection: close\r\n\r\n")
            .replace("GET /events", "GET /view.css"),
    )?;
    assert_eq!(code, 200, "the cookie carries the key");
    Ok(())
}

#[test]
fn an_event_stream_sends_the_state_then_the_changes() -> TestResult {
    let hub = Hub::new();
    hub.begin(Shown::whole(3, 2));
    line(&hub, 1, 3, Some(0));
    let server = ViewServer::start("127.0.0.1:0", hub.clone(), None, false, false)?;
    let mut s = TcpStream::connect(host_of(&server.url))?;
    s.set_read_timeout(Some(Duration::from_secs(10)))?;
    s.write_all(b"GET /events HTTP/1.1\r\nHost: x\r\n\r\n")?;
    let mut reader = BufReader::new(s);
    let mut seen = Vec::new();
    let mut text = String::new();
    while !seen.iter().any(|e: &String| e == "status") {
        text.clear();
        reader.read_line(&mut text)?;
        if let Some(name) = text.strip_prefix("event: ") {
            seen.push(name.trim().to_string());
        }
    }
    assert_eq!(seen, ["begin", "line", "workers", "progress", "status"]);
    line(&hub, 0, 3, Some(1));
    loop {
        text.clear();
        reader.read_line(&mut text)?;
        if text.starts_with("event: ") {
            assert_eq!(text.trim(), "event: line");
            text.clear();
            reader.read_line(&mut text)?;
            assert!(text.contains("\"y\":0"), "{text}");
            break;
        }
    }
    Ok(())
}
