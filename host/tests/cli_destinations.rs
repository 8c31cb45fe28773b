//! Where `strahl render` refuses to write, through the binary: a pipe or another file that is
//! not a regular one (a file written whole and moved into place would replace it), a folder, a
//! symbolic link to nothing, and any file the scene was loaded from (the scene, the seed's data
//! file, a FART scene's mesh and material files), for the image and for `--stats-json`; the
//! statistics may not replace the image either. Each refusal names the path, exits 1 before
//! rendering and leaves the file as it was. A symbolic link to a file is written through, the
//! link kept. A FART mesh's material problems are warned about.

use crate::support::{room_config, TestResult, BIN};
use std::os::unix::fs::FileTypeExt as _;
use std::path::Path;
use std::process::{Command, Stdio};

/// A small NFF scene: one sphere on a floor, one light.
const NFF: &str = "v\nfrom 0 -5 2\nat 0 0 0\nup 0 0 1\nangle 40\nhither 0.1\nresolution 16 16\n\
                   b 0.1 0.1 0.2\nl 4 -4 6\nf 1 0.5 0.5 0.8 0.2 20 0 0\ns 0 0 0.5 0.5\n\
                   p 4\n-3 -3 0\n3 -3 0\n3 3 0\n-3 3 0\n";

/// A FART scene of the mesh in `tri.obj`.
const MESH_FART: &str = "scene {\n  \
    camera { position <0.3, 0.3, 3> look_at <0.3, 0.3, 0> up <0, 1, 0> vfov 40 }\n  \
    light { position <2, 2, 5> intensity 1 }\n  mesh { file \"tri.obj\" }\n}\n";

/// Runs `strahl render SCENE -w 16 -h 16 -q ARGS` in `dir`: its exit code and stderr.
fn render(dir: &Path, scene: &str, args: &[&str]) -> Result<(Option<i32>, String), std::io::Error> {
    let out = Command::new(BIN)
        .current_dir(dir)
        .args(["render", scene, "-w", "16", "-h", "16", "-q"])
        .args(args)
        .stdin(Stdio::null())
        .output()?;
    Ok((
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    ))
}

/// Asserts a refused render: exit 1, a message naming `name` and saying `why`.
fn assert_refused(ran: (Option<i32>, String), name: &str, why: &str) {
    let (code, err) = ran;
    assert_eq!(code, Some(1), "{name}: {err}");
    assert!(
        err.starts_with(&format!("error: {name}: ")),
        "{name}: {err}"
    );
    assert!(err.contains(why), "{name}: expected `{why}` in: {err}");
}

#[test]
fn a_pipe_a_folder_and_a_link_to_nothing_are_refused_and_a_link_is_written_through() -> TestResult {
    let dir = tempfile::tempdir()?;
    let d = dir.path();
    std::fs::write(d.join("s.nff"), NFF)?;
    // A pipe: the one kind of special file a test can make without privileges.
    let made = Command::new("mkfifo").arg(d.join("pipe.png")).status()?;
    assert!(made.success(), "mkfifo");
    std::fs::create_dir(d.join("folder.png"))?;
    std::os::unix::fs::symlink("nothing.png", d.join("dangling.png"))?;
    let not_regular = "it is not a regular file";
    assert_refused(
        render(d, "s.nff", &["-o", "pipe.png"])?,
        "pipe.png",
        not_regular,
    );
    assert_refused(
        render(d, "s.nff", &["-o", "a.png", "--stats-json", "pipe.png"])?,
        "pipe.png",
        not_regular,
    );
    assert_refused(
        render(d, "s.nff", &["-o", "folder.png"])?,
        "folder.png",
        "it is a folder",
    );
    assert_refused(
        render(d, "s.nff", &["-o", "dangling.png"])?,
        "dangling.png",
        "a symbolic link to a file that cannot be reached",
    );
    assert!(d.join("pipe.png").symlink_metadata()?.file_type().is_fifo());
    assert!(
        !d.join("a.png").exists(),
        "no image without its statistics' place"
    );
    assert!(!d.join("nothing.png").exists());

    std::fs::write(d.join("old.png"), b"old")?;
    std::os::unix::fs::symlink("old.png", d.join("link.png"))?;
    let (code, err) = render(d, "s.nff", &["-o", "link.png"])?;
    assert_eq!(code, Some(0), "{err}");
    assert!(d
        .join("link.png")
        .symlink_metadata()?
        .file_type()
        .is_symlink());
    let written = image::open(d.join("old.png"))?;
    assert_eq!((written.width(), written.height()), (16, 16));
    Ok(())
}

#[test]
fn no_output_replaces_a_file_the_scene_was_loaded_from() -> TestResult {
    let dir = tempfile::tempdir()?;
    let d = dir.path();
    std::fs::write(d.join("s.nff"), NFF)?;
    let room = room_config();
    let room_dir = room.parent().ok_or("the room's folder")?;
    std::fs::create_dir(d.join("room"))?;
    for name in ["raytracer.cfg", "ROOM.txt"] {
        std::fs::copy(room_dir.join(name), d.join("room").join(name))?;
    }
    std::fs::write(
        d.join("tri.obj"),
        "mtllib tri.mtl\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )?;
    std::fs::write(d.join("tri.mtl"), "newmtl red\nKd 1 0 0\n")?;
    std::fs::write(d.join("m.fart"), MESH_FART)?;
    let cases: [(&str, &[&str], &str); 7] = [
        ("s.nff", &["-o", "s.nff", "--format", "png"], "s.nff"),
        (
            "room/raytracer.cfg",
            &["-o", "room/ROOM.txt", "--format", "bmp"],
            "room/ROOM.txt",
        ),
        (
            "room/raytracer.cfg",
            &["-o", "./room/raytracer.cfg", "--format", "bmp"],
            "./room/raytracer.cfg",
        ),
        ("m.fart", &["-o", "tri.obj", "--format", "png"], "tri.obj"),
        ("m.fart", &["-o", "tri.mtl", "--format", "png"], "tri.mtl"),
        (
            "s.nff",
            &["-o", "a.png", "--stats-json", "./s.nff"],
            "./s.nff",
        ),
        (
            "m.fart",
            &["-o", "a.png", "--stats-json", "tri.obj"],
            "tri.obj",
        ),
    ];
    for (scene, args, name) in cases {
        let before = std::fs::read(d.join(name))?;
        assert_refused(render(d, scene, args)?, name, "would replace the input");
        assert_eq!(std::fs::read(d.join(name))?, before, "{name} unchanged");
    }
    assert_refused(
        render(d, "s.nff", &["-o", "a.png", "--stats-json", "./a.png"])?,
        "./a.png",
        "the statistics would replace the image",
    );
    assert!(!d.join("a.png").exists(), "nothing rendered");
    Ok(())
}

#[test]
fn a_fart_meshs_material_problems_are_warned_about() -> TestResult {
    let dir = tempfile::tempdir()?;
    let d = dir.path();
    std::fs::write(
        d.join("tri.obj"),
        "mtllib gone.mtl\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )?;
    std::fs::write(d.join("m.fart"), MESH_FART)?;
    let out = Command::new(BIN)
        .current_dir(d)
        .args(["render", "m.fart", "-w", "16", "-h", "16", "-o", "m.png"])
        .stdin(Stdio::null())
        .output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("warning: gone.mtl: cannot read the material file"),
        "{err}"
    );
    assert!(
        err.contains("warning: tri.obj: `usemtl red` names no material"),
        "{err}"
    );
    Ok(())
}
