//! A cache of solved designs, so an unchanged `qpv!` block does not re-run
//! the SDP search on every build.
//!
//! * Key: the normalised polytopic model (every number printed exactly), the
//!   request (α, γ, mode, ... — not its position in the file) and the solver
//!   settings, each in its serde form, and the versions of qpv-macros, qpv-dsl
//!   and qpv-solve. The file name is a 64-bit FNV-1a hash of the key; the
//!   full key is stored in the file and compared on load, so a hash
//!   collision is a miss, never a wrong hit.
//! * Value: the [`Design`] itself, as its JSON (`Design::to_json`), what
//!   `qpv design --json` writes and `qpv check` reads.
//! * Location: `$QPV_CACHE_DIR` if set; else `$CARGO_TARGET_DIR/qpv-cache`;
//!   else `target/qpv-cache` in the nearest ancestor of the calling crate's
//!   directory that holds a `Cargo.lock` (the workspace root). `QPV_CACHE=off`
//!   disables the cache. `cargo clean` empties it.
//! * Only certified designs are stored, and a hit is never trusted: the
//!   caller re-checks it through `qpv_solve::export::Baked::claimed`
//!   (`Design::recheck`: the state bound, output route, skew and cube
//!   slacks and sample period it carries, milliseconds) and solves again if
//!   it does not pass.
//! * Writes go to a temporary file renamed into place, so concurrent rustc
//!   processes never see a half-written entry. Any I/O problem is a miss.

use qpv_dsl::{DesignRequest, PolytopicModel};
use qpv_solve::{Design, Settings};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

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
        // `{:?}` of an f64 is its shortest round-tripping decimal.
        let _ = write!(s, " {v:?}");
    }
    s.push('\n');
}

/// One line `label <JSON>` of the key.
fn push_json(s: &mut String, label: &str, value: &impl serde::Serialize) {
    let json = serde_json::to_string(value).unwrap_or_else(|e| format!("unserialisable: {e}"));
    let _ = writeln!(s, "{label} {json}");
}

/// The cache key: everything that determines the solver's answer, normalised
/// (positions and formatting of the source do not matter).
pub fn key(model: &PolytopicModel, request: &DesignRequest, settings: &Settings) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "qpv-cache v2 macros {}", env!("CARGO_PKG_VERSION"));
    push_json(&mut s, "settings", settings);
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
    push_json(&mut s, "scheduling", &model.scheduling);
    for d in &model.derived {
        push_json(&mut s, "derived", &(&d.text, d.lo, d.hi));
    }
    if let Some(c) = &model.cover {
        for a in &c.axes {
            let _ = writeln!(s, "cover {}", a.param);
            push_nums(&mut s, "breaks", &a.breaks);
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
    push_json(&mut s, "Q", &model.state_bound);
    // The noise channels change the noise-optimal design and the baked figures.
    push_json(&mut s, "noise", &model.noise);
    let request = DesignRequest {
        span: Default::default(),
        ..request.clone()
    };
    push_json(&mut s, "request", &request);
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

/// Looks a key up; any problem (absent, unreadable, different key, not a
/// design) is a miss. The design is a claim for the caller to re-check.
pub fn load(dir: &Path, key: &str) -> Option<Design> {
    let text = std::fs::read_to_string(file_for(dir, key)).ok()?;
    let (stored_key, body) = text.split_once("---\n")?;
    if stored_key != key {
        return None;
    }
    Design::from_json(body).ok()
}

/// Stores a certified design; failures are ignored (the cache is an
/// optimisation).
pub fn store(dir: &Path, key: &str, design: &Design) {
    if std::fs::create_dir_all(dir).is_err() {
        return;
    }
    let mut s = String::from(key);
    s.push_str("---\n");
    s.push_str(&design.to_json());
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
        let mut d = Design::claimed(
            "t",
            qpv_dsl::Mode::Sound,
            10.0,
            0.1889,
            vec![vec![1.0, 0.1], vec![0.1, 2.0]],
            vec![
                vec![vec![0.1], vec![-3.5e-7]],
                vec![vec![1.0 / 3.0], vec![4.0]],
            ],
        );
        d.verdict = qpv_solve::vocab::Verdict::Certified;
        d.skew = Some(vec![vec![vec![vec![0.0, 0.25], vec![-0.25, 0.0]]]]);
        store(&dir, "some key\n", &d);
        assert_eq!(load(&dir, "some key\n"), Some(d.clone()));
        assert_eq!(load(&dir, "another key\n"), None);
        let file = file_for(&dir, "some key\n");
        let text = std::fs::read_to_string(&file).expect("written");
        assert!(text.starts_with("some key\n---\n{"), "{text}");
        // the full key is compared: a file under the same name for another key is a miss
        std::fs::write(&file, text.replacen("some key", "some kez", 1)).expect("rewrite");
        assert_eq!(load(&dir, "some key\n"), None);
        // a damaged design is a miss
        std::fs::write(&file, "some key\n---\n{\"model\": ").expect("rewrite");
        assert_eq!(load(&dir, "some key\n"), None);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_key_has_the_settings_in_their_serde_form() {
        let models = qpv_dsl::parse(
            "model t { state x; output y; A = [-1]; N1 = 0; C = [1]; M1 = 0; region box(1);
             state_bound Q = [0.1]; design { alpha = 0.5; gamma = 0.5; } }",
        )
        .expect("parses");
        let poly = models[0].polytopic();
        let req = &poly.designs[0];
        let settings = Settings::default();
        let k = key(&poly, req, &settings);
        assert!(k.contains("\nsettings {\"margin_rel\":"), "{k}");
        let tighter = Settings {
            margin_rel: 1e-4,
            ..settings.clone()
        };
        assert_ne!(k, key(&poly, req, &tighter));
        // the request's position in the file is not part of the key
        let moved = DesignRequest {
            span: qpv_dsl::diagnostic::Span { start: 7, end: 9 },
            ..req.clone()
        };
        assert_eq!(k, key(&poly, &moved, &settings));
    }
}
