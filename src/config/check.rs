//! Checks that need no rig: every number in its range, every exclusive choice made once.

use super::self_contact::unit;
use super::{
    ConfigError, ContactConfig, PairSpec, ParamSpec, SelfContactSpec, SelfDirection, SelfPairSpec,
    Stiffness, ATTRIBUTE_PREFIX, MAX_GAMMA, MAX_GROW_RINGS, MAX_PASSES,
};
use crate::selfcontact::DirectionSource;

impl ContactConfig {
    pub(super) fn invalid(
        &self,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> ConfigError {
        ConfigError::Invalid {
            file: self.file.clone(),
            field: field.into(),
            message: message.into(),
        }
    }

    /// Checks every number and every exclusive choice.
    pub(super) fn check(&self) -> Result<(), ConfigError> {
        if let Some(p) = self.passes {
            if !(1..=MAX_PASSES).contains(&p) {
                return Err(self.invalid("passes", format!("{p} is not in 1..={MAX_PASSES}")));
            }
        }
        self.check_params(&self.defaults, "defaults")?;
        for (i, o) in self.objects.iter().enumerate() {
            self.check_params(&o.params(), &format!("object[{i}]"))?;
            self.check_map_syntax(o.bulge_map.as_deref(), &format!("object[{i}].bulge_map"))?;
        }
        for (j, p) in self.pairs.iter().enumerate() {
            self.check_pair(p, &format!("pair[{j}]"))?;
        }
        if let Some(sc) = &self.self_contact {
            self.check_self_contact(sc)?;
        }
        Ok(())
    }

    fn check_self_contact(&self, sc: &SelfContactSpec) -> Result<(), ConfigError> {
        let at = "self_contact";
        for (field, value) in [("passes", sc.passes), ("max_passes", sc.max_passes)] {
            if let Some(p) = value {
                if !(1..=MAX_PASSES).contains(&p) {
                    return Err(self.invalid(
                        format!("{at}.{field}"),
                        format!("{p} is not in 1..={MAX_PASSES}"),
                    ));
                }
            }
        }
        if let (Some(p), Some(m)) = (sc.passes, sc.max_passes) {
            if m < p {
                return Err(self.invalid(
                    format!("{at}.max_passes"),
                    format!("{m} is below passes = {p}"),
                ));
            }
        }
        if let Some(t) = sc.threshold {
            if !(t.is_finite() && (0.0..1.0).contains(&t)) {
                return Err(self.invalid(
                    format!("{at}.threshold"),
                    format!("{t} is not in [0, 1) (a skin weight)"),
                ));
            }
        }
        if let Some(r) = sc.grow_rings {
            if r > MAX_GROW_RINGS {
                return Err(self.invalid(
                    format!("{at}.grow_rings"),
                    format!("{r} is not in 0..={MAX_GROW_RINGS}"),
                ));
            }
        }
        if let Some(k) = sc.stiffness {
            if !(k.is_finite() && (0.0..=1.0).contains(&k)) {
                return Err(self.invalid(
                    format!("{at}.stiffness"),
                    format!("{k} is not in [0, 1] (k̄, the share of the parent side)"),
                ));
            }
        }
        self.check_safeguard(sc.safeguard_angle, at)?;
        let params = ParamSpec {
            stiffness: None,
            tau: sc.tau,
            extent: sc.extent,
            extent_factor: sc.extent_factor,
            gamma: sc.gamma,
            omega: sc.omega,
        };
        self.check_params(&params, at)?;
        if let Some(k) = sc.joint_extent {
            if !(k.is_finite() && k > 0.0) {
                return Err(
                    self.invalid(format!("{at}.joint_extent"), "must be finite and positive")
                );
            }
            if sc.extent.is_some() || sc.extent_factor.is_some() {
                return Err(self.invalid(
                    format!("{at}.joint_extent"),
                    "give one of extent, extent_factor and joint_extent",
                ));
            }
        }
        for j in 0..sc.pairs.len() {
            self.check_self_pair(&sc.pairs, j)?;
        }
        if matches!(sc.direction, Some(SelfDirection(DirectionSource::Fixed(_)))) {
            return Err(self.invalid(
                format!("{at}.direction"),
                "must be \"skeleton\" or \"motion\" (a fixed direction is set per pair)",
            ));
        }
        Ok(())
    }

    /// `[[self_contact.pair]]` number `j` of `pairs`: a name given once, something set, a
    /// usable direction and numbers.
    fn check_self_pair(&self, pairs: &[SelfPairSpec], j: usize) -> Result<(), ConfigError> {
        let (p, field) = (&pairs[j], format!("self_contact.pair[{j}]"));
        if p.name.trim().is_empty() {
            return Err(self.invalid(format!("{field}.name"), "is empty"));
        }
        if let Some(first) = pairs[..j].iter().position(|o| o.name == p.name) {
            return Err(ConfigError::Duplicate {
                file: self.file.clone(),
                field: format!("{field}.name"),
                what: format!("joint pair '{}'", p.name),
                first: format!("self_contact.pair[{first}]"),
            });
        }
        if p.direction.is_none() && p.enabled.is_none() && !p.sets_params() {
            return Err(self.invalid(
                field,
                format!(
                    "sets nothing for '{}' (give direction, tau, gamma, omega, \
                     free_isolated_crease or enabled)",
                    p.name
                ),
            ));
        }
        if let Some(SelfDirection(DirectionSource::Fixed(d))) = p.direction {
            if unit(&[d.x, d.y, d.z]).is_none() {
                return Err(self.invalid(format!("{field}.direction"), "is zero or not finite"));
            }
        }
        let own = ParamSpec {
            tau: p.tau,
            gamma: p.gamma,
            omega: p.omega,
            ..ParamSpec::default()
        };
        self.check_params(&own, &field)
    }

    fn check_params(&self, p: &ParamSpec, at: &str) -> Result<(), ConfigError> {
        if let Some(Stiffness(k)) = p.stiffness {
            if k.is_nan() || k <= 0.0 {
                return Err(self.invalid(
                    format!("{at}.stiffness"),
                    format!("{k} is not a positive number or \"rigid\""),
                ));
            }
        }
        let finite = |v: Option<f64>| v.is_none_or(f64::is_finite);
        let positive = |v: Option<f64>| v.is_none_or(|x| x.is_finite() && x > 0.0);
        let checks = [
            ("tau", finite(p.tau), "must be finite"),
            ("extent", positive(p.extent), "must be finite and positive"),
            (
                "extent_factor",
                positive(p.extent_factor),
                "must be finite and positive",
            ),
            (
                "gamma",
                p.gamma.is_none_or(|g| (0.0..=MAX_GAMMA).contains(&g)),
                "must be between 0 (no bulge) and 10 (ten times the lost volume)",
            ),
            (
                "omega",
                p.omega.is_none_or(|w| w.is_finite() && w >= 0.0),
                "must be finite and non-negative",
            ),
        ];
        if let Some((name, _, why)) = checks.iter().find(|c| !c.1) {
            return Err(self.invalid(format!("{at}.{name}"), *why));
        }
        if p.extent.is_some() && p.extent_factor.is_some() {
            return Err(self.invalid(
                format!("{at}.extent_factor"),
                "give extent or extent_factor, not both",
            ));
        }
        Ok(())
    }

    fn check_map_syntax(&self, map: Option<&str>, field: &str) -> Result<(), ConfigError> {
        match map {
            Some(m) if m.trim().is_empty() => Err(self.invalid(field, "is empty")),
            Some(m) if m.strip_prefix(ATTRIBUTE_PREFIX).is_some_and(str::is_empty) => {
                Err(self.invalid(field, "names no attribute (attribute:NAME)"))
            }
            _ => Ok(()),
        }
    }

    /// A safeguard angle must be a number of degrees in `(0, 90]`.
    fn check_safeguard(&self, angle: Option<f64>, at: &str) -> Result<(), ConfigError> {
        match angle {
            Some(a) if !(a > 0.0 && a <= 90.0) => Err(self.invalid(
                format!("{at}.safeguard_angle"),
                format!("{a} is not in (0, 90] (degrees)"),
            )),
            _ => Ok(()),
        }
    }

    fn check_pair(&self, p: &PairSpec, at: &str) -> Result<(), ConfigError> {
        if p.tau.is_some_and(|t| !t.is_finite()) {
            return Err(self.invalid(format!("{at}.tau"), "must be finite"));
        }
        self.check_safeguard(p.safeguard_angle, at)?;
        if p.direction.is_some() && p.direction_keys.is_some() {
            return Err(self.invalid(
                format!("{at}.direction_keys"),
                "give direction or direction_keys, not both",
            ));
        }
        if let Some(d) = p.direction {
            if !usable_direction(&d) {
                return Err(self.invalid(
                    format!("{at}.direction"),
                    "is zero, not finite or too long to normalize",
                ));
            }
        }
        if let Some(keys) = &p.direction_keys {
            self.check_keys(keys, &format!("{at}.direction_keys"))?;
        }
        Ok(())
    }

    fn check_keys(&self, keys: &[[f64; 4]], field: &str) -> Result<(), ConfigError> {
        if keys.is_empty() {
            return Err(self.invalid(field, "has no key"));
        }
        for (k, key) in keys.iter().enumerate() {
            if !key[0].is_finite() {
                return Err(self.invalid(format!("{field}[{k}]"), "time is not finite"));
            }
            if !usable_direction(&[key[1], key[2], key[3]]) {
                return Err(
                    self.invalid(format!("{field}[{k}]"), "direction is zero or not finite")
                );
            }
            if let Some(j) = keys[..k].iter().position(|o| o[0] == key[0]) {
                return Err(self.invalid(
                    format!("{field}[{k}]"),
                    format!("time {} is already keyed by [{j}]", key[0]),
                ));
            }
        }
        Ok(())
    }
}

/// A direction that normalizes to a unit vector: finite, non-zero, and a finite non-zero
/// length computed plainly (`[1e308, 1e308, 1e308]` overflows it and normalized to zero,
/// failing only mid-run, found by fuzzing; `[1e-200, 0, 0]` underflows it: both refused, as
/// the passes normalize a direction without scaling it first).
pub(super) fn usable_direction(d: &[f64; 3]) -> bool {
    let length = d.iter().map(|x| x * x).sum::<f64>().sqrt();
    d.iter().all(|x| x.is_finite()) && length.is_finite() && length > 0.0
}
