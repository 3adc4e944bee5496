//! The contact configuration of a rig: a TOML file giving the parameters of the contact pass
//! ([`crate::pass`]) per object and per pair.
//!
//! ```toml
//! passes = 2                      # optional, ContactPass::with_passes
//! [defaults]                      # optional, for every object
//! stiffness = 1.0                 # pseudo-stiffness k, or "rigid"
//! tau = 0.0
//! extent = 0.3                    # φ̄ in scene units; or extent_factor = 0.5 (× rest size)
//! gamma = 1.0                     # bulge: 0 none, 1 the lost volume, at most 10
//! omega = 2.0
//! [[object]]
//! name = "ball"                   # a body name, or its index (integer or string)
//! stiffness = 0.5
//! bulge_map = "ball_bulge.txt"    # or "attribute:_BULGE"
//! [[pair]]
//! objects = ["ball", "thumb"]
//! tau = 0.6
//! safeguard_angle = 80.0          # degrees, in (0, 90]: Sec. 4.4's safeguard (default 80)
//! direction = [0.0, 1.0, 0.0]     # or direction_keys = [[t, x, y, z], ...]
//! [self_contact]                  # optional: joints folding into themselves
//! enabled = true
//! passes = 2                      # sweeps per frame (exactly, when given without max_passes)
//! max_passes = 6                  # up to this many while a fold still penetrates (default 6)
//! threshold = 0.05                # RegionOptions::threshold
//! grow_rings = 2
//! stiffness = 0.5                 # k̄ of the parent side, in [0, 1]
//! tau = -1.0                      # the paper's Fig. 13 and 15 (default)
//! safeguard_angle = 80.0          # degrees, in (0, 90] (default 80, the paper's)
//! joint_extent = 1.5              # φ̄ × the joint's size (default); or extent / extent_factor
//! gamma = 1.0                     # bulge: 0 none, 1 the lost volume, at most 10
//! omega = 2.0
//! turn_guard = true               # scale the displacement back where a face would turn over
//! bulge_guard = true              # scale the bulge back where it would enter the other part
//! free_isolated_crease = false    # true: isolated crease vertices stay out of the zones (lips)
//! direction = "skeleton"          # every pair's default: "skeleton" or "motion"
//! separated_from_skeleton = true  # also sibling subtrees and joints vs grandchildren (default)
//! [[self_contact.pair]]
//! name = "lips/head-jaw"          # a derived joint pair (`contact-skin info`)
//! direction = [0.0, -1.0, 0.0]    # W1's (parent side's) outward direction at the fold,
//!                                 # or "skeleton", or "motion" (relative motion of the parts)
//! gamma = 0.5                     # this pair's τ, γ, ω (each optional; default the section's)
//! free_isolated_crease = true     # and this (optional)
//! enabled = true                  # resolve it even if its sides cross at rest (or false: never)
//! [[self_contact.separated]]      # two regions of one body that share no vertex (Fig. 14)
//! sides = [["forearm", "hand"], ["hips"]]   # each side's joints (node names)
//! ```
//!
//! [`ContactConfig::load`] parses and checks every number (no rig needed);
//! [`ContactConfig::resolve`] maps names to bodies and reads the painted bulge maps, giving the
//! inputs of [`crate::pass::ContactPass::new`]; [`ContactConfig::resolve_self_contact`] gives
//! those of [`crate::selfcontact::pass::SelfContactPass::new`]. Every error is a
//! [`ConfigError`] naming the file and the field (`object[1].stiffness`,
//! `pair[0].direction_keys[2]`, `self_contact.pair[0].name`, ...).
//!
//! Reading (here) is followed by the checks that need no rig (`check`); the tables as read are
//! in `spec`, their resolution against a rig in `objects` (the contact pass), `self_contact`
//! (the self-contact pass) and `bulge_maps` (painted maps).

use crate::pass::{ObjectParams, PairOverride, DEFAULT_PASSES};
use serde::Deserialize;
use std::path::{Path, PathBuf};

mod bulge_maps;
mod check;
mod error;
mod objects;
mod self_contact;
mod spec;

pub use bulge_maps::parse_map;
pub use error::ConfigError;
pub use objects::rest_sizes;
pub use spec::{
    BodyRef, ObjectSpec, PairSpec, ParamSpec, SelfContactSettings, SelfContactSpec, SelfDirection,
    SelfPairSpec, SeparatedSpec, Stiffness,
};

/// Suffix of a rig's own configuration: `<rig stem>.contact.toml`, next to the rig.
pub const CONFIG_SUFFIX: &str = ".contact.toml";

/// Prefix of a `bulge_map` that names a custom vertex attribute of the glTF file.
pub const ATTRIBUTE_PREFIX: &str = "attribute:";

/// Largest accepted `gamma` (the bulge's share of the lost volume, Sec. 5.3: 1 restores it).
/// A larger bulge dwarfs the contact it balances, and its guard's collision tests then grow
/// with it (a hundred times the volume took 2.6 s per frame on the bending capsule, `-100` did
/// not finish in two minutes, 2026-12-05): such values are refused rather than run.
pub const MAX_GAMMA: f64 = 10.0;

/// Largest accepted `passes`.
pub const MAX_PASSES: usize = 16;

/// Largest accepted `self_contact.grow_rings`.
pub const MAX_GROW_RINGS: usize = 64;

/// Largest configuration or bulge-map file read (64 MiB): a guard against absurd inputs.
pub const MAX_FILE_BYTES: u64 = 64 << 20;

/// A rig's contact configuration (see the module documentation).
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactConfig {
    /// Passes per frame ([`crate::pass::ContactPass::with_passes`]).
    pub passes: Option<usize>,
    /// Parameters of every object.
    #[serde(default)]
    pub defaults: ParamSpec,
    /// Per-object parameters.
    #[serde(default, rename = "object")]
    pub objects: Vec<ObjectSpec>,
    /// Per-pair overrides.
    #[serde(default, rename = "pair")]
    pub pairs: Vec<PairSpec>,
    /// The `[self_contact]` table (`None` when the file has none: the pass defaults).
    #[serde(default)]
    pub self_contact: Option<SelfContactSpec>,
    /// The file it was read from (named in errors).
    #[serde(skip)]
    pub file: PathBuf,
    /// The folder bulge-map files are resolved in (and confined to).
    #[serde(skip)]
    pub base_dir: PathBuf,
}

/// What [`ContactConfig::resolve`] gives: per-body parameters, pair overrides, passes.
pub type Resolved = (Vec<ObjectParams>, Vec<PairOverride>, usize);

// ---------------------------------------------------------------------------------------------
// Reading

impl ContactConfig {
    /// Reads and checks a configuration file; bulge maps are resolved in its folder.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let io = |source| ConfigError::Io {
            file: path.to_path_buf(),
            source,
        };
        let text = read_text(path).map_err(io)?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Self::parse(&text, path, &base)
    }

    /// Parses and checks configuration text; bulge maps are resolved in `base_dir`. Errors name
    /// the file `<base_dir>/<inline>`.
    pub fn from_str_with_base(text: &str, base_dir: &Path) -> Result<Self, ConfigError> {
        Self::parse(text, &base_dir.join("<inline>"), base_dir)
    }

    /// Parses `text`, naming `file` in errors, and checks every number.
    pub fn parse(text: &str, file: &Path, base_dir: &Path) -> Result<Self, ConfigError> {
        let mut config: ContactConfig =
            toml::from_str(text).map_err(|e| parse_error(file, text, &e))?;
        config.file = file.to_path_buf();
        config.base_dir = base_dir.to_path_buf();
        config.check()?;
        Ok(config)
    }

    /// The configuration of the rig at `rig`: `explicit` when given (it must exist), else
    /// `<rig stem>.contact.toml` next to the rig when that file exists, else `None`.
    pub fn for_rig(rig: &Path, explicit: Option<&Path>) -> Result<Option<Self>, ConfigError> {
        match explicit {
            Some(p) => Self::load(p).map(Some),
            None => match default_path(rig) {
                Some(p) if p.is_file() => Self::load(&p).map(Some),
                _ => Ok(None),
            },
        }
    }

    /// Passes per frame (the default when the file does not say).
    pub fn passes(&self) -> usize {
        self.passes.unwrap_or(DEFAULT_PASSES)
    }
}

/// `<rig stem>.contact.toml` next to `rig` (`None` when the path has no file name).
pub fn default_path(rig: &Path) -> Option<PathBuf> {
    let stem = rig.file_stem()?.to_string_lossy();
    Some(rig.with_file_name(format!("{stem}{CONFIG_SUFFIX}")))
}

fn parse_error(file: &Path, text: &str, e: &toml::de::Error) -> ConfigError {
    let offset = e.span().map_or(0, |s| s.start.min(text.len()));
    let (line, column) = line_column(text, offset);
    ConfigError::Parse {
        file: file.to_path_buf(),
        field: field_at(text, line),
        line,
        column,
        message: e.message().trim().to_string(),
    }
}

/// 1-based line and column of byte `offset`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = text.get(..offset).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    (line, column)
}

/// The dotted path of the key on (or last written before) 1-based `line`: the enclosing table
/// (`object[1]`, `defaults`) and the key. A best effort for error messages.
fn field_at(text: &str, line: usize) -> String {
    let lines: Vec<&str> = text.lines().take(line.max(1)).collect();
    let (mut table, mut counts) = (String::new(), Vec::<(String, usize)>::new());
    let mut key = String::new();
    for l in &lines {
        let l = l.split('#').next().unwrap_or("").trim();
        if let Some(name) = l.strip_prefix("[[").and_then(|r| r.strip_suffix("]]")) {
            let name = name.trim().to_string();
            let n = match counts.iter_mut().find(|(k, _)| *k == name) {
                Some((_, c)) => {
                    *c += 1;
                    *c
                }
                None => {
                    counts.push((name.clone(), 0));
                    0
                }
            };
            (table, key) = (format!("{name}[{n}]"), String::new());
        } else if let Some(name) = l.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
            (table, key) = (name.trim().to_string(), String::new());
        } else if let Some((k, _)) = l.split_once('=') {
            key = k.trim().trim_matches('"').to_string();
        }
    }
    match (table.is_empty(), key.is_empty()) {
        (true, true) => "(top level)".into(),
        (true, false) => key,
        (false, true) => table,
        (false, false) => format!("{table}.{key}"),
    }
}

/// The text of a configuration or bulge-map file ([`crate::rig::read_whole`]: a regular file of
/// at most [`MAX_FILE_BYTES`]).
fn read_text(path: &Path) -> std::io::Result<String> {
    let bytes = crate::rig::read_whole(path, MAX_FILE_BYTES).map_err(|e| match e {
        crate::rig::Unreadable::Io(e) => e,
        refused => std::io::Error::other(refused.to_string()),
    })?;
    String::from_utf8(bytes).map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
}
