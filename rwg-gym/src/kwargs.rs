//! `gym.make`'s keyword arguments as the worker receives them: JSON, which
//! has no nan or infinities, so a float that is not finite travels as an
//! object whose only key is [`TAG`] (`{"$rwg": "nan"}`, `"inf"`, `"-inf"`),
//! and an object of the user's that has that one key is escaped as
//! `{"$rwg": {"$rwg": ...}}`. The worker decodes both (`decode_kwargs` in
//! `worker.py`), so `gym.make` gets the floats and objects the user wrote.

use serde_json::{Map, Value};

/// The key of an encoded value.
pub const TAG: &str = "$rwg";

/// `x` as the worker receives it: a JSON number, or the encoded nan/inf.
pub fn float(x: f64) -> Value {
    match serde_json::Number::from_f64(x) {
        Some(n) => Value::Number(n),
        None => {
            let text = if x.is_nan() {
                "nan"
            } else if x > 0.0 {
                "inf"
            } else {
                "-inf"
            };
            tagged(Value::String(text.into()))
        }
    }
}

/// The object `m` (its values already encoded) as the worker receives it:
/// escaped when its only key is [`TAG`].
pub fn object(m: Map<String, Value>) -> Value {
    if m.len() == 1 && m.contains_key(TAG) {
        tagged(Value::Object(m))
    } else {
        Value::Object(m)
    }
}

/// Plain JSON (e.g. given on the command line) as the worker receives it:
/// every object whose only key is [`TAG`] escaped.
pub fn escape(v: Value) -> Value {
    match v {
        Value::Array(a) => Value::Array(a.into_iter().map(escape).collect()),
        Value::Object(m) => object(m.into_iter().map(|(k, v)| (k, escape(v))).collect()),
        other => other,
    }
}

fn tagged(v: Value) -> Value {
    let mut m = Map::new();
    m.insert(TAG.into(), v);
    Value::Object(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn non_finite_floats_and_the_tag_itself_are_encoded() {
        assert_eq!(float(1.5), json!(1.5));
        assert_eq!(float(f64::NAN), json!({"$rwg": "nan"}));
        assert_eq!(float(f64::INFINITY), json!({"$rwg": "inf"}));
        assert_eq!(float(f64::NEG_INFINITY), json!({"$rwg": "-inf"}));
        assert_eq!(
            escape(json!({"a": [{"$rwg": "nan"}], "b": {"$rwg": 1, "c": 2}})),
            json!({"a": [{"$rwg": {"$rwg": "nan"}}], "b": {"$rwg": 1, "c": 2}})
        );
        assert_eq!(
            escape(json!({"$rwg": {"$rwg": 3}})),
            json!({"$rwg": {"$rwg": {"$rwg": {"$rwg": 3}}}})
        );
    }
}
