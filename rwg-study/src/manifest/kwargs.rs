//! An `[[envs]]` entry's `kwargs` as read from the manifest: every value
//! with where it stands, so that what `gym.make` cannot receive is refused at
//! its line with its key named. nan and infinities are floats and pass (the
//! bridge encodes them, [`rwg_gym::kwargs`]); a TOML date, time or datetime
//! is refused (Python would get a dict, not a datetime): give it as a string.

use serde::de::{Deserialize, Deserializer, MapAccess, SeqAccess, Visitor};
use std::fmt;
use std::ops::Range;
use toml::Spanned;

/// The key under which the `toml` crate hands over a date or time.
const DATETIME_KEY: &str = "$__toml_private_datetime";

/// A `kwargs` table as read: its keys in order, each value with its span.
#[derive(Debug, Clone)]
pub(crate) struct RawKwargs(Vec<(String, Spanned<RawValue>)>);

/// A value of a `kwargs` table.
#[derive(Debug, Clone)]
pub(crate) enum RawValue {
    /// A string, number or boolean.
    Plain(toml::Value),
    /// A date, time or datetime, as written.
    Datetime(String),
    /// An array.
    Array(Vec<Spanned<RawValue>>),
    /// A table.
    Table(RawKwargs),
}

impl RawKwargs {
    /// The table, or (span, message) of the first value `gym.make` cannot
    /// receive; `key` names the table in messages (`envs[0].kwargs`).
    pub(crate) fn to_table(&self, key: &str) -> Result<toml::Table, (Range<usize>, String)> {
        let mut t = toml::Table::new();
        for (k, v) in &self.0 {
            t.insert(k.clone(), value(v, &format!("{key}.{k}"))?);
        }
        Ok(t)
    }
}

fn value(v: &Spanned<RawValue>, key: &str) -> Result<toml::Value, (Range<usize>, String)> {
    Ok(match v.get_ref() {
        RawValue::Plain(p) => p.clone(),
        RawValue::Datetime(d) => {
            return Err((
                v.span(),
                format!(
                    "{key}: the TOML date/time {d} would reach gym.make as a dict, not a \
                     datetime; give it as a string (\"{d}\") and parse it in the env"
                ),
            ))
        }
        RawValue::Array(a) => toml::Value::Array(
            a.iter()
                .enumerate()
                .map(|(i, x)| value(x, &format!("{key}[{i}]")))
                .collect::<Result<_, _>>()?,
        ),
        RawValue::Table(t) => toml::Value::Table(t.to_table(key)?),
    })
}

/// `kwargs` (a TOML table) as the Gymnasium bridge sends it: JSON with
/// nan/inf encoded ([`rwg_gym::kwargs`]); a date or time as its text.
pub fn to_json(t: &toml::Table) -> serde_json::Map<String, serde_json::Value> {
    t.iter().map(|(k, v)| (k.clone(), json(v))).collect()
}

fn json(v: &toml::Value) -> serde_json::Value {
    use serde_json::Value as J;
    match v {
        toml::Value::String(s) => J::String(s.clone()),
        toml::Value::Integer(i) => J::from(*i),
        toml::Value::Float(f) => rwg_gym::kwargs::float(*f),
        toml::Value::Boolean(b) => J::Bool(*b),
        toml::Value::Datetime(d) => J::String(d.to_string()),
        toml::Value::Array(a) => J::Array(a.iter().map(json).collect()),
        toml::Value::Table(t) => rwg_gym::kwargs::object(to_json(t)),
    }
}

impl<'de> Deserialize<'de> for RawKwargs {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match RawValue::deserialize(d)? {
            RawValue::Table(t) => Ok(t),
            _ => Err(serde::de::Error::custom("expected a table")),
        }
    }
}

impl<'de> Deserialize<'de> for RawValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(RawVisitor)
    }
}

struct RawVisitor;

impl<'de> Visitor<'de> for RawVisitor {
    type Value = RawValue;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a TOML value")
    }

    fn visit_bool<E>(self, v: bool) -> Result<RawValue, E> {
        Ok(RawValue::Plain(toml::Value::Boolean(v)))
    }

    fn visit_i64<E>(self, v: i64) -> Result<RawValue, E> {
        Ok(RawValue::Plain(toml::Value::Integer(v)))
    }

    fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<RawValue, E> {
        i64::try_from(v)
            .map(|v| RawValue::Plain(toml::Value::Integer(v)))
            .map_err(|_| E::custom(format!("{v} is out of range")))
    }

    fn visit_f64<E>(self, v: f64) -> Result<RawValue, E> {
        Ok(RawValue::Plain(toml::Value::Float(v)))
    }

    fn visit_str<E>(self, v: &str) -> Result<RawValue, E> {
        Ok(RawValue::Plain(toml::Value::String(v.to_string())))
    }

    fn visit_string<E>(self, v: String) -> Result<RawValue, E> {
        Ok(RawValue::Plain(toml::Value::String(v)))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<RawValue, A::Error> {
        let mut out = Vec::new();
        while let Some(v) = seq.next_element::<Spanned<RawValue>>()? {
            out.push(v);
        }
        Ok(RawValue::Array(out))
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<RawValue, A::Error> {
        let mut out = Vec::new();
        while let Some(k) = map.next_key::<String>()? {
            if k == DATETIME_KEY && out.is_empty() {
                let text: String = map.next_value()?;
                return Ok(RawValue::Datetime(text));
            }
            let v = map.next_value::<Spanned<RawValue>>()?;
            out.push((k, v));
        }
        Ok(RawValue::Table(RawKwargs(out)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Deserialize)]
    struct Doc {
        kwargs: RawKwargs,
    }

    fn read(text: &str) -> Result<toml::Table, (Range<usize>, String)> {
        let d: Doc = toml::from_str(text).unwrap();
        d.kwargs.to_table("kwargs")
    }

    #[test]
    fn values_read_as_the_toml_crate_reads_them() {
        let text = "kwargs = { a = nan, b = -inf, c = [1, 2.5, \"x\"], d = { e = true } }";
        let want: toml::Table = toml::from_str::<toml::Table>(text).unwrap()["kwargs"]
            .as_table()
            .unwrap()
            .clone();
        let got = read(text).unwrap();
        // nan != nan: compare the text
        assert_eq!(got.to_string(), want.to_string());
        assert_eq!(
            serde_json::Value::Object(to_json(&got)),
            serde_json::json!({"a": {"$rwg": "nan"}, "b": {"$rwg": "-inf"},
                               "c": [1, 2.5, "x"], "d": {"e": true}})
        );
    }

    #[test]
    fn a_datetime_is_refused_at_its_place_with_its_key() {
        let text = "kwargs = { a = 1, t = { at = [2, 07:32:00] } }";
        let (span, msg) = read(text).unwrap_err();
        assert_eq!(&text[span], "07:32:00");
        assert!(
            msg.starts_with("kwargs.t.at[1]: the TOML date/time 07:32:00"),
            "{msg}"
        );
        let text = "[kwargs]\nwhen = 1979-05-27\n";
        let (span, msg) = read(text).unwrap_err();
        assert_eq!(&text[span], "1979-05-27");
        assert!(msg.contains("(\"1979-05-27\")"), "{msg}");
    }
}
