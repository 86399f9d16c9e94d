//! `--set KEY=VALUE`: change one value of a case file from the command line
//! (or from a script) without editing or regenerating its text.
//!
//! KEY is a dotted path into the case's TOML: `contact.convention`,
//! `output.snapshot_interval`, `material[0].restitution`; an entry of an array
//! of tables is picked by index (`wall[1]`) or by its `name` (`wall.gate`,
//! `phase.discharge`, `material.seed-soft`). VALUE is a TOML value (`0.3`,
//! `[0.0, 0.0, -0.5]`, `{ kn = 1e3, kt = 1e3, gamma_n = 0, gamma_t = 0 }`,
//! `"hooke"`); a bare word that is not TOML is taken as a string (`hooke`).
//! A key whose table does not exist is created; the case is then validated as
//! a whole, as if the file had said so.

use crate::error::TalusError;
use toml::{Table, Value};

/// Parse `KEY=VALUE` into the key and the TOML value.
pub fn parse(set: &str) -> Result<(String, Value), TalusError> {
    let bad = |why: &str| TalusError::Input(format!("--set {set}: {why}"));
    let (key, text) = set.split_once('=').ok_or_else(|| bad("expected KEY=VALUE"))?;
    let key = key.trim();
    if key.is_empty() {
        return Err(bad("the key is empty"));
    }
    let text = text.trim();
    let value = match toml::from_str::<Table>(&format!("v = {text}")) {
        Ok(mut t) => t.remove("v").expect("parsed above"),
        Err(_) if !text.is_empty() && text.chars().all(|c| c.is_alphanumeric() || "-_.".contains(c)) => {
            Value::String(text.to_string())
        }
        Err(e) => return Err(bad(&format!("the value is not TOML: {}", e.message()))),
    };
    Ok((key.to_string(), value))
}

/// One step of a key: a table key, optionally with an index (`wall[1]`).
fn steps(key: &str) -> Vec<(&str, Option<usize>)> {
    key.split('.')
        .map(|s| match s.split_once('[') {
            Some((k, rest)) => (k, rest.trim_end_matches(']').parse().ok()),
            None => (s, None),
        })
        .collect()
}

/// Set `key` to `value` in the case's table; `set` names the option in errors.
pub fn apply(root: &mut Table, key: &str, value: Value, set: &str) -> Result<(), TalusError> {
    let bad = |why: String| TalusError::Input(format!("--set {set}: {why}"));
    let st = steps(key);
    let mut table = root;
    let mut k = 0;
    while k + 1 < st.len() {
        let (name, index) = st[k];
        let entry = table.entry(name.to_string()).or_insert_with(|| Value::Table(Table::new()));
        let kind = entry.type_str();
        table = match entry {
            Value::Table(t) if index.is_none() => t,
            Value::Array(a) => {
                // an array of tables: by index, or by the `name` the next step gives
                let pos = match index {
                    Some(i) => i,
                    None => {
                        k += 1;
                        let want = st[k].0;
                        a.iter()
                            .position(|e| e.get("name").and_then(Value::as_str) == Some(want))
                            .ok_or_else(|| bad(format!("no [[{name}]] named \"{want}\"")))?
                    }
                };
                let len = a.len();
                match a.get_mut(pos) {
                    Some(Value::Table(t)) => t,
                    _ => return Err(bad(format!("{name} has {len} entries; there is no {name}[{pos}]"))),
                }
            }
            _ => return Err(bad(format!("`{name}` is a {kind}, not a table"))),
        };
        k += 1;
    }
    if k >= st.len() {
        return Err(bad("the key names an entry, not a value in it".into()));
    }
    let (last, index) = st[k];
    match index {
        None => {
            table.insert(last.to_string(), value);
        }
        Some(i) => match table.get_mut(last) {
            Some(Value::Array(a)) if i < a.len() => a[i] = value,
            _ => return Err(bad(format!("`{last}` has no element [{i}]"))),
        },
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(text: &str, s: &str) -> Result<Table, TalusError> {
        let mut t: Table = toml::from_str(text).unwrap();
        let (k, v) = parse(s)?;
        apply(&mut t, &k, v, s)?;
        Ok(t)
    }

    const CASE: &str = "[contact]\nmodel = \"hertz\"\n[[wall]]\nname = \"gate\"\nvelocity = [0.0, 0.0, 0.0]\n[[wall]]\nname = \"box\"\n";

    #[test]
    fn values_are_set_by_path_index_and_name() {
        let t = set(CASE, "contact.model=hooke").unwrap();
        assert_eq!(t["contact"]["model"].as_str(), Some("hooke"));
        let t = set(CASE, "wall.box.velocity=[0.1, 0, 0]").unwrap();
        assert_eq!(t["wall"][1]["velocity"][0].as_float(), Some(0.1));
        let t = set(CASE, "wall[0].velocity[2]=-0.5").unwrap();
        assert_eq!(t["wall"][0]["velocity"][2].as_float(), Some(-0.5));
        let t = set(CASE, "contact.stiffness={ kn = 1e3, kt = 1e3, gamma_n = 0.0, gamma_t = 0.0 }").unwrap();
        assert_eq!(t["contact"]["stiffness"]["kn"].as_float(), Some(1e3));
        let t = set(CASE, "output.interval=1e-5").unwrap();
        assert_eq!(t["output"]["interval"].as_float(), Some(1e-5));
    }

    #[test]
    fn bad_sets_name_the_option() {
        for (s, why) in [
            ("contact", "expected KEY=VALUE"),
            ("wall.door.velocity=[0,0,0]", "no [[wall]] named \"door\""),
            ("wall[5].velocity=[0,0,0]", "there is no wall[5]"),
            ("contact.model.x=1", "is a string, not a table"),
            ("output.interval=[1,", "the value is not TOML"),
        ] {
            let e = set(CASE, s).err().unwrap().to_string();
            assert!(e.starts_with(&format!("--set {s}: ")) && e.contains(why), "{e}");
        }
    }
}
