//! The two batch scripts `rwg slurm` writes: a job array with one task per
//! shard, and the merge job. Pure text generation (unit-tested here); the
//! command in `cmd/slurm.rs` writes and submits them.

use crate::cluster::ShardedDir;
use anyhow::{bail, Result};
use rwg_study::shell::{sh_path, sh_quote};
use std::path::Path;

/// What the scripts need to know.
pub struct Scripts<'a> {
    /// The `rwg` binary, by absolute path (compute nodes must see it there).
    pub rwg: &'a Path,
    /// The study's directory, absolute.
    pub dir: &'a ShardedDir,
    /// Number of shards.
    pub shards: u64,
    /// `#SBATCH` options of both scripts (`--partition=...`, ...), in order.
    pub common: &'a [String],
    /// `#SBATCH` options of the array only (`--cpus-per-task=...`).
    pub array_only: &'a [String],
}

/// Checks that `p` can stand in an `#SBATCH` line between double quotes and
/// in a Slurm file name pattern.
pub fn check_sbatch_path(p: &Path) -> Result<()> {
    let Some(s) = p.to_str() else {
        bail!(
            "{}: not valid UTF-8; Slurm scripts need a UTF-8 path, choose another --out",
            p.display()
        );
    };
    if let Some(c) = s
        .chars()
        .find(|c| matches!(c, '"' | '%' | '\\' | '\n' | '\r'))
    {
        bail!(
            "{s}: contains {c:?}, which Slurm's #SBATCH lines or file name patterns cannot \
             carry; choose another --out"
        );
    }
    Ok(())
}

/// Checks an `#SBATCH` option given on the command line.
pub fn check_sbatch_option(opt: &str) -> Result<()> {
    if opt.contains(['\n', '\r']) {
        bail!("sbatch option {opt:?} contains a line break");
    }
    if !opt.starts_with('-') {
        bail!("sbatch option '{opt}' does not start with '-' (give it as --sbatch=--qos=long)");
    }
    Ok(())
}

/// A job name from the study directory's name: `rwg-<kind>-<name>`.
fn job_name(kind: &str, dir: &Path) -> String {
    let base: String = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .take(40)
        .collect();
    format!("rwg-{kind}-{base}")
}

fn sbatch_lines(out: &mut String, opts: &[String]) {
    for o in opts {
        out.push_str(&format!("#SBATCH {o}\n"));
    }
}

impl Scripts<'_> {
    /// The job-array script: task K runs `rwg run --shard K/N` into `DIR/shards/K`.
    pub fn array(&self) -> String {
        let d = self.dir;
        let n = self.shards;
        let mut s = String::from("#!/bin/bash\n");
        s.push_str(&format!(
            "# Written by rwg slurm. Task K of this job array computes shard K of {n} of the\n\
             # study in {manifest}\n\
             # into {shards}/K. A task that is requeued, restarted or resubmitted resumes\n\
             # its shard from the blocks it committed. Resubmit unfinished shards with\n\
             #   {rwg} slurm {manifest} --shards {n} --out {root}\n",
            manifest = sh_path(&d.manifest()),
            shards = sh_path(&d.root.join("shards")),
            rwg = sh_path(self.rwg),
            root = sh_path(&d.root),
        ));
        s.push_str(&format!(
            "#SBATCH --job-name={}\n",
            job_name("shards", &d.root)
        ));
        s.push_str(&format!("#SBATCH --array=0-{}\n", n - 1));
        s.push_str(&format!(
            "#SBATCH --output=\"{}/shard-%a.out\"\n",
            d.logs().display()
        ));
        s.push_str("#SBATCH --open-mode=append\n#SBATCH --requeue\n");
        sbatch_lines(&mut s, self.array_only);
        sbatch_lines(&mut s, self.common);
        s.push_str(&format!(
            "set -euo pipefail\n\
             k=\"${{SLURM_ARRAY_TASK_ID:?submit this script with sbatch: it is a job array}}\"\n\
             threads=()\n\
             if [ -n \"${{SLURM_CPUS_PER_TASK:-}}\" ]; then threads=(--threads \"$SLURM_CPUS_PER_TASK\"); fi\n\
             echo \"rwg shard $k/{n} on $(hostname) at $(date -u +%FT%TZ) (job ${{SLURM_JOB_ID:-?}})\"\n\
             exec {rwg} run {manifest} --shard \"$k/{n}\" --out {shards}/\"$k\" ${{threads[@]+\"${{threads[@]}}\"}}\n",
            rwg = sh_path(self.rwg),
            manifest = sh_path(&d.manifest()),
            shards = sh_path(&d.root.join("shards")),
        ));
        s
    }

    /// The merge script: `rwg merge` of every shard into `DIR`, stats,
    /// figures and report included. Rerunning it finishes an interrupted merge.
    pub fn merge(&self) -> String {
        let d = self.dir;
        let mut s = String::from("#!/bin/bash\n");
        s.push_str(&format!(
            "# Written by rwg slurm: merges the {} shards of {} into it\n\
             # (cells, stats, figures, report.html). Submitted with --dependency=afterok on the\n\
             # shards' job array; running it again finishes an interrupted merge.\n",
            self.shards,
            sh_path(&d.root)
        ));
        s.push_str(&format!(
            "#SBATCH --job-name={}\n",
            job_name("merge", &d.root)
        ));
        s.push_str(&format!(
            "#SBATCH --output=\"{}/merge-%j.out\"\n",
            d.logs().display()
        ));
        s.push_str("#SBATCH --open-mode=append\n");
        sbatch_lines(&mut s, self.common);
        s.push_str("set -euo pipefail\n");
        s.push_str(&format!("exec {} merge", sh_path(self.rwg)));
        for k in 0..self.shards {
            s.push_str(" \\\n    ");
            s.push_str(&sh_path(&d.shard(k)));
        }
        s.push_str(&format!(" \\\n    --out {}\n", sh_path(&d.root)));
        s
    }
}

/// `0-2` style list of shard indices for `sbatch --array`.
pub fn array_spec(tasks: &[u64]) -> String {
    let mut parts: Vec<String> = vec![];
    let mut i = 0;
    while i < tasks.len() {
        let mut j = i;
        while j + 1 < tasks.len() && tasks[j + 1] == tasks[j] + 1 {
            j += 1;
        }
        parts.push(if j > i {
            format!("{}-{}", tasks[i], tasks[j])
        } else {
            tasks[i].to_string()
        });
        i = j + 1;
    }
    parts.join(",")
}

/// The job id in `sbatch --parsable` output (`ID` or `ID;CLUSTER`).
pub fn parse_job_id(stdout: &str) -> Option<String> {
    let id = stdout.trim().split(';').next()?.trim();
    (!id.is_empty() && id.bytes().all(|c| c.is_ascii_digit())).then(|| id.to_string())
}

/// Quotes a command line for display.
pub fn show_command(args: &[String]) -> String {
    args.iter()
        .map(|a| sh_quote(a))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    #[test]
    fn scripts_quote_paths_and_carry_the_options() {
        let dir = ShardedDir {
            root: PathBuf::from("/data/my runs/it's"),
        };
        let sc = Scripts {
            rwg: Path::new("/opt/rwg bin/rwg"),
            dir: &dir,
            shards: 3,
            common: &["--partition=short".into(), "--time=01:00:00".into()],
            array_only: &["--cpus-per-task=4".into()],
        };
        let a = sc.array();
        assert!(a.starts_with("#!/bin/bash\n"), "{a}");
        assert!(a.contains("#SBATCH --array=0-2\n"), "{a}");
        assert!(a.contains("#SBATCH --output=\"/data/my runs/it's/slurm/logs/shard-%a.out\"\n"));
        assert!(a.contains("#SBATCH --cpus-per-task=4\n#SBATCH --partition=short\n"));
        assert!(a.contains(
            r#"exec '/opt/rwg bin/rwg' run '/data/my runs/it'\''s/slurm/manifest.toml' --shard "$k/3" --out '/data/my runs/it'\''s/shards'/"$k""#
        ), "{a}");
        // every #SBATCH line comes before the first command
        let first_cmd = a.lines().position(|l| l.starts_with("set ")).unwrap();
        assert!(a.lines().skip(first_cmd).all(|l| !l.starts_with("#SBATCH")));
        let m = sc.merge();
        assert!(!m.contains("cpus-per-task"), "{m}");
        assert!(m.contains("#SBATCH --time=01:00:00\n"));
        assert!(m.contains(r"'/data/my runs/it'\''s/shards/2' \"), "{m}");
        assert!(m.ends_with("--out '/data/my runs/it'\\''s'\n"), "{m}");
    }

    #[test]
    fn paths_options_array_specs_and_job_ids() {
        assert!(check_sbatch_path(Path::new("/a b/c")).is_ok());
        assert!(check_sbatch_path(Path::new("/a%b")).is_err());
        assert!(check_sbatch_path(Path::new("/a\"b")).is_err());
        assert!(check_sbatch_option("--qos=long").is_ok());
        assert!(check_sbatch_option("qos=long").is_err());
        assert!(check_sbatch_option("--x\n#SBATCH --y").is_err());
        assert_eq!(array_spec(&[0, 1, 2]), "0-2");
        assert_eq!(array_spec(&[1, 3, 4, 5, 9]), "1,3-5,9");
        assert_eq!(array_spec(&[7]), "7");
        assert_eq!(parse_job_id("123\n").as_deref(), Some("123"));
        assert_eq!(parse_job_id("123;cluster\n").as_deref(), Some("123"));
        assert_eq!(parse_job_id("Submitted batch job 5"), None);
        assert_eq!(parse_job_id(""), None);
        assert_eq!(
            job_name("merge", Path::new("/x/paper run")),
            "rwg-merge-paper_run"
        );
    }
}
