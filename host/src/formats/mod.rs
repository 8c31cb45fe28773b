//! The file formats: every scene, mesh and hosts file the host reads, and every file it writes
//! in those formats, each format's reader and writer side by side in one module.
//!
//! | module | format | reads | writes |
//! |---|---|---|---|
//! | [`lines`] | the line reader the seed's two formats share (`REM`, `QUIT`, numbers with line numbers) | ✓ | |
//! | [`config`] | `raytracer.cfg`, the seed's configuration file | [`config::read_config`] | [`config::write_config`] |
//! | [`datafile`] | the seed's data file (`ROOM.txt`) | [`datafile::read_data`] | [`datafile::write_data_file`] |
//! | [`nff`] | Eric Haines' Neutral File Format (`.nff`) | [`nff::load_nff`] | |
//! | [`obj`] | Wavefront OBJ meshes and their `.mtl` materials | [`obj::read_obj_file`] | |
//! | [`mesh`] | placing a read mesh into a scene | | |
//! | [`fart`] | FART's scene language (`.fart`): lexer, parser, expander | [`fart::load_fart`] | |
//! | [`hosts`] | FART's hosts file | [`hosts::read_hosts_file`] | |
//! | [`load`] | a whole scene, the reader picked by extension, with the command line's overrides | [`load::load_scene`] | |
//! | [`convert`] | OBJ to the seed's data file and `raytracer.cfg` (through the writers above) | | [`convert::convert_obj`] |
//! | [`image`] | BMP and PNG images | | [`image::write_image`] |
//!
//! Every reader reports a [`error::LoadError`] that names the file and, where there is one, the
//! line (and column). The group uses [`crate::util`] and `strahl_core` only: nothing of the
//! command line, the cluster or the benchmarks, so its parsers can become a crate of their own
//! (see the crate doc).

pub mod config;
pub mod convert;
pub mod datafile;
pub mod error;
pub mod fart;
pub mod hosts;
pub mod image;
pub mod lines;
pub mod load;
pub mod mesh;
pub mod nff;
pub mod obj;
