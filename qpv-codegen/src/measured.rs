//! Parameters computed from a measured output (`param p = y1`) in the
//! generated code: the step functions take y and the other parameters
//! only, and compute the full θ from them, from the measurement as
//! deployed (so θ is the noisy y, as it is in the plant the observer runs
//! on). The plant, `mu` and `gain` functions keep the full θ.

use qpv_dsl::Model;
use std::fmt::Write;

/// For every parameter in declaration order: `Ok(output)` for one computed
/// from the output `output`, `Err(j)` for the j-th parameter the caller
/// gives.
pub fn sources(m: &Model) -> Vec<Result<usize, usize>> {
    let mut j = 0;
    m.params
        .iter()
        .map(|p| match &p.measured {
            Some(meas) => Ok(meas.output),
            None => {
                j += 1;
                Err(j - 1)
            }
        })
        .collect()
}

/// Whether some parameter is computed from an output.
pub fn any(m: &Model) -> bool {
    m.params.iter().any(|p| p.measured.is_some())
}

/// How many parameters the caller gives (the others come from y).
pub fn given(m: &Model) -> usize {
    m.params.iter().filter(|p| p.measured.is_none()).count()
}

/// The C header's macro and comment for the step functions' θ.
pub fn c_header(m: &Model, up: &str) -> String {
    if !any(m) {
        return String::new();
    }
    let mut s = format!(
        "#define {up}_NTHETA_IN {} /* parameters the step functions take (theta may be NULL when 0); the others are computed from y */\n",
        given(m)
    );
    s.push_str("/* Computed from the measurement by the step functions (from y as given):");
    for p in &m.params {
        if let Some(meas) = &p.measured {
            let _ = write!(s, " {} = {};", p.name, meas.output_name);
        }
    }
    s.push_str(" */\n");
    s
}

/// `static void <name>_theta_of(y, theta, t)`: the full θ from y and the
/// caller's parameters.
pub fn c_theta_of(m: &Model, name: &str, real: &str) -> String {
    if !any(m) {
        return String::new();
    }
    let mut body = String::new();
    for (i, src) in sources(m).iter().enumerate() {
        let _ = match src {
            Ok(k) => writeln!(body, "    t[{i}] = y[{k}];"),
            Err(j) => writeln!(body, "    t[{i}] = theta[{j}];"),
        };
    }
    let unused = if given(m) == 0 {
        "    (void)theta;\n"
    } else {
        ""
    };
    format!(
        "/* The full θ of a step: the parameters computed from the measurement y, and the caller's. */\n\
         static void {name}_theta_of(const {real} *y, const {real} *theta, {real} *t) {{\n{unused}{body}}}\n\n"
    )
}

/// The step functions' source with their schedule taken at the θ computed
/// from y (`<name>_theta_of`): `src` as printed for a model without such
/// parameters.
pub fn c_steps(m: &Model, name: &str, real: &str, src: &str) -> String {
    if !any(m) {
        return src.to_string();
    }
    let n = m.ntheta();
    let full = format!("    {real} tf[{n}];\n    {name}_theta_of(y, theta, tf);\n");
    src.replace(
        &format!("    const int clamped = {name}_schedule(theta, &c, g);\n"),
        &format!("{full}    const int clamped = {name}_schedule(tf, &c, g);\n"),
    )
    .replace(
        &format!("    (void){name}_schedule(theta, &c, g);\n"),
        &format!("{full}    (void){name}_schedule(tf, &c, g);\n"),
    )
}

/// The header's API documentation with the step functions' θ described
/// as the caller's parameters only (`api` as printed without them).
pub fn c_api_docs(m: &Model, api: &str) -> String {
    if !any(m) {
        return api.to_string();
    }
    api.replace(
        "θ (NTHETA)",
        "θ (NTHETA_IN: the parameters not computed from y)",
    )
    .replace(
        "θ_k (NTHETA)",
        "θ_k (NTHETA_IN: the parameters not computed from y)",
    )
}
