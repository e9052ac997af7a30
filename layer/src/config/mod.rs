//! Layer settings: what they are, where they come from, and which source wins.
//!
//! Sources, highest precedence first:
//! 1. `VK_EXT_layer_settings` structures the application chains into `VkInstanceCreateInfo`
//!    ([`layer_settings`]);
//! 2. environment variables, one per setting (`REVZ_MODE`, ...);
//! 3. `vk_layer_settings.txt`, which Vulkan Configurator writes ([`vk_layer_settings`]);
//! 4. the config file ([`mod@file`]): its top-level keys, then every `[[application]]` section that
//!    matches this process (by executable name or `VkApplicationInfo` names), in file order.
//!
//! A value that cannot be read produces one warning naming where it came from and what is
//! accepted, and the setting keeps what the lower sources gave it. The one exception is
//! `mode`: an unreadable mode means `off`, so that a typo never turns on a rewrite nobody asked
//! for. Resolution is pure (no Vulkan, no process state): [`resolve`] gets everything it reads
//! through [`Sources`].

pub mod file;
pub mod layer_settings;
pub mod vk_layer_settings;

use std::fmt;
use std::path::PathBuf;

use log::LevelFilter;

/// How the layer treats depth.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    /// Pass everything through untouched.
    Off,
    /// Reverse depth by flipping the viewport depth range (no projection rewrite).
    Flip,
    /// Rewrite projections to complementary (finite reversed) Z.
    #[default]
    Complementary,
    /// Rewrite projections to infinite reversed Z.
    Infinite,
}

impl Mode {
    /// Every mode, in the order the documentation lists them.
    pub const ALL: [Mode; 4] = [Mode::Off, Mode::Flip, Mode::Complementary, Mode::Infinite];
    const NAMES: &'static [&'static str] = &["off", "flip", "complementary", "infinite"];

    /// The spelling used in settings and in log lines.
    pub fn name(self) -> &'static str {
        Mode::NAMES[self as usize]
    }

    /// Parses a mode name (case-insensitive, surrounding blanks ignored).
    pub fn parse(text: &str) -> Option<Mode> {
        Mode::ALL
            .into_iter()
            .find(|mode| mode.name().eq_ignore_ascii_case(text.trim()))
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Whether infinite reversed-Z keeps the application's far plane (seed 001's clear-value
/// trick) or removes it, as infinite projections do.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FarClip {
    #[default]
    Remove,
    Keep,
}

impl FarClip {
    const NAMES: &'static [&'static str] = &["remove", "keep"];

    pub fn name(self) -> &'static str {
        FarClip::NAMES[self as usize]
    }

    pub fn parse(text: &str) -> Option<FarClip> {
        [FarClip::Remove, FarClip::Keep]
            .into_iter()
            .find(|v| v.name().eq_ignore_ascii_case(text.trim()))
    }
}

/// Whether depth images in UNORM formats are created in a float format instead
/// (`crate::policy::DevicePolicy::promoted_format`): reversal only gains precision with float
/// storage.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Promote {
    /// In the modes that rewrite depth (`complementary`, `infinite`); not in `flip`, which
    /// gains no precision from it.
    #[default]
    Auto,
    Always,
    Never,
}

impl Promote {
    const NAMES: &'static [&'static str] = &["auto", "always", "never"];

    pub fn name(self) -> &'static str {
        Promote::NAMES[self as usize]
    }

    /// Parses a name; `true` and `false` (the setting's old values) read as `always` and
    /// `never`.
    pub fn parse(text: &str) -> Option<Promote> {
        [Promote::Auto, Promote::Always, Promote::Never]
            .into_iter()
            .find(|v| v.name().eq_ignore_ascii_case(text.trim()))
            .or_else(|| parse_bool(text).map(Promote::from))
    }

    /// Whether images are promoted in `mode`.
    pub fn applies(self, mode: Mode) -> bool {
        match self {
            Promote::Auto => matches!(mode, Mode::Complementary | Mode::Infinite),
            Promote::Always => mode != Mode::Off,
            Promote::Never => false,
        }
    }
}

impl From<bool> for Promote {
    fn from(promote: bool) -> Self {
        if promote {
            Promote::Always
        } else {
            Promote::Never
        }
    }
}

/// Which depth images the application can observe revz may still reverse.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Observable {
    /// None: an image read by shaders or copied from keeps standard depth.
    None,
    /// Images read only by copies (screenshots, picking, test readback) are reversed, their
    /// copies converted (`copy_values`); images shaders read (sampled, storage, input
    /// attachments) or the host maps (linear tiling) stay native.
    #[default]
    Copies,
    /// Every depth image is reversed, whoever reads it.
    All,
}

impl Observable {
    const NAMES: &'static [&'static str] = &["none", "copies", "all"];

    pub fn name(self) -> &'static str {
        Observable::NAMES[self as usize]
    }

    /// Parses a name; `true` and `false` are read as `all` and `none`.
    pub fn parse(text: &str) -> Option<Observable> {
        let all = [Observable::None, Observable::Copies, Observable::All];
        all.into_iter()
            .find(|v| v.name().eq_ignore_ascii_case(text.trim()))
            .or_else(|| parse_bool(text).map(Observable::from))
    }
}

impl From<bool> for Observable {
    fn from(reverse: bool) -> Self {
        if reverse {
            Observable::All
        } else {
            Observable::None
        }
    }
}

/// What copies out of a reversed depth image hand the application, and what copies into one
/// are taken to hold.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CopyValues {
    /// The standard values the application would have without revz: converted on the way
    /// out and in (`crate::depth_copy`).
    #[default]
    Standard,
    /// The values revz stores, reversed, as they are (for tools that measure the stored
    /// precision, such as the tester's accuracy report).
    Stored,
}

impl CopyValues {
    const NAMES: &'static [&'static str] = &["standard", "stored"];

    pub fn name(self) -> &'static str {
        CopyValues::NAMES[self as usize]
    }

    pub fn parse(text: &str) -> Option<CopyValues> {
        [CopyValues::Standard, CopyValues::Stored]
            .into_iter()
            .find(|v| v.name().eq_ignore_ascii_case(text.trim()))
    }
}

/// How draws into reversed attachments get their flipped compare op.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CompareOp {
    /// `vkCmdSetDepthCompareOp` (Vulkan 1.3 or `VK_EXT_extended_dynamic_state`); devices with
    /// neither get variants.
    #[default]
    Dynamic,
    /// A second pipeline with the flipped compare op, bound for those draws.
    Variants,
}

impl CompareOp {
    const NAMES: &'static [&'static str] = &["dynamic", "variants"];

    pub fn name(self) -> &'static str {
        CompareOp::NAMES[self as usize]
    }

    pub fn parse(text: &str) -> Option<CompareOp> {
        [CompareOp::Dynamic, CompareOp::Variants]
            .into_iter()
            .find(|v| v.name().eq_ignore_ascii_case(text.trim()))
    }
}

/// The settings one instance runs with.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Settings {
    pub mode: Mode,
    pub far_clip: FarClip,
    /// Which depth images the application can observe (sampled, copied from, ...) are still
    /// reversed; those hand reversed values to the shaders or the CPU that read them.
    pub reverse_observable: Observable,
    /// What copies out of and into reversed depth images carry.
    pub copy_values: CopyValues,
    /// Dynamic compare ops or pipeline variants.
    pub compare_op: CompareOp,
    /// Whether D16/D24 depth images are created as D32_SFLOAT (D32_SFLOAT_S8_UINT).
    pub promote_depth_formats: Promote,
    /// The log level (per process: the first instance's settings install the logger).
    pub log_level: LevelFilter,
    /// Append the log to this file instead of stderr.
    pub log_file: Option<PathBuf>,
    /// Write the depth profile (`crate::profile`) to this file, or into this directory.
    pub report: Option<PathBuf>,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            mode: Mode::default(),
            far_clip: FarClip::default(),
            reverse_observable: Observable::Copies,
            copy_values: CopyValues::Standard,
            compare_op: CompareOp::Dynamic,
            promote_depth_formats: Promote::Auto,
            log_level: LevelFilter::Off,
            log_file: None,
            report: None,
        }
    }
}

/// Identifies one setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Key {
    Mode,
    FarClip,
    ReverseObservable,
    CopyValues,
    CompareOp,
    PromoteDepthFormats,
    Log,
    LogFile,
    Report,
}

/// What values a setting takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// One of a list of names (case-insensitive).
    Choice(&'static [&'static str]),
    /// `true` or `false` (also `1`/`0`, `on`/`off`, `yes`/`no` in text sources).
    Bool,
    /// A file path.
    Path,
}

/// The description of one setting: its name in every source, its values and default. This
/// table is the single list of settings; the manifests' settings and the README follow it
/// (a test checks the manifests).
#[derive(Debug)]
pub struct SettingSpec {
    pub key: Key,
    /// The name in the config file and in `VK_EXT_layer_settings`.
    pub name: &'static str,
    /// The environment variable.
    pub env: &'static str,
    pub kind: Kind,
    /// The default, as text.
    pub default: &'static str,
    pub description: &'static str,
}

/// Every setting.
pub const SETTINGS: &[SettingSpec] = &[
    SettingSpec {
        key: Key::Mode,
        name: "mode",
        env: "REVZ_MODE",
        kind: Kind::Choice(Mode::NAMES),
        default: "complementary",
        description: "Depth policy: off passes everything through; flip reverses depth by \
                      flipping the viewport depth range; complementary and infinite rewrite \
                      projection matrices to finite or infinite reversed-Z.",
    },
    SettingSpec {
        key: Key::FarClip,
        name: "far_clip",
        env: "REVZ_FAR_CLIP",
        kind: Kind::Choice(FarClip::NAMES),
        default: "remove",
        description: "In infinite mode: remove the far plane, or keep far clipping by clearing \
                      depth to n/f.",
    },
    SettingSpec {
        key: Key::ReverseObservable,
        name: "reverse_observable",
        env: "REVZ_REVERSE_OBSERVABLE",
        kind: Kind::Choice(Observable::NAMES),
        default: "copies",
        description: "Which depth images the application can read back are reversed anyway: \
                      none; copies (images only copied from, not read by shaders: their \
                      copies are converted, see copy_values); all (shaders then read \
                      reversed values). true and false mean all and none.",
    },
    SettingSpec {
        key: Key::CopyValues,
        name: "copy_values",
        env: "REVZ_COPY_VALUES",
        kind: Kind::Choice(CopyValues::NAMES),
        default: "standard",
        description: "What copies out of reversed depth images give the application, and what \
                      copies into them are taken to hold: standard (the values it would have \
                      without revz, converted on the way) or stored (revz's reversed values as \
                      they are, for measuring the stored precision).",
    },
    SettingSpec {
        key: Key::CompareOp,
        name: "compare_op",
        env: "REVZ_COMPARE_OP",
        kind: Kind::Choice(CompareOp::NAMES),
        default: "dynamic",
        description: "How draws into reversed attachments get the flipped depth compare op: \
                      dynamic (vkCmdSetDepthCompareOp; a device without Vulkan 1.3 or \
                      VK_EXT_extended_dynamic_state uses variants anyway) or variants (revz \
                      creates a second pipeline with the flipped compare op and binds it for \
                      those draws).",
    },
    SettingSpec {
        key: Key::PromoteDepthFormats,
        name: "promote_depth_formats",
        env: "REVZ_PROMOTE_DEPTH_FORMATS",
        kind: Kind::Choice(Promote::NAMES),
        default: "auto",
        description: "Create D16 and D24 depth images as D32_SFLOAT (D32_SFLOAT_S8_UINT with \
                      stencil), where the device supports it and their bytes are not copied \
                      (no transfer usage, optimal tiling): auto (in complementary and \
                      infinite), always (in every mode but off) or never; true and false read \
                      as always and never. Reversed depth gains precision only in float \
                      storage.",
    },
    SettingSpec {
        key: Key::Log,
        name: "log",
        env: "REVZ_LOG",
        kind: Kind::Choice(crate::logging::LEVEL_NAMES),
        default: "off",
        description: "Log level of the layer's messages.",
    },
    SettingSpec {
        key: Key::LogFile,
        name: "log_file",
        env: "REVZ_LOG_FILE",
        kind: Kind::Path,
        default: "",
        description: "Append the log to this file instead of stderr.",
    },
    SettingSpec {
        key: Key::Report,
        name: "report",
        env: "REVZ_REPORT",
        kind: Kind::Path,
        default: "",
        description: "Write the depth profile (JSON: depth images, pipelines and the path \
                      their draws take, draws per path per frame) to this file, or into this \
                      directory; rewritten every few seconds and when the device is destroyed.",
    },
];

impl SettingSpec {
    /// The setting called `name` in files and layer settings.
    pub fn named(name: &str) -> Option<&'static SettingSpec> {
        SETTINGS.iter().find(|spec| spec.name == name)
    }

    /// What the setting accepts, for warnings.
    pub fn accepted(&self) -> String {
        match self.kind {
            Kind::Choice(names) => format!("one of: {}", names.join(", ")),
            Kind::Bool => "true or false".to_owned(),
            Kind::Path => "a file path".to_owned(),
        }
    }
}

/// A setting's value as a source gives it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Value {
    Text(String),
    Bool(bool),
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Text(text) => write!(f, "'{text}'"),
            Value::Bool(value) => write!(f, "{value}"),
        }
    }
}

fn parse_bool(text: &str) -> Option<bool> {
    match text.trim().to_ascii_lowercase().as_str() {
        "true" | "1" | "on" | "yes" => Some(true),
        "false" | "0" | "off" | "no" => Some(false),
        _ => None,
    }
}

impl Settings {
    /// Sets one setting from `value`. On a value it cannot use, returns the warning text
    /// (without its origin) and leaves the setting as it was, except `mode`, which becomes
    /// `off`.
    pub fn apply(&mut self, spec: &SettingSpec, value: &Value) -> Result<(), String> {
        let text = match value {
            Value::Text(text) => Some(text.as_str()),
            Value::Bool(_) => None,
        };
        let applied = match spec.key {
            Key::Mode => text.and_then(Mode::parse).map(|m| self.mode = m),
            Key::FarClip => text.and_then(FarClip::parse).map(|v| self.far_clip = v),
            Key::ReverseObservable => match value {
                Value::Bool(b) => Some(Observable::from(*b)),
                Value::Text(text) => Observable::parse(text),
            }
            .map(|v| self.reverse_observable = v),
            Key::CopyValues => text
                .and_then(CopyValues::parse)
                .map(|v| self.copy_values = v),
            Key::CompareOp => text.and_then(CompareOp::parse).map(|v| self.compare_op = v),
            Key::PromoteDepthFormats => match value {
                Value::Bool(b) => Some(Promote::from(*b)),
                Value::Text(text) => Promote::parse(text),
            }
            .map(|v| self.promote_depth_formats = v),
            Key::Log => text
                .and_then(crate::logging::parse_level)
                .map(|l| self.log_level = l),
            Key::LogFile => text
                .filter(|t| !t.trim().is_empty())
                .map(|t| self.log_file = Some(PathBuf::from(t))),
            Key::Report => text
                .filter(|t| !t.trim().is_empty())
                .map(|t| self.report = Some(PathBuf::from(t))),
        };
        if applied.is_some() {
            return Ok(());
        }
        let fallback = if spec.key == Key::Mode {
            // A typo must not silently enable a rewriting mode.
            self.mode = Mode::Off;
            "using off".to_owned()
        } else {
            format!("using {}", self.describe(spec.key))
        };
        Err(format!(
            "{value} is not a valid {} (expected {}); {fallback}",
            spec.name,
            spec.accepted()
        ))
    }

    /// The current value of a setting, as text.
    pub fn describe(&self, key: Key) -> String {
        match key {
            Key::Mode => self.mode.name().to_owned(),
            Key::FarClip => self.far_clip.name().to_owned(),
            Key::ReverseObservable => self.reverse_observable.name().to_owned(),
            Key::CopyValues => self.copy_values.name().to_owned(),
            Key::CompareOp => self.compare_op.name().to_owned(),
            Key::PromoteDepthFormats => self.promote_depth_formats.name().to_owned(),
            Key::Log => self.log_level.to_string().to_lowercase(),
            Key::LogFile => self
                .log_file
                .as_ref()
                .map_or("stderr".to_owned(), |p| p.display().to_string()),
            Key::Report => self
                .report
                .as_ref()
                .map_or("none".to_owned(), |p| p.display().to_string()),
        }
    }

    /// One line with every setting but the mode, for the load log line.
    pub fn summary(&self) -> String {
        SETTINGS
            .iter()
            .filter(|spec| spec.key != Key::Mode)
            .map(|spec| format!("{}={}", spec.name, self.describe(spec.key)))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// What identifies the process to per-application config sections.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct AppIdentity {
    /// The executable's file name (`vkcube`, not its path).
    pub executable: Option<String>,
    /// `VkApplicationInfo::pApplicationName`.
    pub application_name: Option<String>,
    /// `VkApplicationInfo::pEngineName`.
    pub engine_name: Option<String>,
}

/// Everything resolution reads.
pub struct Sources<'a> {
    /// Environment lookup (the process environment in production).
    pub env: &'a dyn Fn(&str) -> Option<String>,
    /// Reads a config file (the file system in production).
    pub read_file: &'a dyn Fn(&std::path::Path) -> std::io::Result<String>,
    /// Tells whether a path is a directory (the file system in production).
    pub is_dir: &'a dyn Fn(&std::path::Path) -> bool,
    pub app: AppIdentity,
    /// Settings from `VK_EXT_layer_settings`, already extracted, in the order given.
    pub layer_settings: Vec<layer_settings::LayerSetting>,
}

impl fmt::Debug for Sources<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Sources")
            .field("app", &self.app)
            .field("layer_settings", &self.layer_settings)
            .finish_non_exhaustive()
    }
}

/// The outcome of [`resolve`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Resolved {
    pub settings: Settings,
    /// One line per problem, each naming its origin.
    pub warnings: Vec<String>,
    /// Where the settings came from, for the load line (`config file ...`).
    pub notes: Vec<String>,
    /// Where each setting that is not at its default got its value (the last source that
    /// set it, the highest in precedence): `environment REVZ_MODE`, `config file <path>`, ...
    pub origins: Vec<(Key, String)>,
}

impl Resolved {
    /// `key` was set from `origin` (a later, higher source replaces an earlier one).
    pub fn set_origin(&mut self, key: Key, origin: String) {
        self.origins.retain(|(k, _)| *k != key);
        self.origins.push((key, origin));
    }

    /// Applies `value` from `origin`: a problem is a warning beginning with `named` (where a
    /// person finds the value: the variable, the file and line, the setting). The origin
    /// is recorded where the value was taken, and for an unreadable mode (which means `off`).
    pub fn apply(&mut self, spec: &SettingSpec, value: &Value, origin: String, named: &str) {
        match self.settings.apply(spec, value) {
            Ok(()) => self.set_origin(spec.key, origin),
            Err(problem) => {
                self.warnings.push(format!("{named}: {problem}"));
                if spec.key == Key::Mode {
                    self.set_origin(spec.key, origin);
                }
            }
        }
    }

    /// Where `key` got its value: `default` where no source set it.
    pub fn origin(&self, key: Key) -> &str {
        self.origins
            .iter()
            .find(|(k, _)| *k == key)
            .map_or("default", |(_, origin)| origin)
    }
}

/// Resolves the settings from every source, in precedence order.
pub fn resolve(sources: &Sources<'_>) -> Resolved {
    let mut resolved = Resolved {
        settings: Settings::default(),
        warnings: Vec::new(),
        notes: Vec::new(),
        origins: Vec::new(),
    };

    // 4. The config file.
    if let Some((path, explicit)) = file::locate(sources.env) {
        if let Some(text) = read_optional(sources, &path, explicit, &mut resolved) {
            file::apply(&path, &text, &sources.app, &mut resolved);
        }
    }

    // 3. Vulkan Configurator's settings file.
    let (path, explicit) = vk_layer_settings::locate(sources.env, sources.is_dir);
    if let Some(text) = read_optional(sources, &path, explicit, &mut resolved) {
        vk_layer_settings::apply(&path, &text, &mut resolved);
    }

    // 2. Environment variables.
    for spec in SETTINGS {
        if let Some(text) = (sources.env)(spec.env).filter(|v| !v.trim().is_empty()) {
            let origin = format!("environment {}", spec.env);
            resolved.apply(spec, &Value::Text(text), origin, spec.env);
        }
    }

    // 1. VK_EXT_layer_settings.
    for setting in &sources.layer_settings {
        let origin = format!("VK_EXT_layer_settings '{}'", setting.name);
        let Some(spec) = SettingSpec::named(&setting.name) else {
            resolved.warnings.push(format!(
                "{origin}: unknown setting (known: {})",
                setting_names()
            ));
            continue;
        };
        match &setting.value {
            Ok(value) => {
                resolved.apply(spec, value, origin.clone(), &origin);
            }
            Err(problem) => resolved
                .warnings
                .push(format!("{origin}: {problem}; ignored")),
        }
    }

    resolved
}

/// Reads a settings file. A file at a default location may be absent; one the user named must
/// be readable, and a failure is a warning.
fn read_optional(
    sources: &Sources<'_>,
    path: &std::path::Path,
    explicit: bool,
    resolved: &mut Resolved,
) -> Option<String> {
    match (sources.read_file)(path) {
        Ok(text) => Some(text),
        Err(err) if explicit || err.kind() != std::io::ErrorKind::NotFound => {
            resolved.warnings.push(format!(
                "{}: cannot read the config file ({err}); using the defaults",
                path.display()
            ));
            None
        }
        Err(_) => None,
    }
}

/// The names of every setting, for warnings.
pub fn setting_names() -> String {
    SETTINGS
        .iter()
        .map(|spec| spec.name)
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests;
