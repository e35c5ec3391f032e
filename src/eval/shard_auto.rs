//! `--shard auto`: the shard of this task from the scheduler running it, so
//! one array job or Indexed Job runs a sweep sharded across nodes.

use crate::rundir::Shard;

/// `--shard auto`: this task's shard from the scheduler's environment.
///
/// - Slurm job array (`sbatch --array=0-5`): `SLURM_ARRAY_TASK_ID`,
///   `SLURM_ARRAY_TASK_MIN` and `SLURM_ARRAY_TASK_COUNT` (and
///   `SLURM_ARRAY_TASK_STEP` for `--array=0-10:2`); shard K = (ID - MIN) /
///   STEP + 1 of COUNT. A sparse list (`--array=1,4,9`) has no such
///   mapping and is refused by the range check.
/// - Kubernetes Indexed Job: `JOB_COMPLETION_INDEX` (0-based); the count
///   is not in the pod's environment, so it comes from `count` (the
///   `--shard-count` flag or its `NEGOTIATOR_SHARD_COUNT` variable),
///   which must equal the Job's `completions`.
///
/// Returns the shard and a phrase naming where it came from.
pub fn shard_from_scheduler(
    env: impl Fn(&str) -> Option<String>,
    count: Option<u64>,
) -> Result<(Shard, String), String> {
    let num = |name: &str| -> Result<Option<u64>, String> {
        match env(name) {
            None => Ok(None),
            Some(v) => v.trim().parse().map(Some).map_err(|_| format!("${name} = '{v}' is not a whole number")),
        }
    };
    if let Some(id) = num("SLURM_ARRAY_TASK_ID")? {
        let min = num("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
        let step = num("SLURM_ARRAY_TASK_STEP")?.unwrap_or(1).max(1);
        let n = match count {
            Some(n) => n,
            None => num("SLURM_ARRAY_TASK_COUNT")?
                .ok_or("--shard auto: $SLURM_ARRAY_TASK_ID is set but $SLURM_ARRAY_TASK_COUNT is not")?,
        };
        let offset = id.checked_sub(min).filter(|d| d % step == 0).ok_or_else(|| {
            format!("--shard auto: Slurm array task {id} is not on the array's range (min {min}, step {step})")
        })?;
        let shard = Shard { index: offset / step + 1, count: n };
        if n == 0 || shard.index > n {
            return Err(format!(
                "--shard auto: Slurm array task {id} maps to shard {} of {n}: use a contiguous --array=0-{} ",
                shard.index,
                n.saturating_sub(1)
            ));
        }
        return Ok((shard, format!("Slurm array task {id}")));
    }
    if let Some(index) = num("JOB_COMPLETION_INDEX")? {
        let n = count.ok_or(
            "--shard auto: $JOB_COMPLETION_INDEX is set but the shard count is not: give --shard-count N \
             (or NEGOTIATOR_SHARD_COUNT) equal to the Job's completions",
        )?;
        if n == 0 || index >= n {
            return Err(format!("--shard auto: completion index {index} is not below the shard count {n}"));
        }
        return Ok((Shard { index: index + 1, count: n }, format!("Kubernetes completion index {index}")));
    }
    Err("--shard auto: neither a Slurm job array ($SLURM_ARRAY_TASK_ID) nor a Kubernetes Indexed Job \
         ($JOB_COMPLETION_INDEX) is in the environment; give --shard K/N"
        .to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_auto_maps_slurm_arrays_and_indexed_jobs() {
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |k: &str| pairs.iter().find(|(n, _)| *n == k).map(|(_, v)| v.to_string())
        };
        // sbatch --array=0-5: tasks 0..5 are shards 1/6..6/6, all of them once.
        let mut seen = Vec::new();
        for id in ["0", "1", "2", "3", "4", "5"] {
            let pairs: &'static [(&'static str, &'static str)] = Box::leak(Box::new([
                ("SLURM_ARRAY_TASK_ID", id),
                ("SLURM_ARRAY_TASK_MIN", "0"),
                ("SLURM_ARRAY_TASK_COUNT", "6"),
            ]));
            seen.push(shard_from_scheduler(env(pairs), None).unwrap().0);
        }
        assert_eq!(seen, (1..=6).map(|k| Shard { index: k, count: 6 }).collect::<Vec<_>>());
        // --array=1-3 starts at 1; --array=10-14:2 steps.
        let one = env(&[("SLURM_ARRAY_TASK_ID", "3"), ("SLURM_ARRAY_TASK_MIN", "1"), ("SLURM_ARRAY_TASK_COUNT", "3")]);
        assert_eq!(shard_from_scheduler(one, None).unwrap().0, Shard { index: 3, count: 3 });
        let step = env(&[
            ("SLURM_ARRAY_TASK_ID", "14"),
            ("SLURM_ARRAY_TASK_MIN", "10"),
            ("SLURM_ARRAY_TASK_STEP", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
        ]);
        assert_eq!(
            shard_from_scheduler(step, None).unwrap(),
            (Shard { index: 3, count: 3 }, "Slurm array task 14".into())
        );
        let sparse =
            env(&[("SLURM_ARRAY_TASK_ID", "9"), ("SLURM_ARRAY_TASK_MIN", "1"), ("SLURM_ARRAY_TASK_COUNT", "3")]);
        assert!(shard_from_scheduler(sparse, None).unwrap_err().contains("maps to shard 9 of 3"));
        // Kubernetes: 0-based index, count from the flag.
        let k8s = env(&[("JOB_COMPLETION_INDEX", "0")]);
        assert_eq!(shard_from_scheduler(k8s, Some(6)).unwrap().0, Shard { index: 1, count: 6 });
        let k8s = env(&[("JOB_COMPLETION_INDEX", "5")]);
        assert_eq!(shard_from_scheduler(k8s, Some(6)).unwrap().0, Shard { index: 6, count: 6 });
        assert!(shard_from_scheduler(k8s, Some(5)).unwrap_err().contains("not below the shard count 5"));
        assert!(shard_from_scheduler(k8s, None).unwrap_err().contains("--shard-count"));
        let bad = env(&[("JOB_COMPLETION_INDEX", "x")]);
        assert!(shard_from_scheduler(bad, Some(2)).unwrap_err().contains("JOB_COMPLETION_INDEX = 'x'"));
        let none = env(&[]);
        assert!(shard_from_scheduler(none, Some(2)).unwrap_err().starts_with("--shard auto: neither a Slurm"));
    }
}
