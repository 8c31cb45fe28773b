//! Strahl's file formats (`strahl-formats`): every scene, mesh and hosts file the host reads,
//! and every file it writes in those formats, each format's reader and writer side by side in
//! one module. `strahl-host` re-exports this crate as `strahl_host::formats`.
//!
//! | module | format | reads | writes |
//! |---|---|---|---|
//! | [`lines`] | the line reader the seed's two formats share (`REM`, `QUIT`, numbers with line numbers) | ✓ | |
//! | [`config`] | `raytracer.cfg`, the seed's configuration file | [`config::read_config`] | [`config::write_config`] |
//! | [`datafile`] | the seed's data file (`ROOM.txt`) | [`datafile::read_data`] | [`datafile::write_data_file`] |
//! | [`nff`] | Eric Haines' Neutral File Format (`.nff`) | [`nff::load_nff`] | |
//! | [`obj`] | Wavefront OBJ meshes and their `.mtl` materials | [`obj::read_obj_file`] | |
//! | [`mesh`] | placing a read mesh into a scene | | |
//! | [`polygon`] | faces of more than three corners split into triangles (a fan where it covers the face once, else ear clipping) | | |
//! | [`crease`] | hard edges where a format has no normals: points split at sharp angles | | |
//! | [`fart`] | FART's scene language (`.fart`): lexer, parser, expander | [`fart::load_fart`] | |
//! | [`hosts`] | FART's hosts file | [`hosts::read_hosts_file`] | |
//! | [`load`] | a whole scene, the reader picked by extension, with the command line's overrides | [`load::load_scene`] | |
//! | [`convert`] | OBJ to the seed's data file and `raytracer.cfg` (through the writers above) | | [`convert::convert_obj`] |
//! | [`fs`] | any file, written whole or not at all | | [`fs::write_atomically`] |
//! | [`limits`] | the counts every format holds a scene to | | |
//!
//! Every reader reports a [`error::LoadError`] that names the file and, where there is one, the
//! line (and column). The crate depends on `strahl-core`, `glam`, `thiserror`, `anyhow` (the
//! writers' errors), `tempfile` (atomic writes) and `strahl-tcp` (the hosts file's default
//! port): no clap, indicatif or image, so a user of the parsers pulls in no command line. Images
//! are written by `strahl-host`'s `output` module.

pub mod config;
pub mod convert;
pub mod crease;
pub mod datafile;
pub mod error;
pub mod fart;
pub mod fs;
pub mod hosts;
pub mod limits;
pub mod lines;
pub mod load;
pub mod mesh;
pub mod nff;
pub mod obj;
pub mod polygon;
