//! Painted bulge maps (2021 Sec. 7): read from a file confined to the configuration's folder,
//! or from a custom vertex attribute of the rig, per welded vertex.

use super::{read_text, ConfigError, ContactConfig, ATTRIBUTE_PREFIX};
use crate::mesh::WeldedMesh;
use crate::rig::{Confinement, Rig};

impl ContactConfig {
    fn map_error(&self, field: &str, map: &str, message: impl Into<String>) -> ConfigError {
        ConfigError::BulgeMap {
            file: self.file.clone(),
            field: field.to_string(),
            map: map.to_string(),
            message: message.into(),
        }
    }

    /// The painted map of body `b` per welded vertex.
    pub(super) fn painted(
        &self,
        rig: &Rig,
        welded: &WeldedMesh,
        b: usize,
        map: &str,
        field: &str,
    ) -> Result<Vec<f64>, ConfigError> {
        let body = &rig.bodies[b];
        let values = match map.strip_prefix(ATTRIBUTE_PREFIX) {
            Some(name) => self.attribute_map(rig, b, name, field)?,
            None => self.file_map(map, field)?,
        };
        if values.len() != body.vertex_count() {
            return Err(ConfigError::BulgeCount {
                file: self.file.clone(),
                field: field.to_string(),
                map: map.to_string(),
                body: body.name.clone(),
                expected: body.vertex_count(),
                got: values.len(),
            });
        }
        if let Some(v) = values.iter().position(|x| !x.is_finite()) {
            let message = format!("value of vertex {v} is {}, not finite", values[v]);
            return Err(self.map_error(field, map, message));
        }
        if welded.to_welded.len() != values.len() {
            let message = "the welded mesh does not match the body";
            return Err(self.map_error(field, map, message));
        }
        Ok(welded.gather(&values))
    }

    fn attribute_map(
        &self,
        rig: &Rig,
        b: usize,
        name: &str,
        field: &str,
    ) -> Result<Vec<f64>, ConfigError> {
        rig.extra_attribute(b, name)
            .map(<[f64]>::to_vec)
            .ok_or_else(|| {
                let names: Vec<&str> = rig
                    .extra_attributes
                    .get(b)
                    .map(|l| l.iter().map(|(n, _)| n.as_str()).collect())
                    .unwrap_or_default();
                ConfigError::UnknownAttribute {
                    file: self.file.clone(),
                    field: field.to_string(),
                    body: rig.bodies[b].name.clone(),
                    attribute: name.to_string(),
                    available: if names.is_empty() {
                        "none".into()
                    } else {
                        names.join(", ")
                    },
                }
            })
    }

    /// Reads a map file confined to the configuration's folder.
    fn file_map(&self, map: &str, field: &str) -> Result<Vec<f64>, ConfigError> {
        let path = crate::rig::confined_path(&self.base_dir, map).map_err(|e| match e {
            Confinement::Refused(why) => self.map_error(
                field,
                map,
                format!("the path {why}: a bulge map must lie inside the configuration's folder"),
            ),
            Confinement::Unreadable(message) => self.map_error(field, map, message),
        })?;
        let text = read_text(&path)
            .map_err(|e| self.map_error(field, map, format!("cannot read: {e}")))?;
        parse_map(&text).map_err(|message| self.map_error(field, map, message))
    }
}

/// The numbers of a bulge-map text: whitespace separated, `#` starts a comment. Non-finite
/// values are an error.
pub fn parse_map(text: &str) -> Result<Vec<f64>, String> {
    let mut out = Vec::new();
    for (l, line) in text.lines().enumerate() {
        let content = line.split('#').next().unwrap_or("");
        for token in content.split_whitespace() {
            let v: f64 = token
                .parse()
                .map_err(|_| format!("line {}: '{token}' is not a number", l + 1))?;
            if !v.is_finite() {
                return Err(format!("line {}: value '{token}' is not finite", l + 1));
            }
            out.push(v);
        }
    }
    Ok(out)
}
