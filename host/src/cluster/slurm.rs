//! `--slurm`: one worker per node of the Slurm allocation the master runs in, started through
//! `srun` as one job step, each dialling back to the master.
//!
//! The allocation is read from the environment `sbatch` and `salloc` set (`SLURM_JOB_ID`,
//! `SLURM_JOB_NUM_NODES`, `SLURM_JOB_CPUS_PER_NODE`). The step asks for one task per node with
//! the node's CPUs (the fewest any node has, on a mixed allocation), shares the CPUs of the
//! master's own step (`--overlap`), and keeps going when a node's task fails
//! (`--kill-on-bad-exit=0`): the master gives a lost worker's lines to the others.

use std::path::Path;

/// The Slurm allocation this process runs in.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Allocation {
    /// `SLURM_JOB_ID`.
    pub job: String,
    /// Nodes allocated.
    pub nodes: u32,
    /// CPUs on each node (the fewest, where nodes differ).
    pub cpus_per_node: u32,
}

impl Allocation {
    /// The allocation that `var` (the environment) describes.
    ///
    /// # Errors
    /// No allocation (`SLURM_JOB_ID` unset), or counts Slurm would not write.
    pub fn from_env(var: impl Fn(&str) -> Option<String>) -> Result<Allocation, String> {
        let job = var("SLURM_JOB_ID").ok_or(
            "--slurm runs inside a Slurm allocation, and there is none here (SLURM_JOB_ID is not \
             set): run strahl from an sbatch script or under salloc (see docs/slurm.sbatch)",
        )?;
        let nodes = var("SLURM_JOB_NUM_NODES")
            .or_else(|| var("SLURM_NNODES"))
            .and_then(|n| n.trim().parse::<u32>().ok())
            .filter(|&n| n > 0)
            .ok_or("--slurm: SLURM_JOB_NUM_NODES is missing or not a number of nodes")?;
        let cpus = var("SLURM_JOB_CPUS_PER_NODE").unwrap_or_else(|| "1".into());
        let cpus_per_node = fewest_cpus(&cpus).ok_or_else(|| {
            format!("--slurm: SLURM_JOB_CPUS_PER_NODE `{cpus}` is not Slurm's list of counts")
        })?;
        Ok(Allocation {
            job,
            nodes,
            cpus_per_node,
        })
    }

    /// The `srun` command that starts the workers: `strahl` at `exe`, dialling `master`,
    /// proving the secret in `secret_file` when there is one (else `STRAHL_SECRET`, which srun
    /// passes on).
    pub fn srun_command(
        &self,
        exe: &Path,
        master: &str,
        secret_file: Option<&Path>,
    ) -> Vec<String> {
        let mut argv: Vec<String> = [
            "srun".to_string(),
            format!("--nodes={}", self.nodes),
            format!("--ntasks={}", self.nodes),
            "--ntasks-per-node=1".into(),
            format!("--cpus-per-task={}", self.cpus_per_node),
            "--overlap".into(),
            "--kill-on-bad-exit=0".into(),
            "--job-name=strahl-worker".into(),
            exe.display().to_string(),
            "worker".into(),
            "--connect".into(),
            master.to_string(),
        ]
        .into();
        if let Some(file) = secret_file {
            argv.extend(["--secret-file".to_string(), file.display().to_string()]);
        }
        argv
    }
}

/// The fewest CPUs in Slurm's per-node list (`16(x2),8` → 8).
fn fewest_cpus(list: &str) -> Option<u32> {
    list.split(',')
        .map(|entry| {
            entry
                .split('(')
                .next()
                .unwrap_or("")
                .trim()
                .parse::<u32>()
                .ok()
        })
        .collect::<Option<Vec<u32>>>()?
        .into_iter()
        .filter(|&n| n > 0)
        .min()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let map: HashMap<String, String> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |k| map.get(k).cloned()
    }

    #[test]
    fn reads_the_allocation_and_builds_one_task_per_node() {
        let a = Allocation::from_env(env(&[
            ("SLURM_JOB_ID", "42"),
            ("SLURM_JOB_NUM_NODES", "3"),
            ("SLURM_JOB_CPUS_PER_NODE", "16(x2),8"),
        ]))
        .expect("an allocation");
        assert_eq!((a.nodes, a.cpus_per_node), (3, 8));
        let argv = a.srun_command(Path::new("/bin/strahl"), "head:7418", Some(Path::new("/k")));
        assert_eq!(argv[..3], ["srun", "--nodes=3", "--ntasks=3"]);
        assert!(argv.contains(&"--cpus-per-task=8".to_string()));
        assert!(argv.ends_with(&[
            "/bin/strahl".into(),
            "worker".into(),
            "--connect".into(),
            "head:7418".into(),
            "--secret-file".into(),
            "/k".into()
        ]));
    }

    #[test]
    fn no_allocation_says_how_to_get_one() {
        let e = Allocation::from_env(env(&[])).expect_err("none");
        assert!(e.contains("sbatch") && e.contains("salloc"), "{e}");
        let e = Allocation::from_env(env(&[("SLURM_JOB_ID", "1"), ("SLURM_JOB_NUM_NODES", "x")]))
            .expect_err("bad count");
        assert!(e.contains("SLURM_JOB_NUM_NODES"), "{e}");
        assert_eq!(fewest_cpus("4"), Some(4));
        assert_eq!(fewest_cpus("a"), None);
    }
}
