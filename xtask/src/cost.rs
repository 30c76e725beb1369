//! What a child process cost: wall seconds and the CPU seconds (user + system, all its threads and
//! waited-for descendants) it got. On a shared machine a run with a fixed wall-clock budget gets
//! whatever CPU the other work leaves; its CPU seconds show how much that was.
//!
//! CPU time comes from `cutime` and `cstime` of `/proc/self/stat` (Linux): the times of the
//! children this process has waited for, read before and after each child, so no FFI is needed.
//! Elsewhere it is `None`.

use anyhow::{Context, bail};
use std::process::Command;
use std::sync::OnceLock;
use std::time::Instant;

/// Wall and CPU seconds of one child process.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cost {
    pub wall: f64,
    /// User + system seconds; `None` where `/proc/self/stat` is not readable.
    pub cpu: Option<f64>,
}

/// Clock ticks per second of `/proc`'s times (`getconf CLK_TCK`; 100, Linux's USER_HZ, when that
/// cannot be asked).
fn ticks_per_second() -> f64 {
    static TCK: OnceLock<f64> = OnceLock::new();
    *TCK.get_or_init(|| {
        Command::new("getconf")
            .arg("CLK_TCK")
            .output()
            .ok()
            .and_then(|o| String::from_utf8(o.stdout).ok())
            .and_then(|s| s.trim().parse::<f64>().ok())
            .filter(|t| *t > 0.0)
            .unwrap_or(100.0)
    })
}

/// User + system seconds of the children waited for so far, from the text of `/proc/self/stat`.
pub fn children_cpu_from_stat(stat: &str, ticks: f64) -> Option<f64> {
    // The command name (field 2) may hold spaces and parentheses: fields count from the last ')'.
    let rest = stat.get(stat.rfind(')')? + 1..)?;
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // After the name: field 3 (state) is fields[0], so cutime (16) and cstime (17) are 13 and 14.
    let cutime: f64 = fields.get(13)?.parse().ok()?;
    let cstime: f64 = fields.get(14)?.parse().ok()?;
    Some((cutime + cstime) / ticks)
}

/// User + system seconds of this process's waited-for children so far.
fn children_cpu() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    children_cpu_from_stat(&stat, ticks_per_second())
}

/// Runs `cmd` to its end and returns what it cost; a failure (start or exit status) is an error
/// naming `what`.
pub fn run_costed(cmd: &mut Command, what: &str) -> anyhow::Result<Cost> {
    let cpu0 = children_cpu();
    let t0 = Instant::now();
    let status = cmd
        .status()
        .with_context(|| format!("{what}: cannot start it"))?;
    let wall = t0.elapsed().as_secs_f64();
    let cpu1 = children_cpu();
    if !status.success() {
        bail!("{what} failed ({status}): {cmd:?}");
    }
    Ok(Cost {
        wall,
        cpu: cpu0.zip(cpu1).map(|(a, b)| (b - a).max(0.0)),
    })
}

/// The load average over the last minute (`/proc/loadavg`), for the record of a measurement.
pub fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_of_children_from_a_stat_line() {
        // A name with a space and a ')' in it; cutime 250 and cstime 50 ticks at 100 per second.
        let stat = "4242 (x) task) S 1 4242 4242 0 -1 4194304 100 0 0 0 7 3 250 50 20 0 1 0 12345 \
                    1000 100 18446744073709551615";
        assert_eq!(children_cpu_from_stat(stat, 100.0), Some(3.0));
        assert_eq!(children_cpu_from_stat("4242 (x) S 1", 100.0), None);
    }

    #[test]
    fn a_child_that_computes_shows_cpu_time() {
        // `sh` busy for a moment: some CPU time, never more than its wall time on two cores.
        let Some(_) = children_cpu() else {
            return; // not Linux: nothing to check
        };
        let mut cmd = Command::new("sh");
        cmd.args(["-c", "i=0; while [ $i -lt 200000 ]; do i=$((i+1)); done"]);
        let c = run_costed(&mut cmd, "sh").unwrap();
        let cpu = c.cpu.unwrap();
        assert!(cpu > 0.0 && cpu <= 2.0 * c.wall + 0.02, "{c:?}");
    }
}
