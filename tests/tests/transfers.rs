//! Depth images that are only ever copied, as a conformance suite's copy and blit groups use
//! them (issue #44; `revz-tester transfers`): two images with transfer usage only, the source
//! uploaded from a buffer (depth values of full mantissas, a stencil pattern), one copy or
//! blit of every aspect, the destination read back into a buffer. revz reverses such images by
//! default (and stores D16/D24 as float32 in the precise modes), so the upload converts into
//! the reversed image, the copy or blit goes down as it is (or through revz's staged image),
//! and the read-back converts back.
//!
//! In every mode and format, with the validation layer and synchronization validation: zero
//! messages, both images logged as reversed, the stencil read back bit for bit as without
//! revz, and the depth too, but for blits of D24: lavapipe blits D24 through float32 and is
//! itself one unit off the uploaded value at some texels, where revz's blit (of complemented
//! values, or of float32 storage) rounds otherwise: within one unit of the native blit there
//! (a conformance suite allows a D24 blit one unit). Copies of D24 through float32 storage
//! come back exactly: the read-back unflips (`ShaderHeader::mask`).

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
        ("blit-3d", all),
    ]
}

/// Runs the case; its depth (f32 a texel), stencil (empty without one) and stderr.
fn transfer(
    harness: &Harness,
    case: &str,
    format: &str,
    mode: Option<&str>,
) -> (Vec<f32>, Vec<u8>, String) {
    let name = format!("transfers-{case}-{format}-{}", mode.unwrap_or("none"));
    let dir = harness.scratch_dir(&name);
    let mut command = revz_tests::clean_command(&harness.tester);
    command
        .args(["transfers", "--validation", "--sync-validation"])
        .args([
            "--device",
            "llvmpipe",
            "--depth-format",
            format,
            "--case",
            case,
        ])
        .arg("--out")
        .arg(&dir);
    if let Some(mode) = mode {
        harness
            .with_layer(&mut command)
            .env("REVZ_MODE", mode)
            .env("REVZ_LOG", "info");
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
    let stencil = std::fs::read(dir.join("stencil.u8")).unwrap_or_default();
    (depth, stencil, stderr)
}

#[test]
fn copies_and_blits_of_transfer_only_images_read_back_as_without_revz() {
    let harness = Harness::locate();
    for (case, formats) in cases() {
        for format in formats {
            let (native_depth, native_stencil, _) = transfer(&harness, case, format, None);
            assert!(native_depth.len() >= 4096, "{case} {format}");
            assert_eq!(
                native_stencil.is_empty(),
                !format.ends_with("s8"),
                "{case} {format}"
            );
            let d24 = format.contains("d24");
            let allowed = if d24 && case.starts_with("blit") {
                1.0 / 16_777_215.0 * 1.001
            } else {
                0.0
            };
            for mode in MODES {
                let (depth, stencil, log) = transfer(&harness, case, format, Some(mode));
                let reversed = log.matches("): reversed").count();
                assert!(
                    reversed >= 2,
                    "{case} {format} {mode}: the images were not reversed\n{log}"
                );
                assert!(
                    !log.contains("is not converted"),
                    "{case} {format} {mode}: {log}"
                );
                assert_eq!(stencil, native_stencil, "{case} {format} {mode}: stencil");
                let off: Vec<(usize, f32, f32)> = depth
                    .iter()
                    .zip(&native_depth)
                    .enumerate()
                    .filter(|(_, (a, b))| (*a - *b).abs() > allowed || (allowed == 0.0 && a != b))
                    .map(|(i, (a, b))| (i, *a, *b))
                    .collect();
                assert!(
                    off.is_empty(),
                    "{case} {format} {mode}: {} of {} texels read back otherwise than without \
                     revz (allowed {allowed:e}); first (texel, revz, native): {:?}",
                    off.len(),
                    depth.len(),
                    &off[..off.len().min(5)]
                );
            }
        }
    }
}
