//! Depth images that are only ever copied, as a conformance suite's copy and blit groups use
//! them (issue #44; `revz-tester transfers`): a source uploaded from a buffer (depth values of
//! full mantissas, a stencil pattern), one copy or blit of every aspect (2D and 3D images,
//! boxes downscaled, mirrored and 1:1, the aspects' layouts set apart), the destination read
//! back into a buffer. In every mode and format, with the validation layer and synchronization
//! validation: zero messages, and the stencil read back bit for bit as without revz, in three
//! configurations (each aspect compared where a region writes it or none does: where a blit
//! region writes one aspect of a packed D24_S8 texel, lavapipe writes the other too, which the
//! spec does not allow, and what it writes there is the driver's):
//!
//! - **Transfer usage only** (the suite's images): revz keeps such images native and in their
//!   format (no draw can store depth in them): every texel reads back bit for bit as without
//!   revz.
//! - **`--attachment`**: the 2D images may be depth attachments, so revz reverses them (and
//!   stores D16/D24 as float32 in the precise modes); the upload converts into them and the
//!   read-back back. D16 and D24 come back exactly (the read-back unflips the float,
//!   `ShaderHeader::mask`); float32 within half an ulp of [0.5, 1) (1 - d rounds d's low bits
//!   below 0.5: the inherent cost of reversing values the application uploads). Blits of D24
//!   within one unit: lavapipe blits D24 through float32 and is itself one unit off the
//!   uploaded value at some texels, where its blit of reversed values rounds elsewhere.
//! - **`REVZ_REVERSE_OBSERVABLE=all`** with `--attachment`: every image reversed, 3D ones
//!   included (in their format: only attachments are promoted), so that their conversions run:
//!   uploads into and read-backs out of 3D images, copies and blits from a 3D image into a
//!   promoted 2D one (D16/D24 in the precise modes), a box sixteen slices deep through a 3D
//!   staged image. As `--attachment`.

use revz_tests::Harness;

const MODES: [&str; 3] = ["flip", "complementary", "infinite"];

/// The cases and the formats each runs in (the separate layouts need a stencil aspect).
fn cases() -> Vec<(&'static str, Vec<&'static str>)> {
    let all = revz_tests::DEPTH_FORMATS.to_vec();
    vec![
        ("blit", all.clone()),
        ("blit-separate-layouts", vec!["d24-s8", "d32-s8"]),
        ("copy-3d", all.clone()),
        ("copy-3d-to-2d", all.clone()),
        ("blit-3d", all.clone()),
        ("blit-3d-to-2d", all),
        // The stencil alone: between a D24_S8 image that is no attachment (kept in its
        // format) and a promoted one, revz moves it through its scratch.
        ("copy-stencil-3d-to-2d", vec!["d24-s8", "d32-s8"]),
        ("blit-stencil-3d-to-2d", vec!["d24-s8", "d32-s8"]),
    ]
}

/// Which images the case makes, and what revz is asked to reverse.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Images {
    TransferOnly,
    Attachment,
    ObservableAll,
}

/// Runs the case; its depth (f32 a texel), stencil (empty without one) and stderr.
fn transfer(
    harness: &Harness,
    (case, format): (&str, &str),
    mode: Option<&str>,
    images: Images,
) -> Transferred {
    let name = format!(
        "transfers-{case}-{format}-{}-{images:?}",
        mode.unwrap_or("none")
    );
    let dir = harness.scratch_dir(&name);
    let mut command = revz_tests::clean_command(&harness.tester);
    command
        .args(["transfers", "--validation", "--sync-validation"])
        .args(["--device", "llvmpipe", "--depth-format", format])
        .args(["--case", case])
        .arg("--out")
        .arg(&dir);
    if images != Images::TransferOnly {
        command.arg("--attachment");
    }
    if let Some(mode) = mode {
        harness
            .with_layer(&mut command)
            .env("REVZ_MODE", mode)
            .env("REVZ_LOG", "info");
        if images == Images::ObservableAll {
            command.env("REVZ_REVERSE_OBSERVABLE", "all");
        }
    }
    let output = command.output().expect("start revz-tester");
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(
        output.status.success(),
        "{name}: exit {:?}\n{stderr}",
        output.status.code()
    );
    let bytes = std::fs::read(dir.join("depth.f32")).expect("depth.f32");
    let depth = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    Transferred {
        depth,
        stencil: std::fs::read(dir.join("stencil.u8")).unwrap_or_default(),
        aspects: std::fs::read(dir.join("aspects.u8")).expect("aspects.u8"),
        log: stderr,
    }
}

/// What a run read back.
struct Transferred {
    depth: Vec<f32>,
    /// Empty without a stencil aspect.
    stencil: Vec<u8>,
    /// Per texel, the aspects the regions write (bit 0 depth, bit 1 stencil).
    aspects: Vec<u8>,
    log: String,
}

/// Whether texel `i`'s aspect `bit` is compared: a region writes it, or none writes the texel.
fn compared(aspects: &[u8], i: usize, bit: u8) -> bool {
    aspects[i] == 0 || aspects[i] & bit != 0
}

/// How many of the case's two images revz reverses, and how many it keeps native as no depth
/// attachment.
fn expected_images(case: &str, images: Images) -> (usize, usize) {
    match images {
        Images::TransferOnly => (0, 2),
        Images::ObservableAll => (2, 0),
        // The 3D source is no attachment.
        Images::Attachment if case.ends_with("to-2d") => (1, 1),
        Images::Attachment => (2, 0),
    }
}

/// How far a texel may read back from the run without revz: see the module's points.
fn allowed(case: &str, format: &str, images: Images) -> f32 {
    if images == Images::TransferOnly {
        return 0.0;
    }
    if format.contains("d24") && case.starts_with("blit") {
        1.0 / 16_777_215.0 * 1.001
    } else if format.starts_with("d32") {
        // Half an ulp of [0.5, 1).
        2f32.powi(-25) * 1.001
    } else {
        0.0
    }
}

#[test]
fn copies_and_blits_of_transfer_only_images_read_back_as_without_revz() {
    let harness = Harness::locate();
    for (case, formats) in cases() {
        for format in formats {
            let native = transfer(&harness, (case, format), None, Images::TransferOnly);
            assert!(native.depth.len() >= 4096, "{case} {format}");
            assert_eq!(native.aspects.len(), native.depth.len());
            assert_eq!(
                native.stencil.is_empty(),
                !format.ends_with("s8"),
                "{case} {format}"
            );
            for images in [
                Images::TransferOnly,
                Images::Attachment,
                Images::ObservableAll,
            ] {
                if images == Images::Attachment && matches!(case, "copy-3d" | "blit-3d") {
                    // No 2D image: transfer usage only, above.
                    continue;
                }
                let allowed = allowed(case, format, images);
                for mode in MODES {
                    let what = format!("{case} {format} {mode} {images:?}");
                    let run = transfer(&harness, (case, format), Some(mode), images);
                    let log = &run.log;
                    let seen = (
                        log.matches("): reversed").count(),
                        log.matches("): native, because it is no depth attachment")
                            .count(),
                    );
                    assert_eq!(
                        seen,
                        expected_images(case, images),
                        "{what}: images reversed, kept native\n{log}"
                    );
                    if images == Images::TransferOnly {
                        assert!(!log.contains("promoted to"), "{what}: promoted\n{log}");
                    }
                    assert!(!log.contains("is not converted"), "{what}: {log}");
                    assert_eq!(run.aspects, native.aspects, "{what}");
                    let stencil_off = (0..run.stencil.len())
                        .filter(|&i| compared(&run.aspects, i, 2))
                        .filter(|&i| run.stencil[i] != native.stencil[i])
                        .count();
                    assert_eq!(stencil_off, 0, "{what}: stencil texels off");
                    let off: Vec<(usize, f32, f32)> = run
                        .depth
                        .iter()
                        .zip(&native.depth)
                        .enumerate()
                        .filter(|&(i, _)| compared(&run.aspects, i, 1))
                        .filter(|(_, (a, b))| {
                            (*a - *b).abs() > allowed
                                || (allowed == 0.0 && a.to_bits() != b.to_bits())
                        })
                        .map(|(i, (a, b))| (i, *a, *b))
                        .collect();
                    assert!(
                        off.is_empty(),
                        "{what}: {} of {} texels read back otherwise than without revz \
                         (allowed {allowed:e}); first (texel, revz, native): {:?}",
                        off.len(),
                        run.depth.len(),
                        &off[..off.len().min(5)]
                    );
                }
            }
        }
    }
}
