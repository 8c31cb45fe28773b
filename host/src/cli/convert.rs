//! `strahl convert`: its arguments, and the call into [`crate::formats::convert`], which does the
//! work (reading the OBJ and writing the data file and `raytracer.cfg` beside it).

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
}

/// `strahl convert`: the OBJ as the seed's data file and a configuration file for it.
///
/// # Errors
/// A bad or unreadable OBJ or .mtl (naming the file and line) or a file that cannot be written.
pub fn run(args: &ConvertArgs) -> anyhow::Result<()> {
    let options = crate::formats::convert::ConvertOptions {
        y_up: !args.z_up,
        force: args.force,
    };
    let summary = crate::formats::convert::convert_obj_with(&args.input, &args.output, &options)?;
    eprint!("{summary}");
    Ok(())
}
