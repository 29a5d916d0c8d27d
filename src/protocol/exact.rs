//! Fixed-size arrays in protocol and hardware files that must have exactly their length:
//! serde's own impl for `[T; N]` stops after N elements and silently drops any more
//! (`retract_speed_mm_s = [0.1, 5.0, "garbage"]` read as `[0.1, 5.0]`).

use serde::de::{Deserialize, Deserializer, Error};

/// `#[serde(deserialize_with = "exactly")]`: an array of exactly `N` values.
pub fn exactly<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    let values: Vec<T> = Vec::deserialize(d)?;
    let got = values.len();
    values
        .try_into()
        .map_err(|_| D::Error::invalid_length(got, &format!("exactly {N} values").as_str()))
}

#[cfg(test)]
mod tests {
    #[derive(Debug, serde::Deserialize)]
    struct S {
        #[serde(deserialize_with = "super::exactly")]
        a: [f64; 2],
    }

    #[test]
    fn more_or_fewer_values_or_wrong_ones_are_errors() {
        assert_eq!(toml::from_str::<S>("a = [0.1, 5.0]").unwrap().a, [0.1, 5.0]);
        for bad in [
            "a = [0.1, 5.0, 7.0]",
            "a = [0.1]",
            "a = [0.1, 5.0, \"garbage\", {x=1}]",
        ] {
            assert!(toml::from_str::<S>(bad).is_err(), "{bad}");
        }
        let e = toml::from_str::<S>("a = [1, 2, 3]")
            .unwrap_err()
            .to_string();
        assert!(e.contains("exactly 2 values"), "{e}");
    }
}
