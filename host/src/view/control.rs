//! `strahl view`'s renders: the page's Start, Stop and Resume ([`Control`]) run the same
//! pipeline as `strahl render` (load with the form's settings as overrides, prepare, start the
//! workers, the master, write the image) on a thread of their own, feeding the [`Hub`].
//!
//! A stopped render keeps its finished results in memory; Resume hands them to the master as a
//! checkpoint, so the image is the one an uninterrupted render gives.

use super::events::{Settings, Status};
use super::hub::{Hub, Shown};
use super::server::Control;
use crate::cluster::checkpoint::Record;
use crate::cluster::executor::{start_workers, WorkerSources};
use crate::cluster::job::{ClusterError, MasterOptions};
use crate::cluster::local::MAX_WORKERS;
use crate::cluster::master::{run_master_with, Hooks};
use crate::cluster::prepared::PreparedScene;
use crate::formats::load::{load_scene, LoadedScene, Overrides};
use crate::output::{check_scene_output, write_image};
use anyhow::anyhow;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::settings::{AA_THRESHOLD, AMBIENT_OCCLUSION, MAX_DEPTH, SAMPLES};
use strahl_core::scene::MAX_IMAGE_SIDE;

/// The renders of one scene started from the page.
pub struct Renders {
    scene: PathBuf,
    /// The image file (`-o`), else the scene's.
    output: Option<PathBuf>,
    /// The master's options (its secret for TCP workers).
    master: MasterOptions,
    hub: Arc<Hub>,
    state: Mutex<RunState>,
}

#[derive(Default)]
struct RunState {
    running: Option<Running>,
    /// The last render stopped early: its settings and the results it kept.
    stopped: Option<(Settings, Vec<Record>)>,
}

struct Running {
    stop: Arc<AtomicBool>,
    thread: JoinHandle<()>,
}

impl Renders {
    /// Renders of `scene` (its image to `output`, else the scene's) shown on `hub`.
    pub fn new(
        scene: PathBuf,
        output: Option<PathBuf>,
        master: MasterOptions,
        hub: Arc<Hub>,
    ) -> Arc<Renders> {
        Arc::new(Renders {
            scene,
            output,
            master,
            hub,
            state: Mutex::new(RunState::default()),
        })
    }

    fn lock(&self) -> MutexGuard<'_, RunState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Stops the render that runs, if any, and waits for it to end.
    fn stop_running(&self) -> bool {
        let running = self.lock().running.take();
        let Some(r) = running else { return false };
        r.stop.store(true, Ordering::Relaxed);
        let _ = r.thread.join();
        true
    }

    /// Starts a render of `settings` going on from `resume`.
    fn spawn(self: &Arc<Self>, settings: Settings, resume: Vec<Record>) -> Result<(), String> {
        let stop = Arc::new(AtomicBool::new(false));
        let (me, flag) = (Arc::clone(self), Arc::clone(&stop));
        let mut state = self.lock();
        state.stopped = None;
        let thread = std::thread::Builder::new()
            .name("view-render".into())
            .spawn(move || me.render(&settings, resume, &flag))
            .map_err(|e| format!("cannot start the render's thread: {e}"))?;
        state.running = Some(Running { stop, thread });
        Ok(())
    }

    /// One render, start to end, told to the hub.
    fn render(&self, settings: &Settings, resume: Vec<Record>, stop: &AtomicBool) {
        let kept = Mutex::new(resume);
        let status = match self.render_to_file(settings, &kept, stop) {
            Ok(output) => Status::Done { output },
            Err(e) => match e.downcast_ref::<ClusterError>() {
                Some(&ClusterError::Interrupted { finished, total }) => {
                    let records = kept.into_inner().unwrap_or_else(|e| e.into_inner());
                    self.lock().stopped = Some((settings.clone(), records));
                    Status::Stopped { finished, total }
                }
                _ => Status::Failed {
                    message: format!("{e:#}"),
                },
            },
        };
        self.hub.end(status);
    }

    /// Loads, prepares and renders the scene with `settings`, taking the results in `kept`
    /// first and adding each new one; writes the image and gives its path.
    fn render_to_file(
        &self,
        settings: &Settings,
        kept: &Mutex<Vec<Record>>,
        stop: &AtomicBool,
    ) -> anyhow::Result<String> {
        let loaded = self.load(settings)?;
        let kind = check_scene_output(&loaded, None)?;
        let prepared = PreparedScene::new(&loaded.desc, &OctreeParams::default())
            .map_err(|e| anyhow!("{}: {e}", loaded.data_path.display()))?;
        let s = prepared.scene.settings;
        self.hub.begin(Shown::whole(s.width, s.height));
        let sources = WorkerSources {
            worker: settings.tcp_workers.clone(),
            secret: self.master.secret.is_some(),
            ..WorkerSources::default()
        };
        let warn = |m: &str| eprintln!("warning: {m}");
        let mut workers = start_workers(&sources, settings.workers as usize, &prepared, &warn)?;
        let resume = kept.lock().unwrap_or_else(|e| e.into_inner()).clone();
        let record = |task: u32, rays: RayCounts, pixels: &[Pixel]| {
            let record = Record {
                task,
                rays,
                pixels: pixels.to_vec(),
            };
            kept.lock().unwrap_or_else(|e| e.into_inner()).push(record);
        };
        let hooks = Hooks {
            on_line: &|_, _| {},
            log: &warn,
            on_result: Some(&record),
            on_final: Some(&|line| self.hub.line(&line)),
            on_tick: Some(&|w| self.hub.workers(w)),
            resume: &resume,
            stop: Some(stop),
        };
        let links = std::mem::take(&mut workers.links);
        let image = run_master_with(&prepared.job(), links, None, &self.master, &hooks)?;
        write_image(&loaded.output, kind, s.width, s.height, &image.pixels)?;
        Ok(loaded.output.display().to_string())
    }

    /// The scene with `settings` (and `-o`) over the file's own.
    fn load(&self, settings: &Settings) -> anyhow::Result<LoadedScene> {
        let overrides = Overrides {
            output: self.output.clone(),
            width: Some(settings.width),
            height: Some(settings.height),
            shadows: Some(settings.shadows),
            reflections: Some(settings.reflections),
            samples: Some(settings.multisample),
            max_depth: Some(settings.max_depth),
            ambient_occlusion: Some(settings.ambient_occlusion),
            aa_threshold: settings.aa_threshold,
            ..Overrides::default()
        };
        Ok(load_scene(&self.scene, &overrides)?)
    }
}

impl Control for Arc<Renders> {
    fn start(&self, settings: Settings) -> Result<(), String> {
        check(&settings)?;
        self.stop_running();
        self.spawn(settings, Vec::new())
    }

    fn stop(&self) -> Result<(), String> {
        if self.stop_running() {
            Ok(())
        } else {
            Err("no render is running".into())
        }
    }

    fn resume(&self) -> Result<(), String> {
        if self
            .lock()
            .running
            .as_ref()
            .is_some_and(|r| !r.thread.is_finished())
        {
            return Err("a render is running; stop it first".into());
        }
        let Some((settings, records)) = self.lock().stopped.take() else {
            return Err("there is no stopped render to resume".into());
        };
        self.spawn(settings, records)
    }
}

/// The form's settings within the ranges the command line takes; else what is wrong.
///
/// # Errors
/// The first setting out of range, named as the form names it.
pub fn check(s: &Settings) -> Result<(), String> {
    let side = 1..=MAX_IMAGE_SIDE;
    let problems = [
        (
            !side.contains(&s.width),
            format!("width must be 1 to {MAX_IMAGE_SIDE}"),
        ),
        (
            !side.contains(&s.height),
            format!("height must be 1 to {MAX_IMAGE_SIDE}"),
        ),
        (
            !SAMPLES.contains(&s.multisample),
            format!(
                "samples per pixel side must be {} to {}",
                SAMPLES.start(),
                SAMPLES.end()
            ),
        ),
        (
            !MAX_DEPTH.contains(&s.max_depth),
            format!("depth must be {} to {}", MAX_DEPTH.start(), MAX_DEPTH.end()),
        ),
        (
            !AMBIENT_OCCLUSION.contains(&s.ambient_occlusion),
            format!(
                "ambient occlusion must be {} to {}",
                AMBIENT_OCCLUSION.start(),
                AMBIENT_OCCLUSION.end()
            ),
        ),
        (
            s.aa_threshold.is_some_and(|t| !AA_THRESHOLD.contains(&t)),
            "the adaptive threshold must be 0 to 1, or empty for every pixel".to_string(),
        ),
        (
            s.workers > MAX_WORKERS,
            format!("local workers must be 0 to {MAX_WORKERS}"),
        ),
        (
            s.workers == 0 && s.tcp_workers.is_empty(),
            "no workers: give local workers or TCP workers (host:port)".to_string(),
        ),
    ];
    match problems.into_iter().find(|(bad, _)| *bad) {
        Some((_, why)) => Err(why),
        None => Ok(()),
    }
}

/// The form's settings for a scene as loaded, with `workers` local workers.
pub fn settings_of(loaded: &LoadedScene, workers: u32) -> Settings {
    let s = &loaded.desc.settings;
    Settings {
        width: s.width,
        height: s.height,
        shadows: s.shadows,
        reflections: s.reflections,
        multisample: s.samples,
        aa_threshold: s.aa_threshold,
        max_depth: s.max_depth,
        ambient_occlusion: s.ambient_occlusion,
        workers,
        tcp_workers: Vec::new(),
    }
}
