//! A scene prepared once for a distributed render: built for the master and in-process workers,
//! encoded for the others.

use crate::cluster::master::{AdaptiveJob, ClusterJob};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use strahl_core::accel::octree::OctreeParams;
use strahl_core::render::ray_limit::LineRayLimits;
use strahl_core::scene::effects::is_adaptive;
use strahl_core::scene::error::SceneError;
use strahl_core::scene::prepared::SceneGeometry;
use strahl_core::scene::{Scene, SceneDesc};
use strahl_core::wire::error::ProtocolError;
use strahl_core::wire::scene_blob::SceneBlob;
use strahl_core::worker::SceneCache;

/// Why a scene cannot be prepared.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PrepareError {
    /// The scene is not renderable.
    #[error("{0}")]
    Scene(SceneError),
    /// The scene cannot be encoded for the workers.
    #[error("the scene cannot be sent to workers: {0}")]
    Protocol(ProtocolError),
}

/// A built scene and its encoding.
#[derive(Clone, Debug)]
pub struct PreparedScene {
    /// The scene, shared with in-process workers.
    pub scene: Arc<Scene>,
    /// Its encoding, sent to other workers.
    pub blob: Arc<SceneBlob>,
    /// How long its octree took to build, of the whole preparation.
    pub octree_build: Duration,
}

/// Job numbers: distinct within a process, so a worker never mixes two renders' requests.
static NEXT_JOB: AtomicU32 = AtomicU32::new(1);

impl PreparedScene {
    /// Builds the scene with `params` ([`Scene::build`], its octree's build timed) and encodes
    /// it.
    ///
    /// # Errors
    /// [`PrepareError::Scene`] if the scene is not valid, [`PrepareError::Protocol`] if it is
    /// too large to send.
    pub fn new(desc: &SceneDesc, params: &OctreeParams) -> Result<Self, PrepareError> {
        let geometry = SceneGeometry::new(desc).map_err(PrepareError::Scene)?;
        let start = Instant::now();
        let indexed = geometry.index(params);
        let octree_build = start.elapsed();
        let scene = indexed.into_scene(u64::MAX);
        let blob = SceneBlob::encode(desc, params).map_err(PrepareError::Protocol)?;
        Ok(PreparedScene {
            scene: Arc::new(scene),
            blob: Arc::new(blob),
            octree_build,
        })
    }

    /// A worker cache that already holds this scene.
    pub fn cache(&self) -> SceneCache {
        SceneCache::with_scene(self.blob.digest, Arc::clone(&self.scene))
    }

    /// A new job rendering this scene.
    pub fn job(&self) -> ClusterJob {
        ClusterJob {
            id: NEXT_JOB.fetch_add(1, Ordering::Relaxed),
            blob: Arc::clone(&self.blob),
            width: self.scene.settings.width,
            height: self.scene.settings.height,
            lines: 0..self.scene.settings.height,
            scene: Some(Arc::clone(&self.scene)),
            ray_limits: LineRayLimits::new(&self.scene.settings, self.scene.lights.len()),
            adaptive: self
                .scene
                .settings
                .aa_threshold
                .filter(|_| is_adaptive(&self.scene.settings))
                .map(|threshold| AdaptiveJob {
                    threshold,
                    refine_all: !self.scene.settings.skip_effects,
                }),
        }
    }
}
