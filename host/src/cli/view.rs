//! `strahl view SCENE [ADDR]`: the page with the scene's settings as a form, before anything
//! renders; the user starts, stops, resumes and restarts renders from it
//! ([`crate::view::control::Renders`]) until Ctrl-C.

use super::render::cpu_count;
use crate::cluster::job::MasterOptions;
use crate::formats::load::{load_scene, Overrides};
use crate::util::secret::load_secret;
use crate::view::control::{settings_of, Renders};
use crate::view::hub::Hub;
use crate::view::server::{Control, ViewServer, DEFAULT_VIEW};
use clap::Args;
use std::path::PathBuf;
use std::sync::Arc;

/// Arguments of `strahl view`.
#[derive(Debug, Args)]
pub struct ViewArgs {
    /// The scene: a .fart file, an .nff file, or the seed's configuration file.
    #[arg(value_name = "SCENE")]
    pub scene: PathBuf,

    /// Where to serve the page: PORT or HOST:PORT (port 0 picks one).
    #[arg(value_name = "ADDR", default_value = DEFAULT_VIEW,
          value_parser = super::render::view_address_arg)]
    pub address: String,

    /// Write the images here instead of the scene's output file.
    #[arg(
        short,
        long = "output-file",
        visible_alias = "output",
        value_name = "FILE"
    )]
    pub output: Option<PathBuf>,

    /// Prove to TCP workers the shared secret in FILE [default: $STRAHL_SECRET]; with one, the
    /// page may be served beyond this machine (its URL then carries a key).
    #[arg(long, value_name = "FILE")]
    pub secret_file: Option<PathBuf>,

    /// Serve the page on an address other machines can reach without a secret.
    #[arg(long)]
    pub insecure: bool,
}

/// Runs `strahl view`: loads the scene (its errors name the file and line), serves the page
/// and waits for Ctrl-C.
///
/// # Errors
/// A scene that cannot be loaded, a secret file that cannot be read, an address that cannot be
/// served.
pub fn run(args: &ViewArgs) -> anyhow::Result<()> {
    let overrides = Overrides {
        output: args.output.clone(),
        ..Overrides::default()
    };
    super::render::scene_format(&args.scene)?;
    let loaded = load_scene(&args.scene, &overrides)?;
    let secret = load_secret(args.secret_file.as_deref())?;
    let hub = Hub::new();
    hub.set_settings(settings_of(&loaded, cpu_count()));
    let master = MasterOptions {
        secret: secret.clone(),
        name: crate::util::sys::host_name(),
        ..MasterOptions::default()
    };
    let renders = Renders::new(
        args.scene.clone(),
        args.output.clone(),
        master,
        Arc::clone(&hub),
    );
    let control: Arc<dyn Control> = Arc::new(renders);
    let server = ViewServer::start(
        &args.address,
        hub,
        Some(control),
        secret.is_some(),
        args.insecure,
    )?;
    eprintln!("view: {}", server.url);
    eprintln!("view: set up the render on the page and press Start; Ctrl-C ends");
    loop {
        std::thread::park();
    }
}
