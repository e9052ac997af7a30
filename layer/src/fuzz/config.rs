//! The config target: arbitrary text as the config file (`config::file::apply`), as Vulkan
//! Configurator's settings file (`vk_layer_settings::apply`), and cut into environment values
//! and `VK_EXT_layer_settings` (`VkLayerSettingEXT` arrays read by `layer_settings::read`),
//! all resolved together (`config::resolve`). Nothing may panic; every problem is a warning
//! naming where it comes from; a file that is not TOML is one warning and changes nothing;
//! applying a file twice changes nothing more; `layer_settings::read` keeps exactly revz's
//! settings, in order, with their values.

use std::ffi::{c_char, CString};
use std::path::Path;

use ash::vk;

use super::{hash_of, mutate_bytes, Counter, Rng, Target};
use crate::config::layer_settings;
use crate::config::{file, resolve, vk_layer_settings, AppIdentity, Resolved, Settings};
use crate::config::{Sources, Value, SETTINGS};
use crate::LAYER_NAME;

const CONFIG: &str = "/fuzz/revz.toml";
const VK_SETTINGS: &str = "/fuzz/vk_layer_settings.txt";

const SEEDS: &[&str] = &[
    "mode = \"complementary\"\nlog = \"warn\"\n\n[[application]]\nexecutable = \"vkcube\"\n\
     mode = \"infinite\"\n\n[[application]]\nengine_name = \"MyEngine\"\nmode = \"off\"\n",
    "mode = \"infinite\"\nfar_clip = \"keep\"\nreverse_observable = true\ncompare_op = \
     \"variants\"\npromote_depth_formats = false\nlog_file = \"/tmp/revz.log\"\n",
    "[[application]]\napplication_name = \"demo\"\nexecutable = \"demo\"\nlog = \"debug\"\n\
     [application.nested]\nx = 1\n",
    "application = 3\nmode = 7\nunknown = \"x\"\n[[application]]\nmode = \"flip\"\n",
    "revz_reverse_z.mode = flip\nrevz_reverse_z.log = info\n# comment\n\
     khronos_validation.enables = x\nrevz_reverse_z.bogus\nrevz_reverse_z.far_clip=keep\n",
    "mode = 'flip' # literal string\nlog = \"\"\"\nwarn\"\"\"\n[x]\ny = [1, 2, {a = 1}]\n",
];

const DICTIONARY: &[&str] = &[
    "mode",
    "far_clip",
    "reverse_observable",
    "copy_values",
    "compare_op",
    "promote_depth_formats",
    "log",
    "log_file",
    "[[application]]",
    "[application]",
    "executable",
    "application_name",
    "engine_name",
    " = ",
    "=",
    "\"",
    "'",
    "\n",
    "\r\n",
    "true",
    "false",
    "\"infinite\"",
    "\"off\"",
    "\"flip\"",
    "\"keep\"",
    "\"copies\"",
    "\"variants\"",
    "\"trace\"",
    "revz_reverse_z.",
    "{",
    "}",
    "[",
    "]",
    "#",
    "1",
    "-0",
    "1e400",
    "nan",
    "1979-05-27T07:32:00Z",
    "\"\"\"",
    "'''",
    "\\u0000",
    "\\",
    ".",
    ",",
    "\t",
    "é",
    "\u{feff}",
    "\u{0}",
    "a.b.c",
    "[[application.x]]",
    "{ executable = \"vkcube\" }",
    "[[[",
    "]]]",
];

/// The environment a case sees: the file paths, and a value for each setting's variable.
fn environment(text: &str, rng: &mut Rng) -> Vec<(String, String)> {
    let mut env = vec![
        (file::PATH_VAR.to_owned(), CONFIG.to_owned()),
        (
            vk_layer_settings::PATH_VAR.to_owned(),
            VK_SETTINGS.to_owned(),
        ),
    ];
    let lines: Vec<&str> = text.lines().collect();
    for spec in SETTINGS {
        if !lines.is_empty() && rng.one_in(2) {
            let line = rng.pick(&lines);
            let value = line
                .rsplit('=')
                .next()
                .unwrap_or(line)
                .trim_matches([' ', '"']);
            env.push((spec.env.to_owned(), value.to_owned()));
        }
    }
    env
}

/// `VkLayerSettingEXT`s cut from the text, with every type, null and non-UTF-8 names and
/// values, and the settings `layer_settings::read` must return for them.
struct LayerSettings {
    _strings: Vec<CString>,
    _string_arrays: Vec<Vec<*const c_char>>,
    _bools: Vec<Vec<vk::Bool32>>,
    settings: Vec<vk::LayerSettingEXT<'static>>,
    expected: Vec<(String, Option<Value>)>,
}

fn c_string(strings: &mut Vec<CString>, bytes: &[u8]) -> *const c_char {
    let bytes: Vec<u8> = bytes.iter().copied().filter(|&b| b != 0).collect();
    let string = CString::new(bytes).expect("no NUL left");
    let pointer = string.as_ptr();
    strings.push(string);
    pointer
}

fn layer_settings(text: &str, rng: &mut Rng) -> LayerSettings {
    let mut strings = Vec::new();
    let mut string_arrays: Vec<Vec<*const c_char>> = Vec::new();
    let mut bools: Vec<Vec<vk::Bool32>> = Vec::new();
    let mut settings = Vec::new();
    let mut expected = Vec::new();
    let pieces: Vec<&str> = text.split(['\n', '=', ' ']).collect();
    for _ in 0..rng.below(6) {
        let ours = !rng.one_in(4);
        let layer = match rng.below(8) {
            0 => std::ptr::null(),
            1 => c_string(&mut strings, b"VK_LAYER_KHRONOS_validation"),
            _ if ours => c_string(&mut strings, LAYER_NAME.as_bytes()),
            _ => c_string(&mut strings, rng.pick(&pieces).as_bytes()),
        };
        // SAFETY: null or one of the strings kept in `strings`.
        let ours = unsafe { crate::ffi::c_str(layer) }
            .is_some_and(|l| l.to_bytes() == LAYER_NAME.as_bytes());
        let (name, name_text) = match rng.below(10) {
            0 => (std::ptr::null(), None),
            1 => (c_string(&mut strings, b"mo\xffde"), None),
            2..=5 => {
                let spec = rng.pick(SETTINGS);
                (
                    c_string(&mut strings, spec.name.as_bytes()),
                    Some(spec.name.to_owned()),
                )
            }
            _ => {
                let piece = rng.pick(&pieces).replace('\0', "");
                (c_string(&mut strings, piece.as_bytes()), Some(piece))
            }
        };
        let ty = match rng.below(8) {
            0..=3 => vk::LayerSettingTypeEXT::STRING,
            4..=5 => vk::LayerSettingTypeEXT::BOOL32,
            6 => vk::LayerSettingTypeEXT::from_raw(rng.below(8) as i32),
            _ => vk::LayerSettingTypeEXT::from_raw(rng.u32() as i32),
        };
        let count = rng.below(3) as u32;
        let mut value = None;
        let p_values: *const std::ffi::c_void = if count == 0 || rng.one_in(8) {
            std::ptr::null()
        } else if ty == vk::LayerSettingTypeEXT::STRING {
            let array: Vec<*const c_char> = (0..count)
                .map(|_| match rng.below(6) {
                    0 => std::ptr::null(),
                    1 => c_string(&mut strings, b"\xfe\xff"),
                    _ => {
                        let piece = rng.pick(&pieces).replace('\0', "");
                        c_string(&mut strings, piece.as_bytes())
                    }
                })
                .collect();
            // SAFETY: the strings live in `strings`.
            value = unsafe { crate::ffi::c_str(array[0]) }
                .and_then(|s| s.to_str().ok())
                .map(|s| Value::Text(s.to_owned()));
            let pointer = array.as_ptr().cast();
            string_arrays.push(array);
            pointer
        } else {
            // Any other type's values are read as 32-bit words at most (BOOL32).
            let array: Vec<vk::Bool32> = (0..count.max(2)).map(|_| rng.below(3) as u32).collect();
            if ty == vk::LayerSettingTypeEXT::BOOL32 {
                value = Some(Value::Bool(array[0] != vk::FALSE));
            }
            let pointer = array.as_ptr().cast();
            bools.push(array);
            pointer
        };
        if ours {
            if let Some(name) = name_text {
                expected.push((name, value));
            }
        }
        settings.push(vk::LayerSettingEXT {
            p_layer_name: layer,
            p_setting_name: name,
            ty,
            value_count: count,
            p_values,
            ..Default::default()
        });
    }
    LayerSettings {
        _strings: strings,
        _string_arrays: string_arrays,
        _bools: bools,
        settings,
        expected,
    }
}

fn fresh() -> Resolved {
    Resolved {
        settings: Settings::default(),
        warnings: Vec::new(),
        notes: Vec::new(),
        origins: Vec::new(),
    }
}

pub static NOT_TOML: Counter = Counter::new("not TOML");
pub static WARNINGS: Counter = Counter::new("warnings");
pub static LAYER_SETTINGS: Counter = Counter::new("layer settings read");
pub static COUNTERS: &[&Counter] = &[&NOT_TOML, &WARNINGS, &LAYER_SETTINGS];

fn check(bytes: &[u8]) -> Result<u64, String> {
    let text = String::from_utf8_lossy(bytes).into_owned();
    let app = AppIdentity {
        executable: Some("vkcube".into()),
        application_name: Some("demo".into()),
        engine_name: None,
    };

    // The config file alone.
    let path = Path::new(CONFIG);
    let mut once = fresh();
    file::apply(path, &text, &app, &mut once);
    if let Some(w) = once.warnings.iter().find(|w| !w.starts_with(CONFIG)) {
        return Err(format!("a config file warning without its origin: {w}"));
    }
    if toml_edit::Document::parse(text.as_str()).is_err() {
        NOT_TOML.add();
        if once.warnings.len() != 1 || once.settings != Settings::default() {
            return Err(format!(
                "a file that is not TOML: {:?}, {:?}",
                once.warnings, once.settings
            ));
        }
    }
    let mut twice = once.clone();
    file::apply(path, &text, &app, &mut twice);
    if twice.settings != once.settings || twice.warnings.len() != 2 * once.warnings.len() {
        return Err(format!(
            "applying the file twice changes the outcome: {:?} then {:?}",
            once, twice
        ));
    }

    // Vulkan Configurator's file alone.
    let mut vk_file = fresh();
    vk_layer_settings::apply(Path::new(VK_SETTINGS), &text, &mut vk_file);
    if let Some(w) = vk_file
        .warnings
        .iter()
        .find(|w| !w.starts_with(VK_SETTINGS))
    {
        return Err(format!("a settings file warning without its origin: {w}"));
    }

    // VK_EXT_layer_settings.
    let mut rng = Rng::new(hash_of(&bytes));
    let built = layer_settings(&text, &mut rng);
    let info = vk::LayerSettingsCreateInfoEXT {
        setting_count: built.settings.len() as u32,
        p_settings: built.settings.as_ptr(),
        ..Default::default()
    };
    // SAFETY: a chain of one structure whose arrays live in `built`.
    let read = unsafe {
        layer_settings::read((&info as *const vk::LayerSettingsCreateInfoEXT<'_>).cast())
    };
    LAYER_SETTINGS.add();
    let got: Vec<(String, Option<Value>)> = read
        .iter()
        .map(|s| (s.name.clone(), s.value.clone().ok()))
        .collect();
    if got != built.expected {
        return Err(format!(
            "layer_settings::read returns {got:?}, {:?} expected",
            built.expected
        ));
    }

    // Everything resolved together.
    let env = environment(&text, &mut rng);
    let lookup = |name: &str| {
        env.iter()
            .find(|(key, _)| key == name)
            .map(|(_, value)| value.clone())
    };
    let read_file = |p: &Path| {
        if p == Path::new(CONFIG) || p == Path::new(VK_SETTINGS) {
            Ok(text.clone())
        } else {
            Err(std::io::Error::from(std::io::ErrorKind::NotFound))
        }
    };
    let is_dir = |_: &Path| false;
    let resolved = resolve(&Sources {
        env: &lookup,
        read_file: &read_file,
        is_dir: &is_dir,
        app: app.clone(),
        layer_settings: read,
    });
    let origins = [CONFIG, VK_SETTINGS, "VK_EXT_layer_settings"];
    for warning in &resolved.warnings {
        WARNINGS.add();
        let named = origins.iter().any(|o| warning.starts_with(o))
            || SETTINGS
                .iter()
                .any(|s| warning.starts_with(&format!("{}:", s.env)));
        if !named {
            return Err(format!("a warning without its origin: {warning}"));
        }
    }
    // Each kind of warning once: its first words after the origin.
    let mut shape: Vec<String> = resolved
        .warnings
        .iter()
        .map(|w| {
            let message = w.split_once(": ").map_or(w.as_str(), |(_, m)| m);
            let words: Vec<&str> = message.split_whitespace().take(3).collect();
            words.join(" ")
        })
        .collect();
    shape.sort();
    shape.dedup();
    Ok(hash_of(&(shape, format!("{:?}", resolved.settings))))
}

/// A value as a config file may give it: the accepted names (in any case), booleans, and
/// everything a setting does not take.
fn value(rng: &mut Rng) -> String {
    let names: Vec<&str> = SETTINGS
        .iter()
        .flat_map(|spec| match spec.kind {
            crate::config::Kind::Choice(names) => names.to_vec(),
            _ => Vec::new(),
        })
        .collect();
    match rng.below(12) {
        0..=3 => format!("\"{}\"", rng.pick(&names)),
        4 => format!("\"{}\"", rng.pick(&names).to_uppercase()),
        5 => rng.pick(&["true", "false"]).to_string(),
        6 => format!(
            "\"{}\"",
            rng.pick(&["1", "0", "on", "off", "yes", "no", " ", ""])
        ),
        7 => format!("{}", rng.u32() as i32),
        8 => rng
            .pick(&[
                "1.5",
                "nan",
                "-inf",
                "1979-05-27",
                "[1, \"a\"]",
                "{ a = 1 }",
                "[]",
            ])
            .to_string(),
        9 => format!("'{}'", rng.pick(DICTIONARY).replace(['\'', '\n', '\r'], "")),
        10 => "\"\"\"\nmulti\nline\"\"\"".to_owned(),
        _ => format!("\"/tmp/{}.log\"", rng.below(100)),
    }
}

/// A random config file that is mostly valid TOML: settings at the top level and in
/// `[[application]]` sections (matching or not), unknown keys, other tables, and the lines of
/// Vulkan Configurator's file.
fn generate(rng: &mut Rng) -> String {
    let mut text = String::new();
    let key = |rng: &mut Rng| -> String {
        match rng.below(8) {
            0..=4 => rng.pick(SETTINGS).name.to_owned(),
            5 => rng.pick(&file::MATCH_KEYS).to_string(),
            6 => "application".to_owned(),
            _ => format!("key{}", rng.below(5)),
        }
    };
    // Keys already set in the current table (TOML refuses a key set twice).
    let mut keys = std::collections::HashSet::new();
    for _ in 0..1 + rng.below(12) {
        let (line, key) = match rng.below(12) {
            0..=5 => {
                let key = key(rng);
                (format!("{key} = {}", value(rng)), Some(key))
            }
            6 => {
                keys.clear();
                ("[[application]]".to_owned(), None)
            }
            7 => {
                let key = rng.pick(&file::MATCH_KEYS).to_string();
                let name = rng.pick(&["vkcube", "demo", "MyEngine", ""]);
                (format!("{key} = \"{name}\""), Some(key))
            }
            8 => {
                keys.clear();
                let table = rng.pick(&["[application]", "[table]", "[[application.sub]]", "[a.b]"]);
                (table.to_string(), None)
            }
            9 => {
                let key = format!("{}{}", vk_layer_settings::PREFIX, key(rng));
                (format!("{key} = {}", value(rng)), Some(key))
            }
            10 => ("# a comment".to_owned(), None),
            _ => (String::new(), None),
        };
        if key.is_some_and(|key| !keys.insert(key)) {
            continue;
        }
        text.push_str(&line);
        text.push_str(if rng.one_in(10) { "\r\n" } else { "\n" });
    }
    text
}

fn mutate(rng: &mut Rng, corpus: &[Vec<u8>], input: &mut Vec<u8>) {
    if rng.one_in(2) {
        *input = generate(rng).into_bytes();
        if !rng.one_in(4) {
            return;
        }
    }
    mutate_bytes(rng, corpus, input, DICTIONARY);
    if rng.one_in(100) {
        // Deep nesting.
        let depth = 1 + rng.below(5000);
        let open = rng.pick(&["[", "{a=", "a=[", "[[a.", "\""]).repeat(depth);
        let at = rng.below(input.len() + 1);
        input.splice(at..at, open.into_bytes());
    }
}

pub fn target() -> Target {
    Target {
        name: "config",
        extension: "toml",
        seeds: SEEDS.iter().map(|s| s.as_bytes().to_vec()).collect(),
        mutate,
        check,
        max_len: 32 << 10,
        counters: COUNTERS,
    }
}

pub fn run() {
    let report = super::run(target());
    if report.replay {
        return;
    }
    assert!(NOT_TOML.get() > 0 && WARNINGS.get() > 0 && LAYER_SETTINGS.get() > 0);
}
