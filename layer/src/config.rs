//! Layer settings, read once per `VkInstance`.
//!
//! For now the only source is the environment (`REVZ_MODE`); configuration files and
//! `VK_EXT_layer_settings` come later and will feed the same [`Config`]. A bad value never
//! fails: it produces one warning naming the accepted values, and the default applies.

use std::fmt;

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

    /// The spelling used in `REVZ_MODE` and in log lines.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Off => "off",
            Mode::Flip => "flip",
            Mode::Complementary => "complementary",
            Mode::Infinite => "infinite",
        }
    }

    /// Parses a mode name (case-insensitive, surrounding blanks ignored).
    pub fn parse(text: &str) -> Result<Mode, UnknownMode> {
        let wanted = text.trim();
        Mode::ALL
            .into_iter()
            .find(|mode| mode.name().eq_ignore_ascii_case(wanted))
            .ok_or_else(|| UnknownMode(text.to_owned()))
    }

    /// Whether this build of the layer acts on the mode yet. Modes it does not implement
    /// pass everything through, and the load line says so.
    pub fn is_implemented(self) -> bool {
        self == Mode::Off
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A mode name that is not one of [`Mode::ALL`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownMode(pub String);

impl fmt::Display for UnknownMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let valid: Vec<&str> = Mode::ALL.iter().map(|m| m.name()).collect();
        write!(
            f,
            "'{}' is not a valid mode (expected one of: {})",
            self.0,
            valid.join(", ")
        )
    }
}

/// The settings one instance runs with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Config {
    pub mode: Mode,
}

/// The environment variable that selects the mode.
pub const MODE_VAR: &str = "REVZ_MODE";

impl Config {
    /// Reads the configuration through `lookup` (the environment in production). Problems are
    /// returned as warnings for the caller to log, never as errors.
    pub fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> (Config, Vec<String>) {
        let mut config = Config::default();
        let mut warnings = Vec::new();
        if let Some(value) = lookup(MODE_VAR).filter(|v| !v.trim().is_empty()) {
            match Mode::parse(&value) {
                Ok(mode) => config.mode = mode,
                Err(unknown) => {
                    // A typo must not silently enable a rewriting mode: fall back to `off`.
                    config.mode = Mode::Off;
                    warnings.push(format!("{MODE_VAR}: {unknown}; using off"));
                }
            }
        }
        (config, warnings)
    }

    /// Reads the configuration from the process environment.
    pub fn from_env() -> (Config, Vec<String>) {
        Config::from_lookup(|name| std::env::var(name).ok())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config_with(mode: Option<&str>) -> (Config, Vec<String>) {
        Config::from_lookup(|name| {
            assert_eq!(name, MODE_VAR);
            mode.map(str::to_owned)
        })
    }

    #[test]
    fn every_mode_name_round_trips() {
        for mode in Mode::ALL {
            assert_eq!(Mode::parse(mode.name()), Ok(mode));
            assert_eq!(Mode::parse(&mode.name().to_uppercase()), Ok(mode));
            assert_eq!(Mode::parse(&format!(" {mode} ")), Ok(mode));
        }
    }

    #[test]
    fn unset_or_empty_uses_the_default_without_warning() {
        assert_eq!(config_with(None), (Config::default(), vec![]));
        assert_eq!(config_with(Some("  ")), (Config::default(), vec![]));
        assert_eq!(Config::default().mode, Mode::Complementary);
    }

    #[test]
    fn unknown_mode_warns_with_the_valid_names_and_falls_back_to_off() {
        let (config, warnings) = config_with(Some("reverse"));
        assert_eq!(config.mode, Mode::Off);
        assert_eq!(
            warnings,
            vec!["REVZ_MODE: 'reverse' is not a valid mode \
                 (expected one of: off, flip, complementary, infinite); using off"
                .to_owned()]
        );
    }

    #[test]
    fn explicit_mode_is_taken() {
        assert_eq!(config_with(Some("infinite")).0.mode, Mode::Infinite);
        assert_eq!(config_with(Some("flip")).0.mode, Mode::Flip);
    }
}
