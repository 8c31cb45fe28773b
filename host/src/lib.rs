//! Strahl's host side: everything that needs an operating system.
//!
//! Modules (each helper adds its own `pub mod` line here):
pub mod bench;
pub mod cli;
pub mod cluster;
pub mod config;
pub mod convert;
pub mod datafile;
pub mod error;
pub mod executor;
pub mod fart;
pub mod generate;
pub mod hosts;
pub mod lines;
pub mod load;
pub mod mesh;
pub mod nff;
pub mod obj;
pub mod output;
pub mod progress;
pub mod summary;
pub mod worker;
