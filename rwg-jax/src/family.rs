//! The JAX env sources, one row each: the id's prefix, the worker's adapter
//! (its source name), the library and what to pip install for it. Everything
//! that names the sources (id parsing, the manifest's messages, `env.json`'s
//! versions, the docs' checks) reads this table, so a new family is one row
//! here and one adapter in the worker (`jax_families.py`).

/// Which library an env comes from ([`FAMILIES`] row by row).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum JaxKind {
    /// `gymnax:ID`: `gymnax.make(ID)`.
    Gymnax,
    /// `brax:NAME`: `brax.envs.get_environment(NAME)`.
    Brax,
    /// `playground:NAME`: `mujoco_playground.registry.load(NAME)`.
    Playground,
    /// `jumanji:ID`: `jumanji.make(ID)`.
    Jumanji,
    /// `craftax:NAME`: `make_craftax_env_from_name(NAME, auto_reset=False)`.
    Craftax,
    /// `navix:ID`: `navix.make(ID)`.
    Navix,
    /// `xminigrid:ID`: `xminigrid.make(ID)`.
    Xminigrid,
    /// `pgx:ID`: `pgx.make(ID)` (single-player games).
    Pgx,
    /// `jax:module:callable`: a user's function returning `(env, params)`.
    Custom,
}

/// One JAX env source.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Family {
    /// Its kind.
    pub kind: JaxKind,
    /// The id prefix (`gymnax:`).
    pub prefix: &'static str,
    /// How an id of it is written (`gymnax:ID`), for messages.
    pub id_form: &'static str,
    /// The worker's adapter (the hello message's `source`).
    pub source: &'static str,
    /// The library's name as people write it (`MuJoCo Playground`).
    pub library: &'static str,
    /// What `pip install` takes to bring the library (the distribution whose
    /// version `env.json` records), or "" for a user's own module.
    pub package: &'static str,
    /// The call that makes an env (`gymnax.make(ID)`), for docs and messages.
    pub make: &'static str,
}

const fn row(
    kind: JaxKind,
    (prefix, source): (&'static str, &'static str),
    id_form: &'static str,
    library: &'static str,
    package: &'static str,
    make: &'static str,
) -> Family {
    Family {
        kind,
        prefix,
        id_form,
        source,
        library,
        package,
        make,
    }
}

/// The JAX env sources, in [`JaxKind`] order.
pub const FAMILIES: [Family; 9] = [
    row(
        JaxKind::Gymnax,
        ("gymnax:", "gymnax"),
        "gymnax:ID",
        "gymnax",
        "gymnax",
        "gymnax.make(ID)",
    ),
    row(
        JaxKind::Brax,
        ("brax:", "brax"),
        "brax:NAME",
        "Brax",
        "brax",
        "brax.envs.get_environment(NAME)",
    ),
    row(
        JaxKind::Playground,
        ("playground:", "playground"),
        "playground:NAME",
        "MuJoCo Playground",
        "playground",
        "mujoco_playground.registry.load(NAME)",
    ),
    row(
        JaxKind::Jumanji,
        ("jumanji:", "jumanji"),
        "jumanji:ID",
        "Jumanji",
        "jumanji",
        "jumanji.make(ID)",
    ),
    row(
        JaxKind::Craftax,
        ("craftax:", "craftax"),
        "craftax:NAME",
        "Craftax",
        "craftax",
        "make_craftax_env_from_name(NAME, auto_reset=False)",
    ),
    row(
        JaxKind::Navix,
        ("navix:", "navix"),
        "navix:ID",
        "Navix",
        "navix",
        "navix.make(ID)",
    ),
    row(
        JaxKind::Xminigrid,
        ("xminigrid:", "xminigrid"),
        "xminigrid:ID",
        "XLand-MiniGrid",
        "xminigrid",
        "xminigrid.make(ID)",
    ),
    row(
        JaxKind::Pgx,
        ("pgx:", "pgx"),
        "pgx:ID",
        "Pgx",
        "pgx",
        "pgx.make(ID)",
    ),
    row(
        JaxKind::Custom,
        ("jax:", "jax"),
        "jax:module:callable",
        "your own module",
        "",
        "module.callable(**kwargs) -> (env, params)",
    ),
];

impl JaxKind {
    /// Its row of [`FAMILIES`].
    pub fn family(self) -> &'static Family {
        &FAMILIES[self as usize]
    }

    /// The id prefix (`gymnax:`).
    pub fn prefix(self) -> &'static str {
        self.family().prefix
    }

    /// The source's name in the worker protocol (`gymnax`, `brax`, `jax`).
    pub fn source(self) -> &'static str {
        self.family().source
    }
}

/// The kind and seed id of a JAX env id (`gymnax:CartPole-v1` ->
/// `(Gymnax, "CartPole-v1")`), or `None` for any other id.
pub fn jax_id(id: &str) -> Option<(JaxKind, &str)> {
    FAMILIES
        .iter()
        .find_map(|f| id.strip_prefix(f.prefix).map(|rest| (f.kind, rest)))
}

/// How the JAX ids are written, for messages: `gymnax:ID, brax:NAME, ...`.
pub fn id_forms() -> String {
    let forms: Vec<&str> = FAMILIES.iter().map(|f| f.id_form).collect();
    forms.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_row_is_its_kinds_and_prefixes_are_distinct() {
        for (i, f) in FAMILIES.iter().enumerate() {
            assert_eq!(f.kind as usize, i, "{f:?}");
            assert!(f.prefix.ends_with(':') && f.id_form.starts_with(f.prefix));
            assert_eq!(format!("{}:", f.source), f.prefix);
            for g in &FAMILIES[..i] {
                assert!(!f.prefix.starts_with(g.prefix) && !g.prefix.starts_with(f.prefix));
            }
        }
        assert_eq!(JaxKind::Pgx.source(), "pgx");
        assert_eq!(JaxKind::Custom.source(), "jax");
        assert_eq!(
            jax_id("xminigrid:MiniGrid-Empty-8x8").unwrap().0,
            JaxKind::Xminigrid
        );
        assert!(id_forms().contains("playground:NAME, jumanji:ID"));
    }
}
