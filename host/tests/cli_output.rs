//! Output options a POV-Ray user expects, through the binary: `--region` renders a rectangle
//! whose pixels are the full render's (cropped, or in a full-size image with the rest in the
//! background colour) and whose lines alone the master holds, `--format` and the extensions
//! write BMP, PNG 8 and 16 bit, PPM and EXR, `-o -` writes to standard output, and what Strahl
//! cannot read or write is a usage error (exit 2) that lists what it can.

use crate::support::{room_config, TestResult, BIN};
use std::process::{Command, Stdio};

/// A finished run: its exit code, stdout and stderr.
type Ran = Result<(Option<i32>, Vec<u8>, String), Box<dyn std::error::Error>>;

/// Runs `strahl ARGS`.
fn strahl(args: &[&str]) -> Ran {
    let out = Command::new(BIN).args(args).stdin(Stdio::null()).output()?;
    Ok((
        out.status.code(),
        out.stdout,
        String::from_utf8_lossy(&out.stderr).into_owned(),
    ))
}

/// The room at 96×72 with reflections, into `out`, with `extra` options.
fn room(out: &str, extra: &[&str]) -> Ran {
    let scene = room_config().display().to_string();
    let mut args = vec![
        "render",
        &scene,
        "-o",
        out,
        "-w",
        "96",
        "-h",
        "72",
        "--reflections",
        "on",
        "-q",
    ];
    args.extend_from_slice(extra);
    strahl(&args)
}

#[test]
fn a_region_has_the_full_renders_pixels() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = |n: &str| dir.path().join(n).display().to_string();
    for extra in [&[][..], &["-m", "2", "--aa-threshold", "0.1"]] {
        let (code, _, err) = room(&path("full.png"), extra)?;
        assert_eq!(code, Some(0), "{err}");
        let region = [&["--region", "10,20,70,50"][..], extra].concat();
        let (code, _, err) = room(&path("part.png"), &region)?;
        assert_eq!(code, Some(0), "{err}");
        let kept = [&["--region", "10,20,70,50", "--keep-size"][..], extra].concat();
        let (code, _, err) = room(&path("kept.png"), &kept)?;
        assert_eq!(code, Some(0), "{err}");
        let full = image::open(path("full.png"))?.to_rgb8();
        let part = image::open(path("part.png"))?.to_rgb8();
        let kept = image::open(path("kept.png"))?.to_rgb8();
        assert_eq!(part.dimensions(), (60, 30));
        assert_eq!(kept.dimensions(), (96, 72));
        for (x, y, p) in part.enumerate_pixels() {
            assert_eq!(
                p,
                full.get_pixel(x + 10, y + 20),
                "({x}, {y}) with {extra:?}"
            );
        }
        for (x, y, p) in kept.enumerate_pixels() {
            let inside = (10..70).contains(&x) && (20..50).contains(&y);
            let expected = if inside {
                *full.get_pixel(x, y)
            } else {
                image::Rgb([0, 0, 0])
            };
            assert_eq!(*p, expected, "({x}, {y}) with {extra:?}");
        }
    }
    let (code, _, err) = room(&path("x.png"), &["--region", "0,0,97,10"])?;
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("beyond the 96x72 image"), "{err}");
    let (code, _, err) = room(&path("x.png"), &["--region", "5,5,5,9"])?;
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("for example"), "{err}");
    Ok(())
}

/// A region of the largest image Strahl renders, under a 2 GiB address-space limit: the master
/// holds the region's lines alone, where the whole image's pixels would take 6 GiB.
#[test]
fn a_region_of_a_huge_image_holds_its_lines_alone() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("strip.png").display().to_string();
    let scene = room_config().display().to_string();
    let limited = "ulimit -v 2097152 && exec \"$0\" \"$@\"";
    let args = [
        "-c",
        limited,
        BIN,
        "render",
        &scene,
        "-o",
        &out,
        "-w",
        "32768",
        "-h",
        "32768",
        "--region",
        "16000,9000,16064,9002",
        "--workers",
        "2",
        "-q",
    ];
    let run = Command::new("bash")
        .args(args)
        .stdin(Stdio::null())
        .output()?;
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(0), "{err}");
    let strip = image::open(&out)?.to_rgb8();
    assert_eq!(strip.dimensions(), (64, 2));
    assert!(
        strip.pixels().any(|p| p.0 != [0, 0, 0]),
        "the room, not the background"
    );
    Ok(())
}

#[test]
fn every_format_holds_the_same_picture() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = |n: &str| dir.path().join(n).display().to_string();
    let (code, _, err) = room(&path("ref.bmp"), &[])?;
    assert_eq!(code, Some(0), "{err}");
    let reference = image::open(path("ref.bmp"))?.to_rgb8();
    for (name, extra) in [
        ("a.png", &[][..]),
        ("a.ppm", &[]),
        ("deep.png", &["--format", "png16"]),
        ("a.exr", &[]),
    ] {
        let (code, _, err) = room(&path(name), extra)?;
        assert_eq!(code, Some(0), "{name}: {err}");
        let img = image::open(path(name))?;
        match name {
            "deep.png" => {
                assert!(
                    matches!(img, image::DynamicImage::ImageRgb16(_)),
                    "16 bits per channel"
                );
                // Rounded to 8 bits as the BMP is, it is the BMP.
                let deep = img.to_rgb16();
                for (p, q) in deep.pixels().zip(reference.pixels()) {
                    let eight = p.0.map(|v| ((u32::from(v) * 255 + 32767) / 65535) as u8);
                    assert_eq!(eight, q.0);
                }
            }
            "a.exr" => {
                let hdr = img.to_rgb32f();
                for (p, q) in hdr.pixels().zip(reference.pixels()) {
                    let eight =
                        p.0.map(|v| ((v * 65535.0).round() as u32 * 255 + 32767) / 65535);
                    assert_eq!(eight, q.0.map(u32::from));
                }
            }
            _ => assert_eq!(img.to_rgb8(), reference, "{name}"),
        }
    }
    let ppm = std::fs::read(path("a.ppm"))?;
    assert!(ppm.starts_with(b"P6"), "binary PPM");
    Ok(())
}

#[test]
fn dash_writes_to_standard_output() -> TestResult {
    let dir = tempfile::tempdir()?;
    let file = dir.path().join("ref.png").display().to_string();
    let (code, _, err) = room(&file, &[])?;
    assert_eq!(code, Some(0), "{err}");
    let (code, bmp, err) = room("-", &[])?;
    assert_eq!(code, Some(0), "{err}");
    assert!(bmp.starts_with(b"BM"), "BMP by default");
    let (code, png, err) = room("-", &["--format", "png"])?;
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(
        image::load_from_memory(&png)?.to_rgb8(),
        image::open(&file)?.to_rgb8()
    );
    assert_eq!(
        image::load_from_memory(&bmp)?.to_rgb8(),
        image::open(&file)?.to_rgb8()
    );
    Ok(())
}

#[test]
fn what_strahl_cannot_read_or_write_is_a_usage_error_that_lists_what_it_can() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("x.jpg").display().to_string();
    let (code, _, err) = room(&out, &[])?;
    assert_eq!(code, Some(2));
    assert!(err.contains("png16") && err.contains("exr"), "{err}");
    let (code, _, err) = room(
        &dir.path().join("x.bmp").display().to_string(),
        &["--format", "jpeg"],
    )?;
    assert_eq!(code, Some(2));
    assert!(err.contains("unknown image format `jpeg`"), "{err}");
    let obj = dir.path().join("model.obj");
    std::fs::write(&obj, "v 0 0 0\n")?;
    let (code, _, err) = strahl(&["render", &obj.display().to_string()])?;
    assert_eq!(code, Some(2));
    assert!(
        err.contains(".fart") && err.contains(".nff") && err.contains("strahl convert"),
        "{err}"
    );
    let (code, _, err) = strahl(&["render", &room_config().display().to_string(), "-h"])?;
    assert_eq!(code, Some(2));
    assert!(err.contains("use --help"), "{err}");
    let (code, _, err) = room(
        &dir.path().join("t.bmp").display().to_string(),
        &["--threads", "1"],
    )?;
    assert_eq!(code, Some(0), "--threads is --workers: {err}");
    assert_eq!(
        std::fs::read_dir(dir.path())?.count(),
        2,
        "only the model and t.bmp"
    );
    Ok(())
}
