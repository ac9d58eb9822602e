//! The study a run directory holds. Its `manifest.toml` is the study, and
//! `run.json` records the same text ([`RunMeta::study`]) from the moment the
//! run starts, so an edit of `manifest.toml` after rwg wrote it is found
//! instead of being taken for the study the directory holds.

use crate::manifest::Manifest;
use crate::rundir::meta::RunMeta;
use crate::rundir::{MANIFEST, RUN_JSON};
use crate::shell::{sh_path, sh_quote};
use std::path::Path;

/// The command that resumes (or finishes, or rebuilds the `run.json` of)
/// the run in `dir`: `rwg run DIR/manifest.toml --out DIR`, quoted.
pub fn resume_command(dir: &Path) -> String {
    format!(
        "rwg run {} --out {}",
        sh_path(&dir.join(MANIFEST)),
        sh_path(dir)
    )
}

/// How `now` (the directory's `manifest.toml` as it reads today) differs
/// from the study `run.json` recorded: one `key: recorded vs now` entry per
/// difference, empty for the same study. For a `run.json` written before
/// the study was recorded in it, the seed, samples, episodes and weights it
/// holds are compared.
pub fn manifest_edits(dir: &Path, meta: &RunMeta, now: &Manifest) -> Vec<String> {
    if let Some(text) = &meta.study {
        let file = format!("{} (its study)", dir.join(RUN_JSON).display());
        return match Manifest::parse(text, &file, dir) {
            Ok(recorded) => recorded.study_differences(now),
            Err(e) => vec![format!(
                "the study recorded in run.json does not read back: {e}"
            )],
        };
    }
    let mut edits = vec![];
    let mut cmp = |key: &str, recorded: String, now: String| {
        if recorded != now {
            edits.push(format!("{key}: {recorded} vs {now}"));
        }
    };
    cmp("seed", meta.seed.to_string(), now.seed.to_string());
    cmp("samples", meta.samples.to_string(), now.samples.to_string());
    cmp(
        "episodes",
        meta.episodes.to_string(),
        now.episodes.to_string(),
    );
    cmp(
        "weights",
        format!("{} {}", meta.weights.distribution, meta.weights.scale),
        format!("{} {}", now.weights.name(), now.weights.scale()),
    );
    edits
}

/// What to say when `dir/manifest.toml` no longer holds the study `run.json`
/// recorded (`edits`, from [`manifest_edits`]).
pub fn edited_message(dir: &Path, edits: &[String]) -> String {
    let d = dir.display();
    let (manifest, edited) = (
        sh_path(&dir.join(MANIFEST)),
        sh_quote(&format!("{}-edited", dir.to_string_lossy())),
    );
    format!(
        "{}/{MANIFEST} was changed after rwg wrote it ({}; run.json's record vs the file). \
         A run directory's manifest.toml is the study it holds, and its files are that study's. \
         To run the edited study, copy the manifest out and give it a directory of its own: \
         cp {manifest} edited.toml && rwg run edited.toml --out {edited}; to keep this \
         run, undo the edit",
        d,
        edits.join("; ")
    )
}

/// What to say about a `run.json` that does not parse (empty or cut short by
/// a full disk or a crash, or edited): how to get it back.
pub fn damaged_run_json(dir: &Path) -> String {
    let d = dir.display();
    format!(
        "{d}/{RUN_JSON} is not a readable run.json (empty, cut short or edited). Nothing else is \
         lost: resuming the run rebuilds it from the cells' own files. Delete it, then run \
         {}",
        resume_command(dir)
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cells::new_meta;

    const STUDY: &str = "samples = 64\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\n\
                         hidden = []\n[[envs]]\nid = \"CartPole-v1\"\n";

    #[test]
    fn edits_of_the_manifest_are_named_against_the_recorded_study() {
        let dir = Path::new("/runs/x");
        let m = Manifest::parse(STUDY, "m.toml", dir).unwrap();
        let mut meta = new_meta(&m, 1, String::new(), None);
        let resolved = Manifest::parse(&m.to_toml(), "manifest.toml", dir).unwrap();
        assert!(manifest_edits(dir, &meta, &resolved).is_empty());
        let edited = Manifest::parse(
            &STUDY
                .replace("64", "96")
                .replace("CartPole-v1", "Acrobot-v1"),
            "manifest.toml",
            dir,
        )
        .unwrap();
        let edits = manifest_edits(dir, &meta, &edited);
        assert_eq!(edits.len(), 2, "{edits:?}");
        assert_eq!(
            edits[0],
            "envs[0] (CartPole-v1).id: \"CartPole-v1\" vs \"Acrobot-v1\""
        );
        assert_eq!(edits[1], "samples: 64 vs 96");
        // A run.json without the study: its own fields are compared.
        meta.study = None;
        assert_eq!(manifest_edits(dir, &meta, &edited), ["samples: 64 vs 96"]);
        let text = edited_message(dir, &edits);
        assert!(
            text.starts_with("/runs/x/manifest.toml was changed after rwg wrote it (envs[0] "),
            "{text}"
        );
        assert!(
            text.contains("rwg run edited.toml --out /runs/x-edited"),
            "{text}"
        );
    }
}
