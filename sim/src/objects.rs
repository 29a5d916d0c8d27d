//! The object library: the paper's objects with YCB masses and sizes (`data/objects.toml`).

use serde::{Deserialize, Serialize};

use super::SimError;

const BUILT_IN: &str = include_str!("../data/objects.toml");

/// A graspable object of the simulated rig.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    pub name: String,
    #[serde(default)]
    pub ycb_id: Option<String>,
    pub mass_g: f64,
    /// Width across the pinch grasp.
    pub width_mm: f64,
    /// Extent along the slip axis that can stay between the fingers.
    pub length_mm: f64,
    pub mu_static: f64,
    pub mu_kinetic: f64,
    /// The object's own contact stiffness (small for deformable objects).
    pub stiffness_n_per_mm: f64,
    /// How far the centre of mass sits from the grasp's centre along the palm's depth axis
    /// (across both the pinch axis and the slip axis). Gravity acting there is a moment about
    /// the pinch axis that the fingers' friction must also hold; 0 for objects symmetric
    /// about the grasp.
    #[serde(default)]
    pub com_offset_mm: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LibraryFile {
    object: Vec<ObjectSpec>,
}

/// A set of objects looked up by name.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectLibrary {
    objects: Vec<ObjectSpec>,
}

impl ObjectLibrary {
    /// The library shipped with tmo.
    pub fn built_in() -> Self {
        Self::parse(BUILT_IN, "built-in objects.toml").expect("the built-in library is valid")
    }

    /// Parses a library file; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Self, SimError> {
        let file: LibraryFile = toml::from_str(text).map_err(|e| SimError::Config {
            origin: origin.to_string(),
            message: e.to_string(),
        })?;
        for o in &file.object {
            let bad = |what: &str| SimError::Config {
                origin: origin.to_string(),
                message: format!("object `{}`: {what}", o.name),
            };
            if !(o.mass_g > 0.0 && o.width_mm > 0.0 && o.length_mm > 0.0) {
                return Err(bad("mass_g, width_mm and length_mm must be positive"));
            }
            if !(o.mu_kinetic > 0.0 && o.mu_kinetic <= o.mu_static) {
                return Err(bad("expected 0 < mu_kinetic <= mu_static"));
            }
            if o.stiffness_n_per_mm <= 0.0 {
                return Err(bad("stiffness_n_per_mm must be positive"));
            }
            if o.com_offset_mm.is_nan() || o.com_offset_mm.abs() >= o.length_mm {
                return Err(bad(
                    "expected com_offset_mm to be a number smaller than length_mm",
                ));
            }
        }
        Ok(Self {
            objects: file.object,
        })
    }

    pub fn get(&self, name: &str) -> Result<&ObjectSpec, SimError> {
        self.objects
            .iter()
            .find(|o| o.name == name)
            .ok_or_else(|| SimError::UnknownObject {
                name: name.to_string(),
                known: self.names().join(", "),
            })
    }

    pub fn names(&self) -> Vec<&str> {
        self.objects.iter().map(|o| o.name.as_str()).collect()
    }

    pub fn iter(&self) -> impl Iterator<Item = &ObjectSpec> {
        self.objects.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_in_library_has_the_papers_objects() {
        let lib = ObjectLibrary::built_in();
        for name in [
            "crisps_can",
            "windex_bottle",
            "bleach_bottle",
            "mustard_bottle",
            "banana",
            "soup_can",
            "softball",
            "jello_box",
            "coffee_can",
            "foam_brick",
            "toy_cat",
            "rail_object",
        ] {
            lib.get(name).unwrap();
        }
        assert_eq!(lib.get("toy_cat").unwrap().mass_g, 66.0);
    }

    #[test]
    fn unknown_object_lists_the_known_ones() {
        let err = ObjectLibrary::built_in()
            .get("teapot")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("teapot") && err.contains("crisps_can"),
            "{err}"
        );
    }

    #[test]
    fn invalid_friction_is_rejected() {
        let text = r#"
[[object]]
name = "x"
mass_g = 1.0
width_mm = 1.0
length_mm = 1.0
mu_static = 0.5
mu_kinetic = 0.7
stiffness_n_per_mm = 1.0
"#;
        let err = ObjectLibrary::parse(text, "lib.toml")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("lib.toml") && err.contains("mu_kinetic"),
            "{err}"
        );
    }
}
