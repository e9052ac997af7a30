//! The benchmark (`revz-tester bench`, issue #7) runs end to end: `--quick` (tiny counts) with
//! the validation layer on in every child (no, one of every role, with and without the layer
//! in every mode) writes bench.json, the `speed` rows of report.json, report.md after its
//! marker and the plot. No timing is asserted: the figures of a quick run mean nothing.

use std::time::Instant;

use revz_tests::{clean_command, Harness};

#[test]
fn quick_bench_writes_valid_reports() {
    let harness = Harness::locate();
    let dir = harness.scratch_dir("bench-quick");
    // An accuracy report already there: the benchmark must keep it.
    std::fs::write(
        dir.join("report.json"),
        r#"{"device": "x", "driver": "y", "rows": [], "min_separation": []}"#,
    )
    .unwrap();
    std::fs::write(dir.join("report.md"), "# Accuracy\n\nkept\n").unwrap();

    let started = Instant::now();
    let output = clean_command(&harness.tester)
        .args(["bench", "--quick", "--validation", "--device", "llvmpipe"])
        .arg("--layer-dir")
        .arg(&harness.explicit_manifest_dir)
        .arg("--out")
        .arg(&dir)
        .output()
        .expect("run revz-tester bench");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success(),
        "bench failed ({}):\n{stdout}\n{stderr}",
        output.status
    );
    eprintln!(
        "bench --quick took {:.1} s",
        started.elapsed().as_secs_f64()
    );

    let read = |name: &str| -> serde_json::Value {
        let text = std::fs::read_to_string(dir.join(name)).unwrap();
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("{name}: {e}\n{text}"))
    };
    let bench = read("bench.json");
    let speed = bench["speed"].as_array().expect("speed rows");
    let modes: Vec<&str> = speed.iter().map(|r| r["mode"].as_str().unwrap()).collect();
    assert_eq!(modes, ["none", "off", "flip", "complementary", "infinite"]);
    // 9 measurements (2 storms, the storm with a projection per draw, the storm with the depth
    // profile on, the storm over the counting layer, micro, pipelines of distinct codes and of
    // one code, a converted depth copy) + the validated smoke role, in 5 variants.
    assert_eq!(bench["samples"].as_array().unwrap().len(), 50);
    for row in bench["speed"].as_array().unwrap() {
        assert!(row.get("frame_cpu_ratio_with_report").is_some(), "{row}");
        assert!(
            row["pipeline_creation_ratio_repeated_code"].is_number(),
            "{row}"
        );
        assert!(row["depth_copy_wall_ratio"].is_number(), "{row}");
    }
    // What reaches the driver (the counting layer below revz): exactly the application's
    // draws and binds, and its pushes (the carrier folded into them) but for the carrier's
    // first push at the frame's first bind, before the application's first push; beyond them
    // only depth state revz made dynamic (`off`: nothing), at most once per bind and pass
    // begin (the bench's pipelines differ in compare op and bias).
    let calls = |row: &serde_json::Value, command: &str| {
        row["driver_calls_by_command"][command]
            .as_u64()
            .unwrap_or_else(|| panic!("{command} counted in {row}"))
    };
    let none = &speed[0];
    assert!(calls(none, "vkCmdDraw") >= 200, "{none}");
    let setters = [
        "vkCmdSetViewport",
        "vkCmdSetViewportWithCount",
        "vkCmdSetDepthCompareOp",
        "vkCmdSetDepthBias",
        "vkCmdSetDepthBounds",
    ];
    for row in &speed[1..] {
        for command in ["vkCmdDraw", "vkCmdBindPipeline"] {
            assert_eq!(
                calls(row, command),
                calls(none, command),
                "{command}: {row}"
            );
        }
        let pushes = calls(row, "vkCmdPushConstants") - calls(none, "vkCmdPushConstants");
        assert!(pushes <= 1, "{pushes} more pushes: {row}");
        let extra = calls(row, "total") - calls(none, "total") - pushes;
        let set: u64 = setters.iter().map(|c| calls(row, c) - calls(none, c)).sum();
        assert_eq!(extra, set, "only depth state is added: {row}");
        let bound = calls(none, "vkCmdBindPipeline") + calls(none, "vkCmdBeginRenderPass");
        assert!(extra <= 4 * bound, "{extra} more calls per frame: {row}");
        if row["mode"] == "off" {
            assert_eq!(extra, 0, "{row}");
        }
    }

    let report = read("report.json");
    assert_eq!(report["device"], "x", "other keys of report.json are kept");
    assert!(report["rows"].is_array());
    let rows = report["speed"].as_array().expect("report.json gains speed");
    assert_eq!(rows.len(), 5);
    for row in rows {
        for key in [
            "device",
            "mode",
            "frame_cpu_ratio",
            "pipeline_creation_ratio",
            "ns_per_push_constant",
        ] {
            assert!(row.get(key).is_some(), "{key} missing in {row}");
        }
        assert!(
            row["frame_cpu_ratio"].as_f64().is_some_and(|r| r > 0.0),
            "{row}"
        );
    }
    assert_eq!(rows[0]["frame_cpu_ratio"].as_f64(), Some(1.0));

    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(md.starts_with("# Accuracy\n\nkept\n"), "{md}");
    assert!(
        md.contains("<!-- speed -->") && md.contains("| complementary |"),
        "{md}"
    );
    let png = std::fs::read(dir.join("overhead-vs-error.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG"));
    assert!(
        stdout.contains("| infinite |"),
        "the table is printed: {stdout}"
    );
}
