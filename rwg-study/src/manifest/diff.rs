//! How two studies differ: their resolved manifests compared key by key,
//! down to the entry and key that changed (`envs[1] (CartPole-v1).solved:
//! 195.0 vs 100.0`) instead of whole arrays, and each value by its TOML
//! text, so that a NaN (in a kwarg, say) is the same study as itself.

use toml::Value;

/// One `key: A vs B` line per difference between the tables `a` and `b`,
/// in key order (absent values shown as `(absent)`).
pub(super) fn differences(a: &toml::Table, b: &toml::Table) -> Vec<String> {
    let mut out = vec![];
    tables("", a, b, &mut out);
    out
}

fn tables(path: &str, a: &toml::Table, b: &toml::Table, out: &mut Vec<String>) {
    let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
    keys.sort();
    keys.dedup();
    for k in keys {
        let at = if path.is_empty() {
            k.clone()
        } else {
            format!("{path}.{k}")
        };
        values(&at, a.get(k), b.get(k), out);
    }
}

fn values(path: &str, a: Option<&Value>, b: Option<&Value>, out: &mut Vec<String>) {
    match (a, b) {
        (Some(Value::Table(x)), Some(Value::Table(y))) => tables(path, x, y, out),
        (Some(Value::Array(x)), Some(Value::Array(y)))
            if x.len() == y.len() && x.iter().chain(y).all(Value::is_table) =>
        {
            for (i, (p, q)) in x.iter().zip(y).enumerate() {
                values(&format!("{path}[{i}]{}", label(p)), Some(p), Some(q), out);
            }
        }
        (Some(Value::Array(x)), Some(Value::Array(y)))
            if x.len() != y.len() && x.iter().chain(y).all(Value::is_table) =>
        {
            out.push(format!("{path}: {} vs {}", entries(x), entries(y)));
        }
        _ if text(a) != text(b) => out.push(format!("{path}: {} vs {}", text(a), text(b))),
        _ => {}
    }
}

/// ` (ID)` for an entry with an `id` or a `name`, so that a message names it.
fn label(entry: &Value) -> String {
    ["id", "name"]
        .iter()
        .find_map(|k| entry.get(k).and_then(Value::as_str))
        .map_or(String::new(), |n| format!(" ({n})"))
}

/// `N entries (A, B, ...)` of an array of tables.
fn entries(x: &[Value]) -> String {
    let names: Vec<String> = x
        .iter()
        .map(|e| label(e).trim_matches([' ', '(', ')']).to_string())
        .collect();
    let s = if x.len() == 1 { "y" } else { "ies" };
    format!("{} entr{s} ({})", x.len(), names.join(", "))
}

/// A value as TOML writes it; `(absent)` for none.
fn text(v: Option<&Value>) -> String {
    v.map_or("(absent)".to_string(), Value::to_string)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(s: &str) -> toml::Table {
        toml::from_str(s).unwrap()
    }

    #[test]
    fn names_the_entry_and_key_and_takes_nan_as_itself() {
        let a = table(
            "seed = 1\nbias = [true]\n[[envs]]\nid = \"A\"\n[[envs]]\nid = \"B\"\n\
             kwargs = { g = 9.8, x = nan, l = [1.0, nan], t = { u = 1 } }\n",
        );
        assert!(differences(&a, &a.clone()).is_empty());
        let b = table(
            "seed = 1\nbias = [true, false]\n[[envs]]\nid = \"A\"\nsolved = 3\n[[envs]]\n\
             id = \"B\"\nkwargs = { g = 9.0, x = nan, l = [1.0, nan], t = { u = 2 } }\n",
        );
        assert_eq!(
            differences(&a, &b),
            [
                "bias: [true] vs [true, false]",
                "envs[0] (A).solved: (absent) vs 3",
                "envs[1] (B).kwargs.g: 9.8 vs 9.0",
                "envs[1] (B).kwargs.t.u: 1 vs 2",
            ]
        );
        let c = table("seed = 1\nbias = [true]\n[[envs]]\nid = \"A\"\n");
        assert_eq!(
            differences(&a, &c),
            ["envs: 2 entries (A, B) vs 1 entry (A)"]
        );
        // -0.0 and 0.0 are written apart, so they differ
        assert_eq!(
            differences(&table("x = -0.0"), &table("x = 0.0")),
            ["x: -0.0 vs 0.0"]
        );
    }
}
