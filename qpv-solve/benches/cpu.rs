//! The process's CPU time, shared by the benches that print it beside the
//! wall time (a module of each, by `#[path]`; not a bench of its own).

/// CPU time (user + system) of this process so far, in seconds: utime and
/// stime of /proc/self/stat (fields 14 and 15 of the line, after the
/// command name in parentheses), in clock ticks of 1/100 s; NaN where
/// /proc is not available.
pub fn cpu_seconds() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let rest = s.rsplit_once(')').map_or("", |(_, r)| r);
    // rest's first field is field 3 (the state), so field k is f[k - 3]
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| {
        f.get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(f64::NAN)
    };
    (tick(11) + tick(12)) / 100.0
}
