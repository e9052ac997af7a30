//! Resolution tests: each precedence level, per-application matching, and each kind of bad
//! input, with the exact warning text a user sees.

use std::collections::HashMap;
use std::path::Path;

use log::LevelFilter;
use proptest::prelude::*;

use super::layer_settings::LayerSetting;
use super::*;

const CONFIG: &str = "/home/u/revz.toml";

/// A test world: environment variables, files, the application and its layer settings.
#[derive(Default)]
struct World {
    env: HashMap<&'static str, String>,
    files: HashMap<&'static str, String>,
    app: AppIdentity,
    layer_settings: Vec<LayerSetting>,
}

impl World {
    fn with_config(text: &str) -> World {
        let mut world = World::default();
        world.env.insert("REVZ_CONFIG", CONFIG.to_owned());
        world.files.insert(CONFIG, text.to_owned());
        world
    }

    fn resolve(&self) -> Resolved {
        let env = |name: &str| self.env.get(name).cloned();
        let read_file = |path: &Path| {
            self.files
                .get(path.to_str().unwrap())
                .cloned()
                .ok_or_else(|| std::io::Error::from(std::io::ErrorKind::NotFound))
        };
        let is_dir = |path: &Path| path == Path::new("/vkconfig");
        resolve(&Sources {
            env: &env,
            read_file: &read_file,
            is_dir: &is_dir,
            app: self.app.clone(),
            layer_settings: self.layer_settings.clone(),
        })
    }
}

fn layer_setting(name: &str, value: Value) -> LayerSetting {
    LayerSetting {
        name: name.to_owned(),
        value: Ok(value),
    }
}

#[test]
fn defaults_without_any_source() {
    let resolved = World::default().resolve();
    assert_eq!(resolved.settings, Settings::default());
    assert!(resolved.warnings.is_empty());
    assert_eq!(resolved.settings.mode, Mode::Complementary);
    assert_eq!(resolved.settings.log_level, LevelFilter::Off);
}

#[test]
fn every_setting_can_be_set_by_its_environment_variable() {
    let mut world = World::default();
    for (name, value) in [
        ("REVZ_MODE", "infinite"),
        ("REVZ_FAR_CLIP", "keep"),
        ("REVZ_REVERSE_OBSERVABLE", "1"),
        ("REVZ_PROMOTE_DEPTH_FORMATS", "false"),
        ("REVZ_LOG", "debug"),
        ("REVZ_LOG_FILE", "/tmp/revz.log"),
        ("REVZ_COPY_VALUES", "stored"),
    ] {
        world.env.insert(name, value.to_owned());
    }
    let resolved = world.resolve();
    assert_eq!(
        resolved.settings,
        Settings {
            mode: Mode::Infinite,
            far_clip: FarClip::Keep,
            reverse_observable: Observable::All,
            copy_values: CopyValues::Stored,
            compare_op: CompareOp::Dynamic,
            promote_depth_formats: Promote::Never,
            log_level: LevelFilter::Debug,
            log_file: Some("/tmp/revz.log".into()),
            report: None,
        }
    );
    assert!(resolved.warnings.is_empty(), "{:?}", resolved.warnings);
}

#[test]
fn layer_settings_beat_the_environment_which_beats_the_file() {
    let mut world = World::with_config("mode = \"flip\"\nfar_clip = \"keep\"\nlog = \"info\"\n");
    world.env.insert("REVZ_MODE", "infinite".into());
    world.env.insert("REVZ_LOG", "warn".into());
    world.layer_settings = vec![layer_setting("mode", Value::Text("off".into()))];
    let settings = world.resolve().settings;
    assert_eq!(
        settings.mode,
        Mode::Off,
        "layer setting wins over env and file"
    );
    assert_eq!(settings.log_level, LevelFilter::Warn, "env wins over file");
    assert_eq!(
        settings.far_clip,
        FarClip::Keep,
        "file wins over the default"
    );
}

#[test]
fn vulkan_configurator_settings_sit_between_the_environment_and_the_config_file() {
    let mut world = World::with_config("mode = \"flip\"\nfar_clip = \"keep\"\nlog = \"warn\"\n");
    world
        .env
        .insert("VK_LAYER_SETTINGS_PATH", "/vkconfig".into());
    world.files.insert(
        "/vkconfig/vk_layer_settings.txt",
        "# written by vkconfig\nkhronos_validation.mode = whatever\n\
         revz_reverse_z.mode = infinite\nrevz_reverse_z.log = info\n\
         revz_reverse_z.colour = red\nrevz_reverse_z.far_clip\n"
            .into(),
    );
    world.env.insert("REVZ_LOG", "debug".into());
    let resolved = world.resolve();
    assert_eq!(
        resolved.settings.mode,
        Mode::Infinite,
        "beats the config file"
    );
    assert_eq!(
        resolved.settings.far_clip,
        FarClip::Keep,
        "the file still applies"
    );
    assert_eq!(
        resolved.settings.log_level,
        LevelFilter::Debug,
        "the environment wins"
    );
    assert_eq!(
        resolved.warnings,
        vec![
            "/vkconfig/vk_layer_settings.txt:5: unknown setting 'colour' (settings: mode, \
             far_clip, reverse_observable, copy_values, compare_op, promote_depth_formats, log, log_file, report)",
            "/vkconfig/vk_layer_settings.txt:6: expected 'revz_reverse_z.<setting> = <value>'; \
             line ignored",
        ]
    );

    // VK_LAYER_SETTINGS_PATH may also name the file itself.
    world
        .env
        .insert("VK_LAYER_SETTINGS_PATH", "/elsewhere.txt".into());
    world
        .files
        .insert("/elsewhere.txt", "revz_reverse_z.mode = off\n".into());
    assert_eq!(world.resolve().settings.mode, Mode::Off);
}

#[test]
fn the_default_config_location_follows_xdg_then_home() {
    let mut world = World::default();
    world.env.insert("HOME", "/home/u".into());
    world
        .files
        .insert("/home/u/.config/revz/revz.toml", "mode = \"flip\"".into());
    assert_eq!(world.resolve().settings.mode, Mode::Flip);

    world.env.insert("XDG_CONFIG_HOME", "/xdg".into());
    world
        .files
        .insert("/xdg/revz/revz.toml", "mode = \"infinite\"".into());
    let resolved = world.resolve();
    assert_eq!(resolved.settings.mode, Mode::Infinite);
    assert_eq!(resolved.notes, vec!["config file /xdg/revz/revz.toml"]);
}

#[test]
fn a_missing_default_config_file_is_silent_but_a_named_one_is_not() {
    let mut world = World::default();
    world.env.insert("HOME", "/home/u".into());
    assert!(world.resolve().warnings.is_empty());

    world.env.insert("REVZ_CONFIG", "/nowhere/revz.toml".into());
    let resolved = world.resolve();
    assert_eq!(resolved.settings, Settings::default());
    assert_eq!(
        resolved.warnings,
        vec![format!(
            "/nowhere/revz.toml: cannot read the config file ({}); using the defaults",
            std::io::Error::from(std::io::ErrorKind::NotFound)
        )]
    );
}

const PER_APP: &str = r#"
mode = "flip"

[[application]]
executable = "vkcube"
mode = "infinite"

[[application]]
engine_name = "Unreal Engine"
mode = "off"

[[application]]
application_name = "Demo"
engine_name = "Demo Engine"
far_clip = "keep"
"#;

#[test]
fn application_sections_match_by_executable_or_application_info() {
    let mut world = World::with_config(PER_APP);
    assert_eq!(
        world.resolve().settings.mode,
        Mode::Flip,
        "no section matches"
    );

    world.app.executable = Some("vkcube".into());
    let resolved = world.resolve();
    assert_eq!(resolved.settings.mode, Mode::Infinite);
    assert_eq!(
        resolved.notes,
        vec!["config file /home/u/revz.toml", "[[application]] at line 4"]
    );

    world.app = AppIdentity {
        engine_name: Some("Unreal Engine".into()),
        ..Default::default()
    };
    assert_eq!(world.resolve().settings.mode, Mode::Off);

    // Every match key of a section must match.
    world.app = AppIdentity {
        application_name: Some("Demo".into()),
        ..Default::default()
    };
    assert_eq!(world.resolve().settings.far_clip, FarClip::Remove);
    world.app.engine_name = Some("Demo Engine".into());
    assert_eq!(world.resolve().settings.far_clip, FarClip::Keep);
    assert!(world.resolve().warnings.is_empty());
}

#[test]
fn a_file_that_is_not_toml_is_ignored_with_its_line() {
    let world = World::with_config("mode = \"flip\"\nlog = [unclosed\n");
    let resolved = world.resolve();
    assert_eq!(resolved.settings, Settings::default());
    assert_eq!(resolved.warnings.len(), 1, "{:?}", resolved.warnings);
    let warning = &resolved.warnings[0];
    assert!(
        warning.starts_with("/home/u/revz.toml:2: not valid TOML ("),
        "{warning}"
    );
    assert!(
        warning.ends_with("); ignoring this file and using the defaults"),
        "{warning}"
    );
}

#[test]
fn unknown_keys_are_reported_with_their_line_and_the_rest_applies() {
    let world = World::with_config("moed = \"flip\"\nfar_clip = \"keep\"\n");
    let resolved = world.resolve();
    assert_eq!(resolved.settings.far_clip, FarClip::Keep);
    assert_eq!(
        resolved.warnings,
        vec![
            "/home/u/revz.toml:1: unknown key 'moed' (settings: mode, far_clip, \
             reverse_observable, copy_values, compare_op, promote_depth_formats, log, log_file, report; sections: [[application]])"
        ]
    );
}

#[test]
fn wrong_values_name_the_accepted_ones_and_keep_the_lower_source() {
    let world = World::with_config(
        "far_clip = \"sometimes\"\nreverse_observable = \"maybe\"\nlog = 3\nmode = \"reverse\"\n",
    );
    let resolved = world.resolve();
    assert_eq!(
        resolved.warnings,
        vec![
            "/home/u/revz.toml:1: 'sometimes' is not a valid far_clip \
             (expected one of: remove, keep); using remove",
            "/home/u/revz.toml:2: 'maybe' is not a valid reverse_observable \
             (expected one of: none, copies, all); using copies",
            "/home/u/revz.toml:3: log must be a string or a boolean \
             (expected one of: off, error, warn, info, debug, trace); using off",
            "/home/u/revz.toml:4: 'reverse' is not a valid mode \
             (expected one of: off, flip, complementary, infinite); using off",
        ]
    );
    assert_eq!(resolved.settings.mode, Mode::Off, "a bad mode means off");
    assert_eq!(resolved.settings.far_clip, FarClip::Remove);
}

#[test]
fn bad_application_sections_are_reported_even_when_they_do_not_match() {
    let world = World::with_config(
        "[[application]]\nmode = \"flip\"\n\n[[application]]\nexecutable = 7\n\n\
         [[application]]\nexecutable = \"other\"\nfar_clip = \"never\"\n",
    );
    let resolved = world.resolve();
    assert_eq!(resolved.settings, Settings::default());
    assert_eq!(
        resolved.warnings,
        vec![
            "/home/u/revz.toml:1: this [[application]] has no match key \
             (one of: executable, application_name, engine_name); it is ignored",
            "/home/u/revz.toml:5: executable must be a string; this section is ignored",
            "/home/u/revz.toml:9: 'never' is not a valid far_clip \
             (expected one of: remove, keep); using remove",
        ]
    );
}

#[test]
fn application_must_be_an_array_of_tables() {
    let world = World::with_config("[application]\nexecutable = \"vkcube\"\n");
    let warnings = world.resolve().warnings;
    assert_eq!(
        warnings,
        vec![
            "/home/u/revz.toml:1: 'application' must be an array of tables, written \
             [[application]]; it is ignored"
        ]
    );
}

#[test]
fn bad_environment_values_warn_and_keep_the_file_value() {
    let mut world = World::with_config("far_clip = \"keep\"\n");
    world.env.insert("REVZ_FAR_CLIP", "nope".into());
    world.env.insert("REVZ_MODE", "upside-down".into());
    let resolved = world.resolve();
    assert_eq!(resolved.settings.far_clip, FarClip::Keep);
    assert_eq!(resolved.settings.mode, Mode::Off);
    assert_eq!(
        resolved.warnings,
        vec![
            "REVZ_MODE: 'upside-down' is not a valid mode \
             (expected one of: off, flip, complementary, infinite); using off",
            "REVZ_FAR_CLIP: 'nope' is not a valid far_clip \
             (expected one of: remove, keep); using keep",
        ]
    );
}

#[test]
fn bad_layer_settings_are_reported() {
    let world = World {
        layer_settings: vec![
            layer_setting("color", Value::Text("red".into())),
            layer_setting("mode", Value::Bool(true)),
            LayerSetting {
                name: "log".into(),
                value: Err("no value given".into()),
            },
        ],
        ..World::default()
    };
    assert_eq!(
        world.resolve().warnings,
        vec![
            "VK_EXT_layer_settings 'color': unknown setting (known: mode, far_clip, \
             reverse_observable, copy_values, compare_op, promote_depth_formats, log, log_file, report)",
            "VK_EXT_layer_settings 'mode': true is not a valid mode \
             (expected one of: off, flip, complementary, infinite); using off",
            "VK_EXT_layer_settings 'log': no value given; ignored",
        ]
    );
}

#[test]
fn reverse_observable_takes_names_and_booleans() {
    for (text, expected) in [
        ("reverse_observable = \"copies\"", Observable::Copies),
        ("reverse_observable = true", Observable::All),
        ("reverse_observable = \"false\"", Observable::None),
        ("reverse_observable = \"ALL\"", Observable::All),
    ] {
        let resolved = World::with_config(text).resolve();
        assert_eq!(resolved.settings.reverse_observable, expected, "{text}");
        assert!(resolved.warnings.is_empty());
    }
}

#[test]
fn promoting_formats_reads_its_names_and_the_old_booleans() {
    for (text, promote) in [
        ("\"auto\"", Promote::Auto),
        ("\"ALWAYS\"", Promote::Always),
        ("\"never\"", Promote::Never),
        ("true", Promote::Always),
        ("false", Promote::Never),
        ("\"off\"", Promote::Never),
    ] {
        let world = World::with_config(&format!("promote_depth_formats = {text}\n"));
        let resolved = world.resolve();
        assert_eq!(resolved.settings.promote_depth_formats, promote, "{text}");
        assert!(
            resolved.warnings.is_empty(),
            "{text}: {:?}",
            resolved.warnings
        );
    }
    let world = World::with_config("promote_depth_formats = \"sometimes\"\n");
    let resolved = world.resolve();
    assert_eq!(resolved.settings.promote_depth_formats, Promote::Auto);
    assert_eq!(resolved.warnings.len(), 1, "{:?}", resolved.warnings);
    assert!(
        resolved.warnings[0].contains("auto, always, never"),
        "{:?}",
        resolved.warnings
    );
}

#[test]
fn promotion_applies_in_the_modes_that_rewrite_depth() {
    assert!(Promote::Auto.applies(Mode::Complementary));
    assert!(Promote::Auto.applies(Mode::Infinite));
    assert!(!Promote::Auto.applies(Mode::Flip));
    assert!(Promote::Always.applies(Mode::Flip));
    assert!(!Promote::Always.applies(Mode::Off));
    assert!(!Promote::Never.applies(Mode::Infinite));
}

#[test]
fn every_mode_name_round_trips() {
    for mode in Mode::ALL {
        assert_eq!(Mode::parse(mode.name()), Some(mode));
        assert_eq!(Mode::parse(&mode.name().to_uppercase()), Some(mode));
        assert_eq!(Mode::parse(&format!(" {mode} ")), Some(mode));
    }
}

/// The manifests' settings section (what Vulkan Configurator shows) lists exactly the settings
/// of [`SETTINGS`], with the same environment variables, defaults and values.
#[test]
fn manifests_declare_every_setting() {
    {
        let template = "VkLayer_revz.json.in";
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../manifests")
            .join(template);
        let text = std::fs::read_to_string(&path).unwrap();
        let json: serde_json::Value = serde_json::from_str(&text).unwrap();
        let declared = json["layer"]["features"]["settings"]
            .as_array()
            .unwrap_or_else(|| panic!("{template}: no layer.features.settings"));
        assert_eq!(declared.len(), SETTINGS.len(), "{template}");
        for (spec, setting) in SETTINGS.iter().zip(declared) {
            assert_eq!(setting["key"], spec.name, "{template}");
            assert_eq!(setting["env"], spec.env, "{template}");
            let (kind, default) = match spec.kind {
                Kind::Choice(names) => {
                    let flags: Vec<&str> = setting["flags"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .map(|f| f["key"].as_str().unwrap())
                        .collect();
                    assert_eq!(flags, names, "{template}: {}", spec.name);
                    ("ENUM", serde_json::json!(spec.default))
                }
                Kind::Bool => ("BOOL", serde_json::json!(spec.default == "true")),
                Kind::Path => ("SAVE_FILE", serde_json::json!(spec.default)),
            };
            assert_eq!(setting["type"], kind, "{template}: {}", spec.name);
            assert_eq!(setting["default"], default, "{template}: {}", spec.name);
        }
    }
}

proptest! {
    /// Whatever the file holds, resolution returns settings and never panics.
    #[test]
    fn any_config_text_resolves(text in "\\PC{0,200}") {
        let _ = World::with_config(&text).resolve();
    }

    /// Structured noise: plausible keys and values in random arrangements.
    #[test]
    fn any_arrangement_of_known_keys_resolves(
        lines in proptest::collection::vec(
            (
                prop_oneof![
                    Just("mode"), Just("far_clip"), Just("log"), Just("executable"),
                    Just("[[application]]"), Just("[application]"), Just("log_file"),
                ],
                prop_oneof![
                    Just("\"flip\""), Just("true"), Just("3"), Just("\"\""), Just("[1]"),
                ],
            ),
            0..12,
        )
    ) {
        let text: String = lines
            .iter()
            .map(|(k, v)| if k.starts_with('[') { format!("{k}\n") } else { format!("{k} = {v}\n") })
            .collect();
        let mut world = World::with_config(&text);
        world.app.executable = Some("flip".into());
        let _ = world.resolve();
    }
}

#[test]
fn each_setting_says_which_source_gave_its_value() {
    let mut world = World::with_config(
        "mode = 'flip'\nfar_clip = 'keep'\nlog = 'debug'\n\
         [[application]]\nexecutable = 'game'\ncompare_op = 'variants'\n",
    );
    world.app.executable = Some("game".to_owned());
    world.env.insert("REVZ_FAR_CLIP", "remove".to_owned());
    world.env.insert("REVZ_LOG", "loud".to_owned());
    world
        .layer_settings
        .push(layer_setting("mode", Value::Text("infinite".to_owned())));
    let resolved = world.resolve();
    assert_eq!(resolved.settings.mode, Mode::Infinite);
    assert_eq!(resolved.origin(Key::Mode), "VK_EXT_layer_settings 'mode'");
    assert_eq!(resolved.origin(Key::FarClip), "environment REVZ_FAR_CLIP");
    // An unreadable value keeps what the file gave, and the file stays its origin.
    assert_eq!(resolved.settings.log_level, LevelFilter::Debug);
    assert_eq!(resolved.origin(Key::Log), format!("config file {CONFIG}"));
    assert!(resolved
        .origin(Key::CompareOp)
        .starts_with(&format!("config file {CONFIG}, [[application]] at line ")));
    assert_eq!(resolved.origin(Key::ReverseObservable), "default");
    // An unreadable mode means off, from the source that named it.
    let mut typo = World::default();
    typo.env.insert("REVZ_MODE", "infinit".to_owned());
    let resolved = typo.resolve();
    assert_eq!(resolved.settings.mode, Mode::Off);
    assert_eq!(resolved.origin(Key::Mode), "environment REVZ_MODE");
}
