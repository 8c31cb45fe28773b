//! `cargo +nightly fuzz run worker_session`: see `tests/tests/fuzz_entry/mod.rs` for what it feeds.
#![no_main]

#[path = "../../tests/tests/fuzz_entry/mod.rs"]
mod fuzz_entry;

libfuzzer_sys::fuzz_target!(|data: &[u8]| fuzz_entry::worker_session(data));
