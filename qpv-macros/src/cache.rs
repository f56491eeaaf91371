//! A cache of solved designs, so an unchanged `qpv!` block does not re-run
//! the SDP search on every build.
//!
//! * Key: the normalised polytopic model (every number printed exactly), the
//!   request (α, γ, mode — not its position in the file), the solver
//!   settings and the versions of qpv-macros, qpv-dsl and qpv-solve. The file
//!   name is a 64-bit FNV-1a hash of the key; the full key is stored in the
//!   file and compared on load, so a hash collision is a miss, never a wrong hit.
//! * Location: `$QPV_CACHE_DIR` if set; else `$CARGO_TARGET_DIR/qpv-cache`;
//!   else `target/qpv-cache` in the nearest ancestor of the calling crate's
//!   directory that holds a `Cargo.lock` (the workspace root). `QPV_CACHE=off`
//!   disables the cache. `cargo clean` empties it.
//! * Only certified designs are stored, and a hit is never trusted blindly:
//!   the caller re-runs the independent certificate on the cached P and L_l
//!   (milliseconds) and re-solves if it does not pass. For `state_bound
//!   auto` the computed Q is stored too and re-checked (invariance, region
//!   inside F, F inside the box) before it is used; otherwise it is
//!   recomputed. A `conditions = cube` design is stored with its slack
//!   matrices (Y, X, D) and re-certified by them, as the search certified
//!   it; an entry without them (written before they were stored) is
//!   re-certified on the full vertex family, which the slacks imply.
//! * Writes go to a temporary file renamed into place, so concurrent rustc
//!   processes never see a half-written entry. Any I/O problem is a miss.

use qpv_dsl::{DesignRequest, PolytopicModel};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The cached numbers of one certified design.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// For `state_bound auto`: the computed bound, re-checked on load by the caller.
    pub bound: Option<Bound>,
    /// Certified α.
    pub alpha: f64,
    /// Certified γ.
    pub gamma: f64,
    /// Solver status name of the accepted solve.
    pub status: String,
    /// Solver iterations of the accepted solve.
    pub iterations: u32,
    /// P, nx × nx row-major.
    pub p: Vec<f64>,
    /// L_l per vertex, nx × ny row-major.
    pub l: Vec<Vec<f64>>,
    /// `split = skew_slack`: the slack K_{k,l}, per vertex, per k, row-major
    /// (empty without one); re-applied before the re-certification.
    pub skew: Vec<f64>,
    /// `conditions = cube`: the slacks the design was certified with.
    pub cube: Option<Cube>,
}

/// The slacks of a `conditions = cube` design, flattened: Y_{c,k} and
/// X_{c,k} per rate combination c, per generator k, each matrix row-major;
/// the diagonal of D. The caller reshapes them (r = `d.len()` generators,
/// nz × nz matrices) and the certificate checks that they fit the model.
#[derive(Debug, Clone, PartialEq)]
pub struct Cube {
    /// Y_{c,k}, flattened.
    pub y: Vec<f64>,
    /// X_{c,k}, flattened like `y`.
    pub x: Vec<f64>,
    /// The diagonal of D.
    pub d: Vec<f64>,
}

/// A computed `state_bound auto` result.
#[derive(Debug, Clone, PartialEq)]
pub struct Bound {
    /// Box size h of the bound.
    pub h: f64,
    /// Whether the invariance check used the symmetric split of N_k.
    pub symmetric: bool,
    /// Q, nx × nx row-major.
    pub q: Vec<f64>,
}

/// 64-bit FNV-1a: small, stable across Rust versions (unlike `DefaultHasher`).
fn fnv1a(text: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

fn push_nums<'a>(s: &mut String, label: &str, it: impl IntoIterator<Item = &'a f64>) {
    s.push_str(label);
    for v in it {
        let _ = write!(s, " {v:?}");
    }
    s.push('\n');
}

/// The cache key: everything that determines the solver's answer, normalised
/// (positions and formatting of the source do not matter).
pub fn key(model: &PolytopicModel, request: &DesignRequest, settings: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "qpv-cache v1 macros {} settings {settings}",
        env!("CARGO_PKG_VERSION")
    );
    let _ = writeln!(
        s,
        "dims nx {} ny {} nu {} ntheta {}",
        model.nx(),
        model.ny(),
        model.nu(),
        model.ntheta()
    );
    for p in &model.params {
        let _ = writeln!(s, "param {:?} {:?}", p.lo, p.hi);
    }
    let _ = writeln!(s, "scheduling {:?}", model.scheduling);
    for d in &model.derived {
        let _ = writeln!(s, "derived {:?} {:?} {:?}", d.text, d.lo, d.hi);
    }
    if let Some(c) = &model.cover {
        for a in &c.axes {
            let _ = writeln!(s, "cover {} {:?}", a.param, a.breaks);
        }
    }
    for v in &model.vertices {
        push_nums(&mut s, "theta", &v.theta);
        push_nums(&mut s, "A", v.a.iter());
        for n in &v.n {
            push_nums(&mut s, "N", n.iter());
        }
        push_nums(&mut s, "B", v.b.iter());
        push_nums(&mut s, "C", v.c.iter());
        for m in &v.m {
            push_nums(&mut s, "M", m.iter());
        }
    }
    for v in &model.region.vertices {
        push_nums(&mut s, "rv", v.iter());
    }
    for f in &model.region.facets {
        push_nums(&mut s, "rf", f.iter());
    }
    // Debug prints every f64 exactly (shortest round-trip form).
    let _ = writeln!(s, "Q {:?}", model.state_bound);
    // The noise channels change the noise-optimal design and the baked figures.
    let _ = writeln!(s, "noise {:?}", model.noise);
    let request = DesignRequest {
        span: Default::default(),
        ..request.clone()
    };
    let _ = writeln!(s, "request {request:?}");
    s
}

/// The cache directory, or `None` if caching is off or no place was found.
pub fn dir() -> Option<PathBuf> {
    if std::env::var("QPV_CACHE").is_ok_and(|v| v == "off" || v == "0") {
        return None;
    }
    if let Some(d) = std::env::var_os("QPV_CACHE_DIR") {
        return Some(PathBuf::from(d));
    }
    if let Some(d) = std::env::var_os("CARGO_TARGET_DIR") {
        let d = PathBuf::from(d);
        let d = if d.is_relative() {
            std::env::current_dir().ok()?.join(d)
        } else {
            d
        };
        return Some(d.join("qpv-cache"));
    }
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR")?);
    manifest
        .ancestors()
        .find(|a| a.join("Cargo.lock").is_file())
        .map(|root| root.join("target").join("qpv-cache"))
}

/// The file holding `key` in `dir`.
pub fn file_for(dir: &Path, key: &str) -> PathBuf {
    dir.join(format!("{:016x}.design", fnv1a(key)))
}

/// Looks a key up; any problem (absent, unreadable, different key, bad
/// numbers) is a miss.
pub fn load(dir: &Path, key: &str) -> Option<Entry> {
    let text = std::fs::read_to_string(file_for(dir, key)).ok()?;
    let (stored_key, body) = text.split_once("---\n")?;
    if stored_key != key {
        return None;
    }
    let mut e = Entry {
        bound: None,
        alpha: f64::NAN,
        gamma: f64::NAN,
        status: String::new(),
        iterations: 0,
        p: Vec::new(),
        l: Vec::new(),
        skew: Vec::new(),
        cube: None,
    };
    let (mut y, mut x, mut d) = (None, None, None);
    let nums = |rest: &str| -> Option<Vec<f64>> {
        rest.split_whitespace()
            .map(|t| t.parse::<f64>().ok())
            .collect()
    };
    for line in body.lines() {
        let (tag, rest) = line.split_once(' ').unwrap_or((line, ""));
        match tag {
            "alpha" => e.alpha = rest.trim().parse().ok()?,
            "gamma" => e.gamma = rest.trim().parse().ok()?,
            "status" => e.status = rest.to_string(),
            "iterations" => e.iterations = rest.trim().parse().ok()?,
            "P" => e.p = nums(rest)?,
            "L" => e.l.push(nums(rest)?),
            "K" => e.skew = nums(rest)?,
            "Y" => y = Some(nums(rest)?),
            "X" => x = Some(nums(rest)?),
            "D" => d = Some(nums(rest)?),
            "Q" => {
                let v = nums(rest)?;
                let (h, rest) = v.split_first()?;
                let (sym, q) = rest.split_first()?;
                e.bound = Some(Bound {
                    h: *h,
                    symmetric: *sym == 1.0,
                    q: q.to_vec(),
                });
            }
            _ => return None,
        }
    }
    e.cube = match (y, x, d) {
        (Some(y), Some(x), Some(d)) => Some(Cube { y, x, d }),
        (None, None, None) => None,
        // some slacks without the others: a damaged entry
        _ => return None,
    };
    let cube_nums = e
        .cube
        .iter()
        .flat_map(|c| c.y.iter().chain(&c.x).chain(&c.d));
    let finite = e.alpha.is_finite()
        && e.gamma.is_finite()
        && e.p
            .iter()
            .chain(e.l.iter().flatten())
            .chain(&e.skew)
            .chain(cube_nums)
            .all(|v| v.is_finite());
    (finite && !e.p.is_empty() && !e.l.is_empty()).then_some(e)
}

/// Stores an entry; failures are ignored (the cache is an optimisation).
pub fn store(dir: &Path, key: &str, e: &Entry) {
    if std::fs::create_dir_all(dir).is_err() {
        return;
    }
    let mut s = String::from(key);
    s.push_str("---\n");
    let _ = writeln!(s, "alpha {:?}", e.alpha);
    let _ = writeln!(s, "gamma {:?}", e.gamma);
    let _ = writeln!(s, "status {}", e.status.replace('\n', " "));
    let _ = writeln!(s, "iterations {}", e.iterations);
    push_nums(&mut s, "P", &e.p);
    for l in &e.l {
        push_nums(&mut s, "L", l);
    }
    if !e.skew.is_empty() {
        push_nums(&mut s, "K", &e.skew);
    }
    if let Some(c) = &e.cube {
        push_nums(&mut s, "Y", &c.y);
        push_nums(&mut s, "X", &c.x);
        push_nums(&mut s, "D", &c.d);
    }
    if let Some(b) = &e.bound {
        let sym = if b.symmetric { 1.0 } else { 0.0 };
        push_nums(&mut s, "Q", [b.h, sym].iter().chain(&b.q));
    }
    let path = file_for(dir, key);
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    if std::fs::write(&tmp, s).is_ok() && std::fs::rename(&tmp, &path).is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv_is_stable() {
        assert_eq!(fnv1a(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a("a"), 0xaf63_dc4c_8601_ec8c);
    }

    #[test]
    fn round_trip_through_a_directory() {
        let dir = std::env::temp_dir().join(format!("qpv-cache-test-{}", std::process::id()));
        let e = Entry {
            bound: Some(Bound {
                h: 0.08,
                symmetric: true,
                q: vec![0.01, 0.0, 0.0, 0.02],
            }),
            alpha: 10.0,
            gamma: 0.1889,
            status: "Solved".into(),
            iterations: 23,
            p: vec![1.0, 0.1, 0.1, 2.0],
            l: vec![vec![0.1, -3.5e-7], vec![1.0 / 3.0, 4.0]],
            skew: vec![0.0, 0.25, -0.25, 0.0],
            cube: None,
        };
        store(&dir, "some key\n", &e);
        assert_eq!(load(&dir, "some key\n"), Some(e.clone()));
        assert_eq!(load(&dir, "another key\n"), None);

        // With cube slacks (two generators, one rate combination, 2 × 2).
        let cube = Cube {
            y: vec![0.5, 0.1, 0.1, 0.25, 1e-9, 0.0, 0.0, 2.0],
            x: vec![-0.5, 0.0, 0.0, -1.0 / 3.0, 3.0, 1.5, 1.5, 4.0],
            d: vec![0.125, 7.0],
        };
        let with_cube = Entry {
            cube: Some(cube),
            ..e.clone()
        };
        store(&dir, "cube key\n", &with_cube);
        let text = std::fs::read_to_string(file_for(&dir, "cube key\n")).expect("written");
        assert!(text.contains("\nY 0.5 0.1") && text.contains("\nD 0.125 7.0\n"));
        assert_eq!(load(&dir, "cube key\n"), Some(with_cube));

        // An entry written before slacks were stored (no Y, X, D lines)
        // loads without them; one with only some of them is a miss.
        let old: String = text
            .lines()
            .filter(|l| !["Y ", "X ", "D "].iter().any(|t| l.starts_with(t)))
            .map(|l| format!("{l}\n"))
            .collect();
        std::fs::write(file_for(&dir, "cube key\n"), &old).expect("rewrite");
        assert_eq!(load(&dir, "cube key\n"), Some(e));
        let partial: String = text
            .lines()
            .filter(|l| !l.starts_with("X "))
            .map(|l| format!("{l}\n"))
            .collect();
        std::fs::write(file_for(&dir, "cube key\n"), &partial).expect("rewrite");
        assert_eq!(load(&dir, "cube key\n"), None);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
