//! The build-time hint for a slow, unoptimised solve.
//!
//! `qpv!` solves its designs inside rustc, in this crate's code and its
//! dependencies' as compiled for the host. Cargo builds those without
//! optimisation unless the profile's `build-override` says otherwise (a
//! `--release` build included), and then an expansion is about 15 times
//! slower. When that happens and the solves of one expansion took long, the
//! expansion carries one warning naming the profile settings that fix it.
//!
//! Proc-macro diagnostics are unstable, so the warning is a deprecated item
//! used by the generated code: stable rustc reports the deprecation note.

use proc_macro2::TokenStream;
use quote::quote;
use std::time::Duration;

/// Solving time of one expansion above which an unoptimised macro warns.
pub const THRESHOLD: Duration = Duration::from_secs(1);

/// The optimisation level this crate was compiled with (`OPT_LEVEL` as
/// cargo gave it to the build script; empty if unknown).
const OPT_LEVEL: &str = env!("QPV_MACROS_OPT_LEVEL");

/// True unless this crate was compiled with `opt-level = 0` (an unknown
/// level counts as optimised: no warning without evidence).
pub fn macro_is_optimised() -> bool {
    is_optimised(OPT_LEVEL)
}

/// Whether a cargo `OPT_LEVEL` value (`0`..`3`, `s`, `z`) optimises.
fn is_optimised(level: &str) -> bool {
    level.trim() != "0"
}

/// Whether an expansion that spent `solving` in the solver warns, for a
/// macro built with (`optimised`) or without optimisation.
pub fn should_warn(optimised: bool, solving: Duration) -> bool {
    !optimised && solving > THRESHOLD
}

/// The warning's text for an expansion that spent `solving` in the solver.
pub fn message(solving: Duration) -> String {
    format!(
        "qpv!: this expansion spent {:.1} s solving inside rustc with qpv-macros built \
         without optimisation (about 15 times slower than optimised). Build proc-macros \
         optimised: add `[profile.dev.build-override] opt-level = 3` and \
         `[profile.release.build-override] opt-level = 3` to the workspace's Cargo.toml",
        solving.as_secs_f64()
    )
}

/// One compile-time warning carrying `message(solving)`: the use of a
/// deprecated unit struct inside an anonymous constant (nothing is added to
/// the caller's namespace, nothing runs).
pub fn warning(solving: Duration) -> TokenStream {
    let note = message(solving);
    quote! {
        const _: () = {
            #[deprecated(note = #note)]
            #[allow(non_camel_case_types)]
            struct qpv_solved_by_an_unoptimised_macro;
            let _ = qpv_solved_by_an_unoptimised_macro;
        };
    }
}

/// The warning if this macro is unoptimised and the expansion's solves
/// took longer than [`THRESHOLD`]; nothing otherwise, or when
/// `QPV_SLOW_SOLVE_WARNING=off` (for builds that are unoptimised on purpose,
/// such as the UI tests, whose expected output must not depend on speed).
pub fn warning_if_slow(solving: Duration) -> TokenStream {
    let silenced = std::env::var_os("QPV_SLOW_SOLVE_WARNING").is_some_and(|v| v == "off");
    if !silenced && should_warn(macro_is_optimised(), solving) {
        warning(solving)
    } else {
        TokenStream::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_slow_solve_in_an_unoptimised_macro_warns() {
        let slow = THRESHOLD + Duration::from_millis(1);
        let fast = THRESHOLD / 2;
        assert!(should_warn(false, slow));
        assert!(!should_warn(false, fast));
        assert!(
            !should_warn(false, THRESHOLD),
            "the threshold itself is fine"
        );
        assert!(!should_warn(true, slow), "optimised: never");
        assert!(!should_warn(true, Duration::from_secs(3600)));
    }

    #[test]
    fn opt_levels_are_read_as_cargo_writes_them() {
        assert!(!is_optimised("0"));
        for level in ["1", "2", "3", "s", "z", ""] {
            assert!(is_optimised(level), "{level:?}");
        }
        // The build script ran and recorded a level for this very crate.
        assert!(
            ["0", "1", "2", "3", "s", "z"].contains(&OPT_LEVEL),
            "{OPT_LEVEL:?}"
        );
    }

    #[test]
    fn the_warning_names_both_profile_settings_once() {
        let text = message(Duration::from_millis(2400));
        assert!(text.contains("2.4 s"), "{text}");
        assert!(text.contains("[profile.dev.build-override] opt-level = 3"));
        assert!(text.contains("[profile.release.build-override] opt-level = 3"));
        let tokens = warning(Duration::from_millis(2400)).to_string();
        assert_eq!(tokens.matches("deprecated").count(), 1, "{tokens}");
        assert!(tokens.contains("release.build-override"), "{tokens}");
        // the generated item parses as Rust
        assert!(syn::parse_str::<syn::File>(&tokens).is_ok(), "{tokens}");
        assert!(warning_if_slow(Duration::ZERO).is_empty());
    }
}
