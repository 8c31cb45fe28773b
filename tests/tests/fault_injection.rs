//! For any seeded schedule of link faults (bytes dropped, duplicated, corrupted, split into
//! small pieces, delayed, the link cut off), in either direction and over either transport (an
//! in-process pipe or loopback TCP), a render ends with exactly the reference image or with a
//! typed error. Never a wrong pixel, a panic, or a hang past its time-outs.

use proptest::prelude::*;
use std::net::TcpListener;
use std::path::Path;
use std::time::{Duration, Instant};
use strahl_core::accel::octree::OctreeParams;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::worker::{NodeInfo, SceneCache};
use strahl_host::cluster::faults::{inject, Faults};
use strahl_host::cluster::link::Link;
use strahl_host::cluster::master::{run_master, ClusterError, MasterOptions};
use strahl_host::cluster::prepared::PreparedScene;
use strahl_host::cluster::sim::{spawn_sim_worker, SimWorker};
use strahl_host::formats::load::{load_config_scene, Overrides};

/// The demo room, small, with reflections, and its pixels rendered line by line here.
fn scene() -> (PreparedScene, Vec<Pixel>) {
    let cfg = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room/raytracer.cfg");
    let overrides = Overrides {
        width: Some(32),
        height: Some(24),
        reflections: Some(true),
        ..Overrides::default()
    };
    let desc = load_config_scene(&cfg, &overrides)
        .expect("the room loads")
        .desc;
    let prepared = PreparedScene::new(&desc, &OctreeParams::default()).expect("a scene");
    let mut pixels = vec![Pixel::default(); 32 * 24];
    for (y, out) in pixels.chunks_mut(32).enumerate() {
        render_line(&prepared.scene, y as u32, out).expect("a line");
    }
    (prepared, pixels)
}

/// A worker over loopback TCP, served by `strahl worker`'s own TCP code on a thread.
fn tcp_worker(cache: &SceneCache) -> Link {
    let listener = TcpListener::bind("127.0.0.1:0").expect("a port");
    let address = listener.local_addr().expect("its address").to_string();
    let mut cache = cache.clone();
    std::thread::spawn(move || {
        if let Ok((stream, _)) = listener.accept() {
            let node = NodeInfo {
                name: "tcp",
                arch: "test",
                scene_memory: u64::MAX,
                threads: 2,
                secret: None,
                nonce: || [5; 32],
            };
            let _ = strahl_tcp::serve_stream(stream, &node, &mut cache);
        }
    });
    let stream = strahl_tcp::connect(&address, Duration::from_secs(5)).expect("connects");
    Link::from_tcp(address, stream).expect("a link")
}

/// A schedule of faults for one direction.
fn faults() -> impl Strategy<Value = Faults> {
    (
        any::<u64>(),
        prop_oneof![Just(0.0), 0.0..0.002],
        prop_oneof![Just(0.0), 0.0..0.002],
        prop_oneof![Just(0.0), 0.0..0.002],
        any::<bool>(),
        prop_oneof![
            Just(None),
            (0u64..300).prop_map(|us| Some(Duration::from_micros(us)))
        ],
        prop_oneof![Just(None), (0u64..40_000).prop_map(Some)],
    )
        .prop_map(
            |(seed, drop, duplicate, corrupt, split, delay, disconnect_after)| Faults {
                seed,
                drop,
                duplicate,
                corrupt,
                split,
                delay,
                disconnect_after,
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn any_fault_schedule_gives_the_image_or_a_typed_error(
        links in prop::collection::vec((any::<bool>(), faults(), faults()), 1..4),
    ) {
        let (prepared, want) = scene();
        let cache = prepared.cache();
        let workers: Vec<Link> = links
            .iter()
            .enumerate()
            .map(|(i, (over_tcp, down, up))| {
                let link = if *over_tcp {
                    tcp_worker(&cache)
                } else {
                    spawn_sim_worker(i + 1, SimWorker::default(), &cache).expect("a worker")
                };
                inject(link, *down, *up)
            })
            .collect();
        let opts = MasterOptions {
            probe_interval: Duration::from_millis(50),
            worker_timeout: Duration::from_millis(1500),
            wait_for_workers: Duration::from_secs(2),
            ..MasterOptions::default()
        };
        let start = Instant::now();
        let result = run_master(&prepared.job(), workers, None, &opts, &|_, _| {}, &|_| {});
        // Each worker is dropped within its time-out at most once, and the end waits 2 s.
        prop_assert!(start.elapsed() < Duration::from_secs(30), "{:?}", start.elapsed());
        match result {
            Ok(image) => prop_assert!(image.pixels == want, "a wrong pixel"),
            Err(ClusterError::AllWorkersLost { finished, total, .. }) => {
                prop_assert!(finished < total);
            }
            Err(e) => prop_assert!(false, "unexpected error: {e}"),
        }
    }
}

#[test]
fn a_clean_schedule_changes_nothing() {
    // The wrapper itself must not disturb a link: with no faults the image is exact.
    let (prepared, want) = scene();
    let cache = prepared.cache();
    let links = vec![
        inject(tcp_worker(&cache), Faults::default(), Faults::default()),
        inject(
            spawn_sim_worker(2, SimWorker::default(), &cache).expect("a worker"),
            Faults::default(),
            Faults {
                split: true,
                ..Faults::default()
            },
        ),
    ];
    let image = run_master(
        &prepared.job(),
        links,
        None,
        &MasterOptions::default(),
        &|_, _| {},
        &|_| {},
    )
    .expect("renders");
    assert!(image.pixels == want);
}
