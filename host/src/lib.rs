//! Strahl's host side: everything that needs an operating system.
//!
//! Modules (each helper adds its own `pub mod` line here):
pub mod bench;
pub mod cli;
pub mod config;
pub mod datafile;
pub mod error;
pub mod generate;
pub mod lines;
pub mod load;
pub mod local;
pub mod output;
pub mod progress;
pub mod summary;
