//! `cargo xtask piglit`: piglit's OpenGL depth tests (Debian's `piglit` package) through Zink
//! on lavapipe, without revz and with it in each mode, on the system's Zink and, where
//! `cargo xtask setup` extracted it, on Mesa 25.0's. A conformance check of the layer under
//! the Vulkan a real OpenGL driver records: which tests revz turns from pass to fail (issue
//! #44). Not part of CI: the package is large (2 GB installed), and the run takes minutes.
//!
//! The tests are those of piglit's `quick_gl` profile whose name speaks of depth (depth
//! buffers, textures, ranges, clamping, clip control, polygon offset, Hi-Z, `gl_FragDepth`),
//! GLX ones left out. Each runs headless (`PIGLIT_PLATFORM=surfaceless_egl`, `-auto -fbo`) in
//! a process of its own, at most a minute; its result is the one it prints
//! (`PIGLIT: {"result": ...}`), or `crash` where it prints none. Written to
//! `target/revz-piglit`: `results.json` (every test, Zink and variant) and `summary.md` (the
//! counts, and every test whose result revz changes).

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use anyhow::{bail, Context, Result};

use crate::{build, system, Paths};

/// Where Debian's piglit keeps its programs and test lists.
const PIGLIT_DIR: &str = "/usr/lib/x86_64-linux-gnu/piglit";
/// The test list the depth tests are taken from.
const PROFILE: &str = "tests/quick_gl.xml.gz";
/// A test's longest run.
const TIMEOUT_SECONDS: &str = "60";

/// `cargo xtask piglit`'s arguments.
#[derive(Debug, clap::Args)]
pub struct PiglitArgs {
    /// The revz modes to run the tests in (besides without revz).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "flip,complementary,infinite"
    )]
    modes: Vec<String>,
    /// Only the tests whose piglit name contains this.
    #[arg(long)]
    filter: Option<String>,
    /// Every test of the profile (7,636 without GLX), not only those about depth: revz must
    /// change nothing else (about 15 minutes per Zink and variant on 2 cores).
    #[arg(long)]
    all_tests: bool,
    /// The Zinks: `system` (Mesa 22.3 on Debian 12), `newer` (Mesa 25.0, where `cargo xtask
    /// setup` extracted it).
    #[arg(long, value_delimiter = ',', default_value = "system,newer")]
    zinks: Vec<String>,
    /// Tests run at once [default: the CPUs].
    #[arg(long)]
    jobs: Option<usize>,
    /// Every run under the Khronos validation layer (below revz, so that it checks what revz
    /// sends): the summary also lists the validation messages (by VUID) a test has with revz
    /// beyond those it has without. Several times slower.
    #[arg(long)]
    validation: bool,
}

/// One run's result (`pass`, `fail`, `skip`, or `crash(...)`), and its validation messages
/// counted by VUID (none where validation was off).
#[derive(Debug, Clone, Default)]
struct Outcome {
    result: String,
    messages: BTreeMap<String, usize>,
}

/// The VUIDs named in `text`, counted (each message names its VUID more than once: counted
/// once per line).
fn vuids(text: &str) -> BTreeMap<String, usize> {
    let mut counts = BTreeMap::new();
    for line in text.lines() {
        let Some(at) = line.find("VUID") else {
            continue;
        };
        let vuid: String = line[at..]
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '-' || *c == '_')
            .collect();
        *counts.entry(vuid).or_default() += 1;
    }
    counts
}

/// One piglit test: its name and its command line (program and arguments).
#[derive(Debug, Clone)]
struct PiglitTest {
    name: String,
    command: Vec<String>,
}

/// A Zink to run the tests through: its label and the environment selecting it.
struct Zink {
    /// Its name in `--zinks`.
    name: &'static str,
    label: &'static str,
    env: Vec<(&'static str, std::ffi::OsString)>,
}

/// Whether a piglit test's name speaks of depth.
fn about_depth(name: &str) -> bool {
    let name = name.to_ascii_lowercase();
    !name.starts_with("glx@")
        && [
            "depth",
            "polygon-offset",
            "hiz",
            "fragdepth",
            "frag_depth",
            "zfight",
            "clip-control",
            "clip_control",
        ]
        .iter()
        .any(|word| name.contains(word))
}

/// Undoes XML's five entities.
fn unescape(text: &str) -> String {
    text.replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&")
}

/// The value of attribute `name` in `element` (an XML start tag's text).
fn attribute(element: &str, name: &str) -> Option<String> {
    let start = element.find(&format!("{name}=\""))? + name.len() + 2;
    let end = start + element[start..].find('"')?;
    Some(unescape(&element[start..end]))
}

/// A command as piglit's lists write it: a Python list of quoted strings
/// (`['fbo-depth', 'clear', 'GL_DEPTH_COMPONENT16']`).
fn python_list(text: &str) -> Option<Vec<String>> {
    let inner = text.trim().strip_prefix('[')?.strip_suffix(']')?;
    let mut items = Vec::new();
    let mut chars = inner.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\'' | '"' => {
                let mut item = String::new();
                loop {
                    match chars.next()? {
                        '\\' => item.push(chars.next()?),
                        q if q == c => break,
                        other => item.push(other),
                    }
                }
                items.push(item);
            }
            ',' | ' ' => {}
            _ => return None,
        }
    }
    Some(items)
}

/// The depth tests of `xml` (the profile's text).
fn depth_tests(xml: &str) -> Vec<PiglitTest> {
    profile_tests(xml, about_depth)
}

/// The tests of `xml` (the profile's text) whose name `wanted` accepts, GLX ones left out
/// (they need an X server).
fn profile_tests(xml: &str, wanted: impl Fn(&str) -> bool) -> Vec<PiglitTest> {
    xml.split("<Test ")
        .skip(1)
        .filter_map(|test| {
            let name = attribute(test, "name")?;
            if name.starts_with("glx@") || !wanted(&name) {
                return None;
            }
            let option = test.find("name=\"command\"")?;
            let command = python_list(&attribute(&test[option..], "value")?)?;
            (!command.is_empty()).then_some(PiglitTest { name, command })
        })
        .collect()
}

/// What one run of `test` printed: its result, or `crash` (with its exit status) where none;
/// with `validation`, under the validation layer, its messages.
fn run_one(
    test: &PiglitTest,
    zink: &Zink,
    layer: &Path,
    mode: Option<&str>,
    validation: bool,
) -> Outcome {
    let mut command = Command::new("timeout");
    command
        .arg(TIMEOUT_SECONDS)
        .arg(Path::new(PIGLIT_DIR).join("bin").join(&test.command[0]))
        .args(&test.command[1..])
        .args(["-auto", "-fbo"])
        .current_dir(PIGLIT_DIR)
        .env("PIGLIT_PLATFORM", "surfaceless_egl")
        .env("PIGLIT_SOURCE_DIR", PIGLIT_DIR)
        .env("MESA_LOADER_DRIVER_OVERRIDE", "zink")
        .env("GALLIUM_DRIVER", "zink")
        .env("LIBGL_ALWAYS_SOFTWARE", "1")
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .envs(zink.env.iter().map(|(k, v)| (k, v)));
    for variable in ["VK_INSTANCE_LAYERS", "REVZ_MODE", "REVZ_CONFIG"] {
        command.env_remove(variable);
    }
    // The first layer named is the nearest to the application: revz above validation.
    let layers = match (mode, validation) {
        (Some(_), true) => "VK_LAYER_REVZ_reverse_z:VK_LAYER_KHRONOS_validation",
        (Some(_), false) => "VK_LAYER_REVZ_reverse_z",
        (None, true) => "VK_LAYER_KHRONOS_validation",
        (None, false) => "",
    };
    if !layers.is_empty() {
        command.env("VK_INSTANCE_LAYERS", layers);
    }
    if let Some(mode) = mode {
        command
            .env("VK_ADD_LAYER_PATH", layer)
            .env("REVZ_MODE", mode);
    }
    let Ok(output) = command.output() else {
        return Outcome {
            result: "crash(not started)".into(),
            ..Outcome::default()
        };
    };
    let text = String::from_utf8_lossy(&output.stdout);
    let marker = "PIGLIT: {\"result\": \"";
    let result = text
        .rfind(marker)
        .and_then(|at| {
            let rest = &text[at + marker.len()..];
            rest.find('"').map(|end| rest[..end].to_owned())
        })
        .unwrap_or_else(|| format!("crash({})", output.status));
    let messages = if validation {
        let mut messages = vuids(&text);
        for (vuid, n) in vuids(&String::from_utf8_lossy(&output.stderr)) {
            *messages.entry(vuid).or_default() += n;
        }
        messages
    } else {
        BTreeMap::new()
    };
    Outcome { result, messages }
}

/// The Zinks here: the system's, and Mesa 25.0's where `cargo xtask setup` extracted it.
fn zinks(paths: &Paths) -> Vec<Zink> {
    let mut zinks = vec![Zink {
        name: "system",
        label: "Mesa 22.3 (system)",
        env: Vec::new(),
    }];
    let dir = paths.target().join(system::NEWER_LAVAPIPE_DIR);
    let icd = dir.join(system::NEWER_LAVAPIPE_ICD);
    let egl = dir.join(system::NEWER_ZINK_EGL);
    let libraries = dir.join("root/usr/lib/x86_64-linux-gnu");
    if icd.exists() && egl.exists() && libraries.join("dri/zink_dri.so").exists() {
        zinks.push(Zink {
            name: "newer",
            label: "Mesa 25.0 (bookworm-backports)",
            env: vec![
                ("VK_DRIVER_FILES", icd.clone().into()),
                ("VK_ICD_FILENAMES", icd.into()),
                ("LD_LIBRARY_PATH", libraries.clone().into()),
                ("LIBGL_DRIVERS_PATH", libraries.join("dri").into()),
                ("__EGL_VENDOR_LIBRARY_FILENAMES", egl.into()),
            ],
        });
    }
    zinks
}

/// Every (Zink, variant, test) result; variants are `none` and the modes.
type Results = BTreeMap<String, BTreeMap<String, BTreeMap<String, Outcome>>>;

pub fn piglit(args: &PiglitArgs) -> Result<()> {
    system::ensure_packages()?;
    system::install_missing(&["piglit"])?;
    let profile = Path::new(PIGLIT_DIR).join(PROFILE);
    let xml = Command::new("zcat")
        .arg(&profile)
        .output()
        .with_context(|| format!("reading {}", profile.display()))?;
    let xml = String::from_utf8_lossy(&xml.stdout);
    let mut tests = if args.all_tests {
        profile_tests(&xml, |_| true)
    } else {
        depth_tests(&xml)
    };
    if let Some(filter) = &args.filter {
        tests.retain(|t| t.name.contains(filter.as_str()));
    }
    if tests.is_empty() {
        bail!("no piglit depth test in {}", profile.display());
    }
    let paths = Paths::new(true);
    let layer = build(&paths, true)?;
    let jobs = args.jobs.unwrap_or_else(|| {
        std::thread::available_parallelism().map_or(2, std::num::NonZeroUsize::get)
    });
    let variants: Vec<Option<&str>> = std::iter::once(None)
        .chain(args.modes.iter().map(|m| Some(m.as_str())))
        .collect();
    let started = std::time::Instant::now();
    let results: Mutex<Results> = Mutex::default();
    for zink in zinks(&paths)
        .into_iter()
        .filter(|z| args.zinks.iter().any(|n| n == z.name))
    {
        for &mode in &variants {
            let next = AtomicUsize::new(0);
            std::thread::scope(|scope| {
                for _ in 0..jobs {
                    scope.spawn(|| loop {
                        let index = next.fetch_add(1, Ordering::Relaxed);
                        let Some(test) = tests.get(index) else { break };
                        let result = run_one(test, &zink, &layer, mode, args.validation);
                        results
                            .lock()
                            .expect("no panic holds it")
                            .entry(zink.label.to_owned())
                            .or_default()
                            .entry(mode.unwrap_or("none").to_owned())
                            .or_default()
                            .insert(test.name.clone(), result);
                    });
                }
            });
            eprintln!(
                "xtask: piglit, {}, {}: {} tests ({:.0} s so far)",
                zink.label,
                mode.unwrap_or("without revz"),
                tests.len(),
                started.elapsed().as_secs_f64()
            );
        }
    }
    let results = results.into_inner().expect("no panic holds it");
    let out = paths.root.join("target/revz-piglit");
    std::fs::create_dir_all(&out)?;
    let json: serde_json::Value = results
        .iter()
        .map(|(zink, variants)| {
            let variants: serde_json::Map<String, serde_json::Value> = variants
                .iter()
                .map(|(variant, tests)| {
                    let tests: serde_json::Map<String, serde_json::Value> = tests
                        .iter()
                        .map(|(test, o)| {
                            let value = serde_json::json!({
                                "result": o.result,
                                "messages": o.messages,
                            });
                            (test.clone(), value)
                        })
                        .collect();
                    (variant.clone(), tests.into())
                })
                .collect();
            (zink.clone(), variants.into())
        })
        .collect::<serde_json::Map<_, _>>()
        .into();
    std::fs::write(
        out.join("results.json"),
        serde_json::to_string_pretty(&json)? + "\n",
    )?;
    let summary = summary(&results, &variants);
    std::fs::write(out.join("summary.md"), &summary)?;
    print!("{summary}");
    eprintln!("xtask: {}", out.join("summary.md").display());
    Ok(())
}

/// The counts per Zink and variant, then every test whose result differs between variants.
fn summary(results: &Results, variants: &[Option<&str>]) -> String {
    let mut text = String::from(
        "| Zink | revz | tests | pass | fail | skip | other |\n|---|---|---|---|---|---|---|\n",
    );
    let mut changed = String::new();
    let mut messages = String::new();
    for (zink, by_variant) in results {
        for variant in variants.iter().map(|m| m.unwrap_or("none")) {
            let Some(tests) = by_variant.get(variant) else {
                continue;
            };
            let count = |r: &str| tests.values().filter(|o| o.result == r).count();
            let (pass, fail, skip) = (count("pass"), count("fail"), count("skip"));
            text += &format!(
                "| {zink} | {variant} | {} | {pass} | {fail} | {skip} | {} |\n",
                tests.len(),
                tests.len() - pass - fail - skip
            );
        }
        let Some(native) = by_variant.get("none") else {
            continue;
        };
        for (test, without) in native {
            let with: Vec<String> = variants
                .iter()
                .flatten()
                .filter_map(|mode| {
                    let outcome = by_variant.get(*mode)?.get(test)?;
                    (outcome.result != without.result).then(|| format!("{mode} {}", outcome.result))
                })
                .collect();
            if !with.is_empty() {
                changed += &format!(
                    "- {zink}: `{test}`: {} without revz; {}\n",
                    without.result,
                    with.join(", ")
                );
            }
            let added: Vec<String> = variants
                .iter()
                .flatten()
                .filter_map(|mode| {
                    let outcome = by_variant.get(*mode)?.get(test)?;
                    let more: Vec<String> = outcome
                        .messages
                        .iter()
                        .filter_map(|(vuid, &n)| {
                            let before = without.messages.get(vuid).copied().unwrap_or(0);
                            (n > before).then(|| format!("{vuid} +{}", n - before))
                        })
                        .collect();
                    (!more.is_empty()).then(|| format!("{mode}: {}", more.join(", ")))
                })
                .collect();
            if !added.is_empty() {
                messages += &format!("- {zink}: `{test}`: {}\n", added.join("; "));
            }
        }
    }
    if changed.is_empty() {
        text += "\nEvery test has the same result with revz as without it.\n";
    } else {
        text += "\nResults revz changes:\n\n";
        text += &changed;
    }
    if !messages.is_empty() {
        text += "\nValidation messages a test has with revz beyond those it has without:\n\n";
        text += &messages;
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_profile_entry_gives_the_depth_tests_name_and_command() {
        let xml = "<PiglitTestList><Test type=\"gl\" name=\"spec@!opengl 1.1@depthrange-clear\">\
                   <option name=\"command\" value=\"['depthrange-clear']\" /></Test>\
                   <Test type=\"gl\" name=\"spec@ext_framebuffer_object@fbo-depth GL_DEPTH_COMPONENT16\">\
                   <option name=\"run_concurrent\" value=\"True\" />\
                   <option name=\"command\" value=\"['fbo-depth', 'clear', &quot;it's&quot;]\" /></Test>\
                   <Test type=\"gl\" name=\"shaders@glsl-max-varyings\">\
                   <option name=\"command\" value=\"['glsl-max-varyings']\" /></Test>\
                   <Test type=\"gl\" name=\"glx@glx-visuals-depth\">\
                   <option name=\"command\" value=\"['glx-visuals-depth']\" /></Test></PiglitTestList>";
        let tests = depth_tests(xml);
        let names: Vec<&str> = tests.iter().map(|t| t.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "spec@!opengl 1.1@depthrange-clear",
                "spec@ext_framebuffer_object@fbo-depth GL_DEPTH_COMPONENT16"
            ]
        );
        assert_eq!(tests[0].command, ["depthrange-clear"]);
        assert_eq!(tests[1].command, ["fbo-depth", "clear", "it's"]);
    }

    #[test]
    fn python_lists_of_strings_are_read_and_others_refused() {
        assert_eq!(
            python_list("['a', \"b c\", 'd\\'e']"),
            Some(vec!["a".into(), "b c".into(), "d'e".into()])
        );
        assert_eq!(python_list("[]"), Some(vec![]));
        assert_eq!(python_list("['a', 3]"), None);
        assert_eq!(python_list("'a'"), None);
    }

    #[test]
    fn the_summary_counts_and_lists_what_revz_changes() {
        let mut results = Results::new();
        let zink = results.entry("Z".into()).or_default();
        let outcome = |result: &str, messages: &[(&str, usize)]| Outcome {
            result: result.into(),
            messages: messages.iter().map(|&(v, n)| (v.to_owned(), n)).collect(),
        };
        for (variant, a, b) in [
            (
                "none",
                outcome("pass", &[]),
                outcome("skip", &[("VUID-x", 2)]),
            ),
            (
                "infinite",
                outcome("fail", &[]),
                outcome("skip", &[("VUID-x", 3), ("VUID-y", 1)]),
            ),
        ] {
            let tests = zink.entry(variant.into()).or_default();
            tests.insert("t1".into(), a);
            tests.insert("t2".into(), b);
        }
        let text = summary(&results, &[None, Some("infinite")]);
        assert!(text.contains("| Z | none | 2 | 1 | 0 | 1 | 0 |"), "{text}");
        assert!(
            text.contains("| Z | infinite | 2 | 0 | 1 | 1 | 0 |"),
            "{text}"
        );
        assert!(
            text.contains("- Z: `t1`: pass without revz; infinite fail"),
            "{text}"
        );
        assert!(
            text.contains("- Z: `t2`: infinite: VUID-x +1, VUID-y +1"),
            "{text}"
        );
        assert!(!text.contains("`t2`: skip"), "{text}");
    }

    #[test]
    fn validation_messages_are_counted_by_vuid_once_per_line() {
        let text =
            "Validation Error: [ VUID-vkCmdDraw-None-02859 ] ... (VUID-vkCmdDraw-None-02859)\n\
                    ok\nValidation Error: [ VUID_Undefined ] x\n\
                    Validation Error: [ VUID-vkCmdDraw-None-02859 ] again\n";
        let counts = vuids(text);
        assert_eq!(counts.get("VUID-vkCmdDraw-None-02859"), Some(&2));
        assert_eq!(counts.get("VUID_Undefined"), Some(&1));
        assert_eq!(counts.len(), 2);
    }
}
