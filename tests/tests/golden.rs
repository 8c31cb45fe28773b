//! Golden checksums of small renders: any change of pixels must be a conscious change.
//!
//! Each test renders a scene small and hashes its 8-bit image with FNV-1a. When a change of the
//! image is intended, run with `STRAHL_PRINT_GOLDEN=1 cargo test -p strahl-tests golden::
//! -- --nocapture`, look at the new image, and update the constant in the same commit.

use std::path::Path;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::scene::SceneDesc;
use strahl_host::cluster::local::render_local;
use strahl_host::cluster::prepared::PreparedScene;
use strahl_host::formats::load::{load_config_scene, Overrides};

fn fnv1a(bytes: impl Iterator<Item = u8>) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

fn image_hash(desc: &SceneDesc, workers: usize) -> u64 {
    let prepared = PreparedScene::new(desc, &OctreeParams::default()).expect("valid scene");
    let image = render_local(&prepared, workers, &|_, _| {}).expect("render");
    fnv1a(image.pixels.iter().flat_map(|p| p.to_rgb8()))
}

fn check(name: &str, desc: &SceneDesc, expected: u64) {
    let got = image_hash(desc, 2);
    if std::env::var_os("STRAHL_PRINT_GOLDEN").is_some() {
        println!("{name}: 0x{got:016x}");
        return;
    }
    assert_eq!(got, expected, "{name}: image changed (got 0x{got:016x})");
    assert_eq!(
        image_hash(desc, 3),
        got,
        "{name}: worker count changed the image"
    );
}

fn room(overrides: Overrides) -> SceneDesc {
    let cfg = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room/raytracer.cfg");
    let overrides = Overrides {
        width: Some(160),
        height: Some(120),
        ..overrides
    };
    load_config_scene(&cfg, &overrides)
        .expect("the demo room loads")
        .desc
}

#[test]
fn room_as_configured() {
    check(
        "room_as_configured",
        &room(Overrides::default()),
        0x13b2bba99f5fc10f,
    );
}

#[test]
fn room_with_reflections() {
    let desc = room(Overrides {
        reflections: Some(true),
        ..Overrides::default()
    });
    check("room_with_reflections", &desc, 0x46fa9eafebc7a8fb);
}

#[test]
fn room_without_shadows() {
    let desc = room(Overrides {
        shadows: Some(false),
        ..Overrides::default()
    });
    check("room_without_shadows", &desc, 0x28b17662f5687d59);
}

#[test]
fn large_scene() {
    let mut desc = strahl_host::generate::large(20_000);
    desc.settings.width = 96;
    desc.settings.height = 72;
    check("large_scene", &desc, 0x5a55d081aa9146ee);
}

#[test]
fn committed_room_is_the_generator_output() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room/ROOM.txt");
    let committed = std::fs::read_to_string(&path).expect("scenes/room/ROOM.txt is readable");
    assert!(
        committed == strahl_host::generate::room_data_file(),
        "scenes/room/ROOM.txt differs from `strahl generate room`: regenerate it"
    );
}
