//! A peer that floods the master with small malformed frames must not grow the master's memory:
//! the link threads hold a bounded number of events, and a reader that finds the queue full
//! stops reading its link. Before, a flood grew a listening master to 6.1 GB in 25 s.

use crate::support::*;
use std::io::{Read as _, Write as _};
use std::net::TcpListener;
use std::thread;

/// A peer on a loopback port that answers the master's `Hello` with an endless stream of tiny
/// frames that fail their check.
fn start_flood() -> Result<String, Box<dyn std::error::Error>> {
    let listener = TcpListener::bind("127.0.0.1:0")?;
    let address = listener.local_addr()?.to_string();
    thread::spawn(move || {
        let Ok((mut stream, _)) = listener.accept() else {
            return;
        };
        let mut hello = [0u8; 64];
        let _ = stream.read(&mut hello);
        // `00 01 01 00`: a delimiter, a one-byte frame that cannot pass its CRC, a delimiter.
        let burst: Vec<u8> = [0u8, 1, 1].repeat(1 << 14);
        while stream.write_all(&burst).is_ok() {}
    });
    Ok(address)
}

#[test]
fn a_flood_of_bad_frames_does_not_grow_the_master() -> TestResult {
    let flood = start_flood()?;
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let stats = dir.path().join("stats.json");
    let stats_arg = stats.display().to_string();
    let r = render(
        LARGE,
        &out,
        &[
            "--workers",
            "1",
            "--worker",
            &flood,
            "--stats-json",
            &stats_arg,
            "-q",
        ],
    )?;
    r.assert_success();
    assert_reference_image(&out, LARGE)?;
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&stats)?)?;
    let peak = json["peak_memory_bytes"].as_u64().ok_or("no peak memory")?;
    // The render itself needs some 30 MiB; a queue that grows takes hundreds within seconds.
    assert!(peak < 200 << 20, "peak memory {} MiB", peak >> 20);
    Ok(())
}
