//! Regenerates the figures the docs quote (`docs/numbers.txt`) with a
//! `qpv` binary and compares them with the text, or rewrites the text.
//!
//!     cargo run --release --example doc_numbers -- [--bin target/release/qpv] [--cheap] [--write]
//!
//! `scripts/doc-numbers.sh` builds the release binary and runs this. Each
//! record's command runs once (records that share a command share the
//! run). Without `--write` it prints every figure, quoted and fresh, and
//! exits 1 when one is off by more than its stated precision (wall times,
//! `precision = any`, are printed, never compared); with `--write` it
//! replaces each quoted figure by the fresh one, written with as many
//! digits. The same for docs/cli.md's synopsis, generated from the
//! binary's `--help`. `cargo test --workspace` re-runs the cheap records
//! and compares the synopsis (`tests/cli_docs.rs`).

#[path = "../tests/common/doc_numbers.rs"]
mod doc_numbers;

use doc_numbers::{Cost, Precision};
use std::path::{Path, PathBuf};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let bin = args
        .iter()
        .position(|a| a == "--bin")
        .and_then(|i| args.get(i + 1))
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target/release/qpv"));
    let cheap = args.iter().any(|a| a == "--cheap");
    let write = args.iter().any(|a| a == "--write");
    let all = doc_numbers::records(root).unwrap_or_else(|e| fail(&e));
    let chosen: Vec<_> = all
        .iter()
        .filter(|r| !cheap || r.cost == Cost::Cheap)
        .collect();
    let scratch = std::env::temp_dir().join(format!("qpv-doc-numbers-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).unwrap_or_else(|e| fail(&e.to_string()));
    eprintln!(
        "{} figures, {} commands, with {}",
        chosen.len(),
        {
            let mut c: Vec<&str> = chosen.iter().map(|r| r.run.as_str()).collect();
            c.sort();
            c.dedup();
            c.len()
        },
        bin.display()
    );
    let results = doc_numbers::check(&bin, root, &chosen, &scratch);
    let _ = std::fs::remove_dir_all(&scratch);
    let mut bad = 0;
    let mut edits: Vec<(String, std::ops::Range<usize>, String)> = Vec::new();
    for (r, res) in &results {
        match res {
            Ok(c) => {
                let fresh = doc_numbers::format_like(&c.quoted, c.fresh);
                let mark = if r.precision == Precision::Any {
                    "time"
                } else if c.agrees {
                    "ok"
                } else {
                    bad += 1;
                    "DRIFT"
                };
                println!(
                    "{mark:<5} {:<28} {}: quoted {}, fresh {fresh} ({:.6e})",
                    r.name, r.doc, c.quoted, c.fresh
                );
                if write && fresh != c.quoted {
                    edits.push((r.doc.clone(), c.range.clone(), fresh));
                }
            }
            Err(e) => {
                bad += 1;
                println!("ERROR {:<28} {e}", r.name);
            }
        }
    }
    // docs/cli.md's synopsis, from the binary's help
    let synopsis = doc_numbers::synopsis(&bin).unwrap_or_else(|e| fail(&e));
    let (quoted, range) = doc_numbers::quoted_synopsis(root).unwrap_or_else(|e| fail(&e));
    if quoted != synopsis {
        if write {
            edits.push((
                "docs/cli.md".into(),
                range,
                doc_numbers::synopsis_block(&synopsis),
            ));
        } else {
            bad += 1;
            println!("DRIFT docs/cli.md's synopsis differs from `qpv COMMAND --help`:\n{synopsis}");
        }
    } else {
        println!("ok    synopsis                     docs/cli.md");
    }
    if write {
        // From the end of each file, so that the earlier ranges stay valid.
        edits.sort_by(|a, b| (&a.0, b.1.start).cmp(&(&b.0, a.1.start)));
        for (doc, range, text) in &edits {
            let path = root.join(doc);
            let mut s = std::fs::read_to_string(&path).unwrap_or_else(|e| fail(&e.to_string()));
            s.replace_range(range.clone(), text);
            std::fs::write(&path, s).unwrap_or_else(|e| fail(&e.to_string()));
        }
        println!("rewrote {} figure(s)", edits.len());
    } else if bad > 0 {
        println!("{bad} figure(s) off by more than their precision (rerun with --write to update)");
        std::process::exit(1);
    }
}

fn fail(e: &str) -> ! {
    eprintln!("error: {e}");
    std::process::exit(2)
}
