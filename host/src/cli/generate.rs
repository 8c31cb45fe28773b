//! `strahl generate`: its arguments and the files it writes.
//!
//! The scenes come from [`crate::generate`]; they are written in the seed's formats by the
//! writers beside their readers ([`crate::formats::datafile::write_data_file`],
//! [`crate::formats::config::write_config`]), each file atomically.

use crate::formats::config::write_config;
use crate::formats::datafile::write_data_file;
use crate::formats::fs::{refuse_to_replace, write_text_atomically};
use crate::generate::{large, large_config, room_data_file};

/// Which scene `strahl generate` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SceneKind {
    /// The demo room's `ROOM.txt` (for the seed's example `raytracer.cfg`).
    Room,
    /// The large benchmark scene: `LARGE.txt` and a `raytracer.cfg` for it.
    Large,
}

/// Arguments of `strahl generate`.
#[derive(Debug, clap::Args)]
pub struct GenerateArgs {
    /// The scene to write.
    #[arg(value_enum)]
    pub kind: SceneKind,
    /// The folder to write into (it must exist).
    #[arg(short, long, value_name = "DIR", default_value = ".")]
    pub output: std::path::PathBuf,
    /// Replace the files if they are there (without it, generate refuses and names the file).
    #[arg(long)]
    pub force: bool,
    /// Least number of triangles of the large scene.
    #[arg(long, value_name = "N", default_value_t = 100_000,
          value_parser = clap::value_parser!(u32).range(1_000..=50_000_000))]
    pub triangles: u32,
}

/// Runs `strahl generate`: writes the chosen scene into the output folder.
///
/// # Errors
/// A missing or unwritable output folder.
pub fn run(args: &GenerateArgs) -> anyhow::Result<()> {
    let dir = &args.output;
    if !dir.is_dir() {
        anyhow::bail!("{}: no such folder", dir.display());
    }
    match args.kind {
        SceneKind::Room => {
            refuse_to_replace(&[&dir.join("ROOM.txt")], args.force)?;
            write_text_atomically(&dir.join("ROOM.txt"), &room_data_file())?;
            eprintln!("wrote {}", dir.join("ROOM.txt").display());
        }
        SceneKind::Large => {
            refuse_to_replace(
                &[&dir.join("LARGE.txt"), &dir.join("raytracer.cfg")],
                args.force,
            )?;
            let desc = large(args.triangles);
            let header = format!(
                "Strahl large benchmark scene, written by `strahl generate large --triangles {}`.\n\
                 {} triangles: fractal terrain and a ring of twelve smooth spheres.",
                args.triangles,
                desc.triangles.len()
            );
            let data = write_data_file(&desc, &header);
            write_text_atomically(&dir.join("LARGE.txt"), &data)?;
            let comment = format!(
                "Strahl large benchmark scene ({} triangles)",
                desc.triangles.len()
            );
            let cfg = write_config(&large_config(), &comment);
            write_text_atomically(&dir.join("raytracer.cfg"), &cfg)?;
            eprintln!(
                "wrote {} and {}",
                dir.join("LARGE.txt").display(),
                dir.join("raytracer.cfg").display()
            );
        }
    }
    Ok(())
}
