//! A setting that can be switched off, in files: a number, or the word
//! `"off"` (`Option<f64>` in code: `None` is off). A default that is on
//! cannot be switched off by leaving the key out, so the file says so.

use std::fmt;

use serde::de::{self, Deserializer, Visitor};
use serde::Serializer;

/// The word that switches a setting off.
pub const OFF: &str = "off";

/// Writes `Some(x)` as the number `x`, `None` as `"off"`.
pub fn serialize<S: Serializer>(value: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match value {
        Some(x) => s.serialize_f64(*x),
        None => s.serialize_str(OFF),
    }
}

/// Reads a number as `Some`, `"off"` as `None`.
pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    d.deserialize_any(NumberOrOff)
}

struct NumberOrOff;

impl Visitor<'_> for NumberOrOff {
    type Value = Option<f64>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "a number or \"{OFF}\"")
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Self::Value, E> {
        Ok(Some(v))
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Self::Value, E> {
        Ok(Some(v as f64))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Self::Value, E> {
        Ok(Some(v as f64))
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<Self::Value, E> {
        if v == OFF {
            Ok(None)
        } else {
            Err(E::invalid_value(de::Unexpected::Str(v), &self))
        }
    }
}

#[cfg(test)]
mod tests {
    #[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
    struct S {
        #[serde(with = "super")]
        x: Option<f64>,
    }

    #[test]
    fn a_number_or_off_reads_back() {
        for (text, x) in [
            ("x = 0.5", Some(0.5)),
            ("x = 2", Some(2.0)),
            ("x = \"off\"", None),
        ] {
            let s: S = toml::from_str(text).unwrap();
            assert_eq!(s.x, x);
            assert_eq!(
                toml::from_str::<S>(&toml::to_string(&s).unwrap()).unwrap(),
                s
            );
        }
        let e = toml::from_str::<S>("x = \"of\"").unwrap_err().to_string();
        assert!(e.contains("a number or \"off\""), "{e}");
    }
}
