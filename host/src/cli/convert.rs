//! `strahl convert`: its arguments, and the call into [`crate::formats::convert`], which does the
//! work (reading the OBJ and writing the data file and `raytracer.cfg` beside it).

use crate::formats::crease::DEFAULT_CREASE_DEGREES;
use std::path::PathBuf;

/// Arguments of `strahl convert`.
#[derive(Debug, clap::Args)]
pub struct ConvertArgs {
    /// The OBJ file (its .mtl materials are used when present).
    #[arg(value_name = "MODEL.obj")]
    pub input: PathBuf,

    /// The data file to write; a raytracer.cfg that frames the model is written beside it.
    #[arg(short, long, value_name = "DATA.txt")]
    pub output: PathBuf,

    /// Keep the OBJ's coordinates instead of turning its Y-up into the seed's Z-up.
    #[arg(long)]
    pub z_up: bool,

    /// Replace the data file or raytracer.cfg if one is there (without it, convert refuses and
    /// names the file).
    #[arg(long)]
    pub force: bool,

    /// Keep edges where faces meet at more than DEG degrees hard (the seed's format has no
    /// normals, so their shared points are duplicated); 180 makes every edge smooth.
    #[arg(long, value_name = "DEG", default_value_t = DEFAULT_CREASE_DEGREES, value_parser = crease_angle)]
    pub crease: f32,
}

/// Parses a crease angle: degrees from 0 to 180.
///
/// # Errors
/// A message naming the range.
fn crease_angle(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(d) if (0.0..=180.0).contains(&d) => Ok(d),
        _ => Err(
            "expected degrees from 0 to 180 (for example 60; 180 keeps every edge smooth)".into(),
        ),
    }
}

/// `strahl convert`: the OBJ as the seed's data file and a configuration file for it.
///
/// # Errors
/// A bad or unreadable OBJ or .mtl (naming the file and line) or a file that cannot be written.
pub fn run(args: &ConvertArgs) -> anyhow::Result<()> {
    let options = crate::formats::convert::ConvertOptions {
        y_up: !args.z_up,
        force: args.force,
        crease_degrees: args.crease,
    };
    let summary = crate::formats::convert::convert_obj_with(&args.input, &args.output, &options)?;
    eprint!("{summary}");
    Ok(())
}
